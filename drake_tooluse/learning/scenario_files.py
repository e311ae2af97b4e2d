"""A scenario kept with a directory by name: how policy directories and run directories store
the env's `env_kwargs.scenario` so that they stay valid wherever they and the package move.

A scenario the package ships (`paths.SCENARIOS_DIR`) is stored by its file name; any other is
written whole into the directory as `scenario.yaml` (its bases merged in, its tool model beside
it) and stored by that name (`scenario_files`). Reading resolves the name against the directory,
then against the package's scenarios, on the machine that reads it (`resolve_scenario`, the
one place such a name becomes a path).
"""

from __future__ import annotations

import dataclasses as dc
import hashlib
from pathlib import Path

from pydrake.common.yaml import yaml_dump_typed

from drake_tooluse.paths import SCENARIOS_DIR
from drake_tooluse.validation import shown
from drake_tooluse.world.scenario import Scenario, load_scenario

SCENARIO = "scenario.yaml"  # the env's scenario, when it is not one the package ships


def shipped_scenarios() -> list[str]:
    """The names of the scenarios the package ships (`paths.SCENARIOS_DIR`)."""
    return sorted(p.name for p in SCENARIOS_DIR.glob("*.yaml"))


def resolve_scenario(name, directory: Path, where: str = "", what: str = "policy") -> str:
    """The file a `what` directory's `env_kwargs.scenario` names: a file name (no folder), of
    a file in `directory` or else of a scenario the package ships; that scenario loads with
    every file it reads inside those two folders (`load_scenario(within=...)`). Returns its
    path; anything else is a ValueError starting with `where`."""
    directory = Path(directory)
    allowed = (
        f"the name of a scenario file in the {what} directory ({SCENARIO}) or of one the "
        f"package ships ({', '.join(shipped_scenarios())})"
    )
    if not isinstance(name, str) or name in ("", ".", "..") or Path(name).name != name:
        raise ValueError(f"{where}env_kwargs.scenario={shown(name)} must be {allowed}")
    path = directory / name if (directory / name).is_file() else SCENARIOS_DIR / name
    if not path.is_file():
        raise ValueError(f"{where}env_kwargs.scenario={name!r} is not {allowed}")
    try:
        load_scenario(path, within=(directory, SCENARIOS_DIR))
    except (OSError, ValueError) as e:
        raise ValueError(f"{where}env_kwargs.scenario={name!r}: {e}") from None
    return str(path.resolve())


def scenario_files(scenario) -> tuple[str, dict]:
    """What a directory holds of the env's scenario (a Scenario, or a YAML file as the env
    reads one): (its `env_kwargs.scenario`, {file name: bytes}). A scenario the package ships
    is named; any other is written whole (its bases merged in, its tool model beside it) as
    `scenario.yaml`."""
    if not isinstance(scenario, Scenario):
        path = Path(scenario).resolve()
        if path.parent == SCENARIOS_DIR.resolve():
            return path.name, {}
        scenario = load_scenario(path)
    files = {}
    model = scenario.tool.model
    if model and not model.startswith("package://"):
        files[Path(model).name] = Path(model).read_bytes()
        scenario = dc.replace(scenario, tool=dc.replace(scenario.tool, model=Path(model).name))
    files[SCENARIO] = yaml_dump_typed(dc.replace(scenario, base=""), schema=Scenario).encode()
    return SCENARIO, files


def scenario_identity(scenario) -> str:
    """What two scenarios must share to be the same one wherever their files lie: a shipped
    scenario's name, or the name and a digest of the files `scenario_files` writes."""
    name, files = scenario_files(scenario)
    if not files:
        return name
    digest = hashlib.sha256()
    for file_name in sorted(files):
        digest.update(file_name.encode() + b"\0" + files[file_name] + b"\0")
    return f"{name} (sha256 {digest.hexdigest()[:16]})"
