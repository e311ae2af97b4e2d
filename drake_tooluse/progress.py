"""Progress of long work on stderr: one tqdm bar, the same everywhere.

A bar is drawn only where stderr is a terminal (in a log file its carriage returns would be
fragments) and the caller asked for it; stdout stays for the results."""

from __future__ import annotations

import sys

from tqdm import tqdm


def progress_bar(
    total: int, desc: str, unit: str = "it", enabled: bool = True, initial: int = 0
) -> tqdm:
    """A tqdm bar of `total` `unit`s described by `desc` on stderr (a context manager; its
    `update(n)` advances it), drawn only where `enabled` and stderr is a terminal; it leaves
    no line behind. `initial`: the units done before it starts (not counted in its rate)."""
    return tqdm(
        total=total,
        initial=initial,
        desc=desc,
        unit=unit,
        unit_scale=total >= 100_000,  # "1.25M/17.5M step", not 17 digits
        file=sys.stderr,
        disable=not enabled or not sys.stderr.isatty(),
        leave=False,
    )


def progress_line(text: str) -> None:
    """A line of progress to stderr, above any bar drawn there (stdout stays for results)."""
    with tqdm.external_write_mode(file=sys.stderr):
        print(text, file=sys.stderr, flush=True)
