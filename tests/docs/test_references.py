"""Names in backticks that point into the package (`tasks.deploy.deploy`,
`experiments.tool_choice`) resolve: a docstring, comment or page names no module, function or
option that is gone."""

import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LAYERS = ("builders", "tasks", "experiments", "learning", "robot", "world", "systems")
LAYERS += ("perception", "cli")
NAMES = "|".join(LAYERS)
REFERENCE = re.compile(rf"`((?:drake_tooluse\.)?(?:{NAMES})\.[A-Za-z_][\w.]*)")
# `world.plant`, `robot.conservative_limits`: a World's and a scenario's fields, not modules.
INSTANCE_NAMES = ("world", "robot")


def _module(name: str):
    try:
        return importlib.import_module(f"drake_tooluse.{name}")
    except ImportError:
        return None


def resolves(reference: str) -> bool:
    """Whether `reference` (a dotted name below the package) names something that exists; a
    `world.`/`robot.` name that is no module's is taken as an instance's field."""
    parts = reference.removeprefix("drake_tooluse.").rstrip(".").split(".")
    for i in range(len(parts), 0, -1):
        obj = _module(".".join(parts[:i]))
        if obj is None:
            continue
        if i == 1 and parts[0] in INSTANCE_NAMES:
            return True
        for part in parts[i:]:
            if not hasattr(obj, part):
                return False
            obj = getattr(obj, part)
        return True
    return False


def test_every_reference_into_the_package_resolves():
    files = [*(ROOT / "drake_tooluse").rglob("*.py"), *(ROOT / "tests").rglob("*.py")]
    files += [*(ROOT / "docs").rglob("*.md"), ROOT / "README.md"]
    stale = {}
    for path in files:
        for match in REFERENCE.finditer(path.read_text()):
            if not resolves(match[1]):
                stale.setdefault(str(path.relative_to(ROOT)), set()).add(match[1])
    assert not stale, f"names of things that are gone: {stale}"


def test_the_check_finds_a_name_that_is_gone():
    assert resolves("tasks.deploy.deploy") and resolves("experiments.tool_choice")
    assert resolves("world.plant")  # a World's field
    assert not resolves("tasks.push.diagram.build_policy_diagram")
    assert not resolves("learning.distill") and not resolves("tasks.pull.run.run_pull")
