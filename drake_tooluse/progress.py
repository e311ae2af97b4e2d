"""Progress of long work on stderr: one tqdm bar, the same everywhere.

A bar is drawn only where stderr is a terminal (in a log file its carriage returns would be
fragments) and the caller asked for it; stdout stays for the results."""

from __future__ import annotations

import sys

from tqdm import tqdm


def progress_bar(total: int, desc: str, unit: str = "it", enabled: bool = True) -> tqdm:
    """A tqdm bar of `total` `unit`s described by `desc` on stderr (a context manager; its
    `update(n)` advances it), drawn only where `enabled` and stderr is a terminal; it leaves
    no line behind."""
    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=sys.stderr,
        disable=not enabled or not sys.stderr.isatty(),
        leave=False,
    )
