"""What every experiment run shares: where a new run directory goes, its progress log, and a
benchmark's results file."""

from __future__ import annotations

import argparse
import platform
import time
from dataclasses import dataclass
from pathlib import Path

from drake_tooluse.files import atomic_write_json
from drake_tooluse.progress import progress_line

RUNS_DIR = Path("runs")  # relative to the working directory, as the docs' commands use it


def new_run_dir(name: str) -> Path:
    """`runs/<name>-<local time>`: the default directory of a run of `name`."""
    return RUNS_DIR / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}"


@dataclass(frozen=True)
class BenchmarkOutput:
    """Where a benchmark script writes its JSON results: by default a new run directory,
    `runs/<name>-<time>/<name>.json`; `--out FILE` there instead; `--update-docs` the checkout's
    tracked `docs/results/<name>.json`, which the docs quote. `<name>` is the script's stem."""

    script: Path  # the script's `__file__`, in the checkout's benchmarks/

    @property
    def name(self) -> str:
        return Path(self.script).stem

    @property
    def docs_dir(self) -> Path:
        """The checkout's docs/, beside the script's benchmarks/."""
        return Path(self.script).resolve().parents[1] / "docs"

    @property
    def docs_file(self) -> Path:
        return self.docs_dir / "results" / f"{self.name}.json"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """`--out FILE | --update-docs`."""
        group = parser.add_mutually_exclusive_group()
        group.add_argument(
            "--out",
            type=Path,
            metavar="FILE",
            help=f"JSON file (default runs/{self.name}-<time>/{self.name}.json)",
        )
        group.add_argument(
            "--update-docs",
            action="store_true",
            help=f"write docs/results/{self.name}.json, which the docs quote",
        )

    def path(self, args: argparse.Namespace) -> Path:
        """The JSON file the parsed `args` ask for."""
        if args.update_docs:
            return self.docs_file
        return args.out or new_run_dir(self.name) / f"{self.name}.json"

    def write(self, path: Path, command: str, **sections) -> None:
        """Writes the results to `path` (atomically): the command that printed them, the
        machine it ran on, then `sections` in the order given."""
        atomic_write_json(path, {"command": command, "machine": platform.platform(), **sections})


def stderr_log(text: str) -> None:
    """A progress line to stderr, above any bar drawn there (stdout stays for the results)."""
    progress_line(text)


def quiet_log(text: str) -> None:
    """No progress lines."""
