"""Every path of the project's shipped data, defined once.

They are found with `importlib.resources`, never relative to a source file: pyproject.toml maps the
repo's `models/` onto the package `drake_tooluse.models` and `diagrams/` onto
`drake_tooluse.scenarios`, so the same lookups find the files inside an installed wheel and in the
checkout of an editable install alike.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

from drake_tooluse.validation import EnvironmentProblem

__all__ = [
    "BAXTER_URDF",
    "BAXTER_URL",
    "DEFAULT_SCENARIO",
    "HYPERPARAMS_DIR",
    "MODELS_DIR",
    "PAPER_STUDY_CELLS",
    "POLICIES_DIR",
    "PULL_SCENARIO",
    "REALITY_SCENARIO",
    "SCENARIOS_DIR",
    "SHIPPED_POLICY",
    "TRANSFER_POLICY",
]


def _package_dir(package: str, *parts: str) -> Path:
    """The folder of `package` (joined with `parts`) as a real filesystem path."""
    try:
        resource = files(package)
    except ModuleNotFoundError as error:
        raise EnvironmentProblem(
            f"drake-tooluse's data package {package!r} is missing ({error}); install the project "
            "with `pip install .` or `pip install -e .` from a checkout"
        ) from error
    for part in parts:
        resource = resource / part
    try:
        return Path(os.fspath(resource))
    except TypeError:
        raise EnvironmentProblem(
            f"drake-tooluse's data {package!r} are not a folder on disk ({resource!r}): Drake "
            "reads them by file name, so install the project unzipped (`pip install .`)"
        ) from None


# Models: Drake's package map reads package.xml, so BAXTER_URL resolves inside this folder.
MODELS_DIR = _package_dir("drake_tooluse.models")
BAXTER_URDF = MODELS_DIR / "baxter" / "baxter.urdf"
BAXTER_URL = "package://drake_tooluse/baxter/baxter.urdf"

POLICIES_DIR = MODELS_DIR / "policies"
SHIPPED_POLICY = POLICIES_DIR / "ppo_toolpush"
# The policy for other tools: it observes the task in tool-tip space only.
TRANSFER_POLICY = POLICIES_DIR / "ppo_toolpush_tip"
# That policy fine-tuned on pushes 0.10 m further (ToolPushFar-v1): tool choice's push-far.
FAR_PUSH_POLICY = POLICIES_DIR / "ppo_toolpush_tip_far"
# One policy for every hook: it pulls a cube from out of reach (ToolPull-v1).
PULL_POLICY = POLICIES_DIR / "ppo_toolpull"

# Scenarios: the repo's diagrams/ (its YAML scenarios beside the rendered block diagrams).
SCENARIOS_DIR = _package_dir("drake_tooluse.scenarios")
DEFAULT_SCENARIO = SCENARIOS_DIR / "push.yaml"
REALITY_SCENARIO = SCENARIOS_DIR / "reality.yaml"
PULL_SCENARIO = SCENARIOS_DIR / "pull.yaml"

HYPERPARAMS_DIR = _package_dir("drake_tooluse", "learning", "hyperparams")

# The paper study's cells (`drake-tooluse study`).
PAPER_STUDY_CELLS = _package_dir("drake_tooluse", "experiments") / "paper_study.yaml"
