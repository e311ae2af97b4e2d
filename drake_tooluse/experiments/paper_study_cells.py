"""What the paper study is, apart from running it (`experiments.paper_study`): its cells, read
from a study file (the paper's: `paper_study.yaml`) and checked, and where its files go. Light
to import (no Drake, no torch): the command line checks its arguments with it before the runner
loads.
"""

from __future__ import annotations

import dataclasses as dc
import re
from pathlib import Path

from drake_tooluse.files import read_yaml
from drake_tooluse.learning.algorithms import ALGOS
from drake_tooluse.limits import MAX_EPISODES, MAX_SEEDS, MAX_TIMESTEPS
from drake_tooluse.paths import PAPER_STUDY_CELLS
from drake_tooluse.tasks.contract import check_serves, declaration
from drake_tooluse.validation import check_int, check_mapping, check_one_of, check_seed, shown

RESULTS_NAME = "paper_study.json"
ARCHIVE_NAME = "paper_study"  # each run's small files: CELL/sSEED/
# Every episode runs to its step limit (the -v1 envs' only protocol). The -v0 envs' "early-end"
# protocol stays at tag figures-v0.
PROTOCOLS = ("to-limit",)
CELL_KEYS = ("env", "algo", "timesteps", "seeds", "hyperparams", "protocol", "init_from")
DEFAULT_OUT = Path("runs") / "study"


@dc.dataclass(frozen=True)
class StudyFiles:
    """Where a study's files go: its results, the runs' archive, the run directories, and the
    report's page and figures."""

    results: Path
    archive: Path
    runs: Path
    page: Path
    figures: Path

    @classmethod
    def under(cls, out: Path, runs: Path | None = None) -> StudyFiles:
        """Everything under `out` (the default: not tracked files)."""
        out = Path(out)
        return cls(
            out / RESULTS_NAME,
            out / ARCHIVE_NAME,
            Path(runs) if runs else out / "runs",
            out / "TRAINING.md",
            out / "figures",
        )

    @classmethod
    def docs(cls, checkout: Path, runs: Path | None = None) -> StudyFiles:
        """A checkout's docs (`--update-docs`): the files the repository tracks, and the run
        directories where the study has always kept them (runs/paper)."""
        checkout = Path(checkout)
        if not (checkout / "pyproject.toml").is_file() or not (checkout / "docs").is_dir():
            raise ValueError(
                f"{str(checkout.absolute())!r} is not a checkout of the project (no "
                "pyproject.toml and docs/ there): run it in the repository's root"
            )
        results = checkout / "docs" / "results"
        return cls(
            results / RESULTS_NAME,
            results / ARCHIVE_NAME,
            Path(runs) if runs else checkout / "runs" / "paper",
            checkout / "docs" / "TRAINING.md",
            checkout / "docs" / "figures",
        )


def load_cells(path=PAPER_STUDY_CELLS) -> tuple[dict, int, int]:
    """A study file's cells, evaluation episodes and evaluation seed, checked (each error names
    the file, the cell and the key)."""
    data = read_yaml(path, "study file")
    where = f"study file {str(path)!r}"
    if not isinstance(data, dict) or not isinstance(data.get("cells"), dict) or not data["cells"]:
        raise ValueError(f"{where} needs `cells:`, a mapping of cell names to specs")
    unknown = sorted(set(data) - {"cells", "episodes", "evaluation_seed"})
    if unknown:
        raise ValueError(
            f"{where}: unknown key(s) {unknown}; allowed: cells, episodes, evaluation_seed"
        )
    episodes = check_int(data.get("episodes", 100), 1, MAX_EPISODES, f"{where}: episodes")
    seed = check_seed(data.get("evaluation_seed", 1000), f"{where}: evaluation_seed", episodes)
    cells = data["cells"]
    for name, c in cells.items():
        at = f"{where}, cell {name!r}"
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
            raise ValueError(f"{at}: a cell's name is a folder name (letters, digits, _ . -)")
        check_mapping(c, at)
        unknown = sorted(set(c) - set(CELL_KEYS))
        missing = [k for k in ("env", "algo", "timesteps", "seeds") if k not in c]
        if unknown or missing:
            raise ValueError(
                f"{at}: "
                + (f"unknown key(s) {unknown}; " if unknown else "")
                + (f"missing {missing}; " if missing else "")
                + f"allowed: {list(CELL_KEYS)}"
            )
        if not isinstance(c["env"], str):
            raise ValueError(f"{at}: env={shown(c['env'])} must be an env id")
        try:  # a registered id of a task (any task's cells run; the report is the paper's)
            declaration(c["env"])
        except ValueError as e:
            raise ValueError(f"{at}: {e}") from None
        check_one_of(c["algo"], ALGOS, f"{at}: algo")
        check_int(c["timesteps"], 1, MAX_TIMESTEPS, f"{at}: timesteps")
        if not isinstance(c["seeds"], list) or not 1 <= len(c["seeds"]) <= MAX_SEEDS:
            raise ValueError(
                f"{at}: seeds={shown(c['seeds'])} must be a list of 1 to {MAX_SEEDS} seeds"
            )
        for s in c["seeds"]:
            check_seed(s, f"{at}: seed")
        if len(set(c["seeds"])) != len(c["seeds"]):
            raise ValueError(f"{at}: seeds={c['seeds']} repeats a seed")
        check_mapping(c.get("hyperparams"), f"{at}: hyperparams")
        if c.get("protocol") == "early-end":
            raise ValueError(
                f"{at}: protocol early-end was the -v0 envs' (tag figures-v0); every episode of "
                "the -v1 envs runs to its step limit: give protocol: to-limit, or none"
            )
        check_one_of(c.get("protocol", "to-limit"), PROTOCOLS, f"{at}: protocol")
        source = c.get("init_from")
        if source is not None and (source not in cells or source == name):
            raise ValueError(f"{at}: init_from={shown(source)} must name another cell")
    return cells, episodes, seed


def check_cell_names(cells: dict, names) -> None:
    """Each of `names` (None: all) is one of the study's cells; else an error naming them."""
    unknown = [c for c in names or [] if c not in cells]
    if unknown:
        raise ValueError(f"unknown cell(s) {unknown}; the study's cells: {list(cells)}")


def unreported(cells: dict) -> str | None:
    """Why `study-report` cannot make the paper's page of `cells` (a cell of a task that does
    not serve it: `tasks.contract.check_serves`), or None where it can."""
    for name, c in cells.items():
        try:
            check_serves(c["env"], "study-report")
        except ValueError as e:
            return f"cell {name!r}: {e}"
    return None
