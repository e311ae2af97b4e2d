"""What code a result was made with: the package's version and, where it runs from a git
checkout, that checkout's commit and whether tracked files differ from it. Written into a
training run's summary.json, so that a figure made from the run can name its commit."""

from __future__ import annotations

import subprocess
from importlib import metadata
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(
            ["git", "-C", str(_PACKAGE), *args], capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):  # no git, or it hangs
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def code_version() -> dict:
    """{"version", "commit", "modified"}: `commit` None where the package is not in a git
    checkout (an installed wheel); `modified` whether tracked files differ from it (None
    where unknown)."""
    # Only a checkout that tracks this file: a wheel installed in a venv that sits inside some
    # other repository is not that repository's code.
    tracked = _git("ls-files", "--error-unmatch", Path(__file__).name) is not None
    commit = _git("rev-parse", "HEAD") if tracked else None
    status = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    try:
        version = metadata.version("drake-tooluse")
    except metadata.PackageNotFoundError:  # run from a checkout that is not installed
        version = None
    return {
        "version": version,
        "commit": commit,
        "modified": None if status is None else bool(status),
    }
