"""Each range declared once (`drake_tooluse.limits`): no module declares a limit of its own under
a name that module holds, and no literal bound of a count check appears in two modules."""

import argparse
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


def _count_arg_options() -> set:
    """The option names the command line's `count_arg` calls check (a literal second argument)."""
    options = set()
    for path in SOURCES:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "count_arg":
                option = node.args[1]
                if isinstance(option, ast.Constant):
                    options.add(option.value)
    return options


def test_every_count_option_checked_has_its_range_in_the_table():
    assert _count_arg_options() <= set(limits.OPTION_RANGES)


def test_every_count_option_s_help_shows_the_range_it_is_checked_against():
    """Each option of the table exists in some command, and its help states its range."""
    from drake_tooluse.cli import commands, make_parser

    parser = make_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    shown = {}
    for command in commands(sub):
        help_text = " ".join(command.format_help().split())
        for action in command._actions:
            option = action.option_strings[0] if action.option_strings else None
            if option in limits.OPTION_RANGES:
                lo, hi = limits.OPTION_RANGES[option]
                shown[option] = f"[{lo:,} to {hi:,}]" in help_text
    assert shown == dict.fromkeys(limits.OPTION_RANGES, True)


def test_a_count_option_out_of_its_range_is_refused_naming_the_option_and_range(capsys):
    from drake_tooluse.cli import main

    code = main(["transfer", "--runs", str(limits.MAX_RUNS + 1)])
    err = capsys.readouterr().err
    assert code == 2 and "--runs" in err and f"{limits.MAX_RUNS}" in err.replace(",", "")
