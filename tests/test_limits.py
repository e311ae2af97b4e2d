"""Each range declared once (`drake_tooluse.limits`): no module declares a limit of its own under
a name that module holds, and no literal bound of a count check appears in two modules."""

import ast
from collections import defaultdict
from pathlib import Path

from drake_tooluse import limits

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted((ROOT / "drake_tooluse").rglob("*.py")) + sorted(
    (ROOT / "benchmarks").glob("*.py")
)
# The count checks, and where each takes its upper bound: check_int(value, lo, hi, name),
# count_arg(value, option, lo, hi).
UPPER_BOUND_AT = {"check_int": 2, "count_arg": 3}


def _redeclared(tree: ast.AST) -> list[str]:
    """The module-level names assigned in `tree` that `limits` declares."""
    names = {n for n in vars(limits) if n.isupper()}
    return [
        t.id
        for node in tree.body
        if isinstance(node, ast.Assign)
        for t in node.targets
        if isinstance(t, ast.Name) and t.id in names
    ]


def _literal_bounds(tree: ast.AST) -> set:
    """The literal upper bounds (integers ≥ 10) of the count checks called in `tree`."""
    bounds = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = getattr(node.func, "id", getattr(node.func, "attr", None))
        at = UPPER_BOUND_AT.get(name)
        if at is not None and len(node.args) > at:
            hi = node.args[at]
            if isinstance(hi, ast.Constant) and type(hi.value) is int and hi.value >= 10:
                bounds.add(hi.value)
    return bounds


def test_no_module_declares_a_limit_again():
    found = {}
    for path in SOURCES:
        if path.name != "limits.py":
            names = _redeclared(ast.parse(path.read_text()))
            if names:
                found[str(path.relative_to(ROOT))] = names
    assert not found, f"declared in drake_tooluse/limits.py; import it from there: {found}"


def test_no_literal_bound_is_written_in_two_modules():
    where = defaultdict(set)
    for path in SOURCES:
        for bound in _literal_bounds(ast.parse(path.read_text())):
            where[bound].add(str(path.relative_to(ROOT)))
    twice = {bound: sorted(paths) for bound, paths in where.items() if len(paths) > 1}
    assert not twice, f"one range, two declarations (name it in drake_tooluse/limits.py): {twice}"


def test_the_checks_see_planted_duplicates():
    planted = ast.parse("MAX_EPISODES = 5\ncount_arg(x, '--runs', 1, 10_000)\n")
    assert _redeclared(planted) == ["MAX_EPISODES"]
    assert _literal_bounds(planted) == {10_000}
