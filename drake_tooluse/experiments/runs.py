"""What every experiment run shares: where a new run directory goes, and its progress log."""

from __future__ import annotations

import sys
import time
from pathlib import Path

RUNS_DIR = Path("runs")  # relative to the working directory, as the README's commands use it


def new_run_dir(name: str) -> Path:
    """`runs/<name>-<local time>`: the default directory of a run of `name`."""
    return RUNS_DIR / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}"


def stderr_log(text: str) -> None:
    """A progress line to stderr (stdout stays for the results)."""
    print(text, file=sys.stderr, flush=True)


def quiet_log(text: str) -> None:
    """No progress lines."""
