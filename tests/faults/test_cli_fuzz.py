"""The command line fuzzed: every option of every command, walked from the real parser, gets
hostile values (non-finite and huge numbers, empty, blank, long, control-character and
non-UTF-8 text, misspelled choices, numbers swapped into structured values, wrong arity, paths
that are missing, of the wrong kind, unwritable or a FIFO), each put into a command line that
is otherwise valid and cheap; then Hypothesis draws more (any text, any number, any file
content for the files the commands read).

A value that can never be valid is refused at the boundary: exit 2, one line on stderr (after
argparse's usage, where argparse refused it) naming the option or the value, no traceback, no
work before it (the simulator, a process or Ray started) and nothing written. A value that may
be valid runs whole where the command's run is cheap, and ends in a result or that same
refusal; a command whose run is expensive only gets values that must be refused.

A new option is covered with no edit here; a new command needs its cheap command line in
`BASES` (one with no required option runs from its defaults until it has one)."""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import re
import signal
import subprocess
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drake_tooluse.cli import EXIT_USAGE, commands, main, make_parser
from drake_tooluse.paths import TRANSFER_POLICY

pytestmark = pytest.mark.slow

PARSER = make_parser()
COMMANDS = {
    p.prog.removeprefix("drake-tooluse "): p
    for p in commands(next(a for a in PARSER._actions if isinstance(a, argparse._SubParsersAction)))
}
TINY = json.dumps({"n_steps": 64, "batch_size": 64, "n_epochs": 1, "eval_freq": 256})


@dataclass(frozen=True)
class Base:
    """A command's valid command line (option -> its values; `{name}` a path made per case),
    whether its whole run is cheap, the options of it that one under test replaces (a
    `--resume` goes alone), and those one under test needs to be read at all."""

    options: dict
    cheap: bool = False
    drop: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)


BASES = {
    "fk": Base({"--tool-length": ["0.175"], "--q": ["0"] * 7}, cheap=True),
    "ik": Base(
        {"--tool-length": ["0.175"], "--position": ["0.65", "-0.25", "-0.1"]},
        cheap=True,
        extra={"--scenario": {"--measure": []}},
    ),
    "simulate": Base(
        {"--tip-waypoints": ["0.65,-0.25,-0.1"], "--move-time": ["0.1"], "--dwell": ["0.1"]}
    ),
    "train": Base(
        {"--out": ["{new}"], "--timesteps": ["64"], "--n-envs": ["1"], "--hyperparams": [TINY]},
        drop={"--resume": ("--out", "--timesteps", "--n-envs", "--hyperparams")},
    ),
    "evaluate": Base({"--policy": ["{policy}"], "--episodes": ["1"]}),
    "convert-policy": Base(
        {"--policy": ["{policy}"], "--out": ["{new}"], "--trust-pickle": []}, cheap=True
    ),
    "distill": Base(
        {
            "--teacher": ["{policy}"],
            "--out": ["{new}"],
            "--rounds": ["1"],
            "--episodes": ["1"],
            "--epochs": ["1"],
        },
        drop={"--resume": ("--teacher", "--out", "--rounds", "--episodes", "--epochs")},
    ),
    "sweep": Base(
        {"--out": ["{new}"], "--timesteps": ["64"], "--episodes": ["1"], "--num-cpus": ["2"]},
        drop={"--resume": ("--out", "--timesteps", "--episodes")},
    ),
    "trajectory": Base(
        {
            "--policy": ["{policy}"],
            "--out": ["{new}"],
            "--episodes": ["1"],
            "--calibration-draws": ["0"],
        }
    ),
    "export-csv": Base(
        {"--trajectory": ["{trajectory}"], "--tool-length": ["0.175"], "--out": ["{new}.csv"]},
        cheap=True,
    ),
    "transfer": Base(
        {"--tools": ["0.175"], "--runs": ["1"], "--out": ["{new}"]},
        extra={"--trajectory": {"--mode": ["open-loop"]}},
    ),
    "choose-tool": Base({"--rollouts": ["1"], "--tools": ["hook:0.25,0.05,90"]}),
    "demo": Base({"--out": ["{new}"]}),
    "record-video": Base({"--out": ["{new}.gif"]}),
    "study": Base({"--out": ["{new}"], "--status": []}, cheap=True),
    "study-report": Base({"--out": ["{new}"]}, cheap=True),
    "measure": Base({}, cheap=True),
    "measure-box": Base({}, cheap=True),
    "tools sample": Base({"--family": ["rake"], "--out": ["{new}"]}, cheap=True),
    "tools gallery": Base({"--out": ["{new}.png"]}),
    "tools import": Base(
        {
            "--mesh": ["{mesh}"],
            "--sidecar": ["{sidecar}"],
            "--collision": ["hull"],
            "--out": ["{new}"],
        },
        cheap=True,
    ),
    "dev generate-models": Base({"--check": []}, cheap=True),
    "dev render-diagrams": Base({"--check": []}, cheap=True),
    "dev render-figures": Base({"--check": [], "--figures-dir": ["{figures}"]}),
}
# Options whose values are free of scale: a huge value is as valid as a small one.
SCALE_FREE = {("ik", "--quaternion")}  # (a quaternion is a rotation at any scale)
# Cases that fail for a reason outside this pass, each with it.
XFAIL = {
    "train:--hyperparams:in-value:1e308": "an algorithm's own hyperparameters (n_steps, "
    "batch_size, ...) are passed to stable-baselines3 unchecked: a float n_steps is refused "
    "by SB3 after the envs are built, naming neither the key nor the value (their ranges are "
    "to be declared once, with the run's own)",
}

FIGURES = Path(__file__).resolve().parents[2] / "docs" / "figures"  # read only (--check)
LIMIT_S = 30  # per case: a value that starts real work runs past it
HUGE = ["1e308", "-1e308", "1" + "0" * 30]
TEXT = ["", " ", "\t", "x" * 5000, "a\x00b", "a\nb", "a\udcffb"]  # (\udcff: a non-UTF-8 byte)
IN_VALUE = {}  # a structured value with a bad number swapped in -> that number

# What a path option is, by its name, where neither its command line in BASES nor its default
# says (the same names mean the same things in every command).
PATH_ROLES = {
    "--scenario": "input-file",
    "--nominal": "input-file",
    "--reality": "input-file",
    "--trajectory": "input-file",
    "--cells": "input-file",
    "--policy": "input-dir",
    "--teacher": "input-dir",
    "--init-from": "input-dir",
    "--resume": "input-dir",
    "--record": "output-file",
    "--save-images": "output-dir",
    "--runs-dir": "output-dir",
}
# The roles of the paths BASES makes per case.
PLACEHOLDER_ROLES = {
    "{policy}": "input-dir",
    "{figures}": "input-dir",
    "{trajectory}": "input-file",
}
INPUTS = ("input-file", "input-dir")
# Path values (label, value) and the roles that can never take them.
PATH_VALUES = [
    ("missing", "{fx}/missing/x", INPUTS),
    ("newline", "{fx}/a\nb", INPUTS),
    ("non-utf8", "{fx}/a\udcffb", INPUTS),
    ("empty-dir", "{fx}/dir", (*INPUTS, "output-file")),
    ("file", "{fx}/junk", (*INPUTS, "output-dir")),
    ("fifo", "{fx}/fifo", (*INPUTS, "output-dir")),
]
# Paths no option takes: refused whatever the role.
BAD_PATHS = [
    ("proc", "/proc/x/y"),
    ("nul", "a\x00b"),
    ("long-name", "x" * 300),
    ("long-path", "/".join(["d"] * 2100)),
    ("empty", ""),
    ("blank", " "),
]


@dataclass(frozen=True)
class Case:
    command: str
    option: str
    label: str
    tokens: tuple | None  # the option's values; None: the option left out
    must_refuse: bool
    named: tuple = ()  # what the message may name besides the option: the bad token

    @property
    def id(self) -> str:
        return f"{self.command}:{self.option}:{self.label}"


def _options(parser) -> list:
    return [
        a for a in parser._actions if a.option_strings and not isinstance(a, argparse._HelpAction)
    ]


def _kind(action) -> str:
    if action.nargs == 0:
        return "flag"
    if action.type is float:
        return "float"
    if action.type is int:
        return "int"
    if action.type is Path:
        return "path"
    if action.type is None or action.type is str:
        return "text"
    return "other"


def _arity(action) -> int:
    """How many values a valid use gives (at least one for + and *)."""
    if isinstance(action.nargs, int):
        return action.nargs
    return 0 if action.nargs == "?" else 1


def _path_role(command: str, option: str, action) -> str:
    """'input-…' where the valid value is an existing file or folder the command reads,
    'output-…' where it is a new one; else by the option's name (PATH_ROLES)."""
    given = BASES.get(command, Base({})).options.get(option)
    value = str(given[0] if given else action.default)
    if value.startswith("{new}"):
        return "output-file" if Path(value).suffix else "output-dir"
    if value in PLACEHOLDER_ROLES:
        return PLACEHOLDER_ROLES[value]
    if Path(value).is_absolute() and Path(value).exists():  # a default: the package's data
        return "input-dir" if Path(value).is_dir() else "input-file"
    return PATH_ROLES.get(option, "unknown")


def _swap_first_number(text: str, bad: str) -> str | None:
    m = re.search(r"-?\d+(\.\d+)?", text)
    return None if m is None else text[: m.start()] + bad + text[m.end() :]


def _values(command: str, action) -> list[tuple[str, str, bool]]:
    """(label, token, must be refused) for `action`'s first value."""
    option = action.option_strings[0]
    kind = _kind(action)
    out = []
    if kind in ("float", "int", "other"):
        out += [("nan", "nan", True), ("inf", "inf", True), ("-inf", "-inf", True)]
        out += [("1e309", "1e309", True)]
        huge = (command, option) not in SCALE_FREE
        out += [(f"huge{i}", v, huge) for i, v in enumerate(HUGE)]
        out += [("0", "0", False), ("word", "x", True), ("comma", "1,5", True)]
    if kind == "int":
        out += [("-1", "-1", True), ("1.5", "1.5", True), ("2**64", str(2**64), True)]
    if kind == "float":
        out += [("-1", "-1", False)]
    if kind in ("float", "int", "other", "text"):
        out += [(f"text{i}", v, True) for i, v in enumerate(TEXT)]
    if kind == "text":
        default = action.default if isinstance(action.default, str) else None
        words = list(action.choices or [])[:2] + ([default] if default else [])
        for word in dict.fromkeys(words):  # a choice misspelled
            for i, w in enumerate([word.upper(), word[:-1], f" {word}"]):
                out.append((f"misspelled{i}:{word[:12]}", w, True))
        is_json = action.metavar == "JSON"
        if is_json:
            for i, text in enumerate(["[]", "{", '{"a": NaN}', '{"no_such_key": 1}']):
                out.append((f"json{i}", text, True))
        for word in BASES.get(command, Base({})).options.get(option) or []:
            for bad in ("NaN", "Infinity", "1e308") if is_json else ("nan", "inf", "1e308"):
                swapped = _swap_first_number(word, bad)  # a bad number in a structured value
                if swapped is not None:
                    out.append((f"in-value:{bad}", swapped, True))
                    IN_VALUE[swapped] = bad
    if kind == "path":
        role = _path_role(command, option, action)
        out += [(label, value, True) for label, value in BAD_PATHS]
        out += [(label, value, role in never) for label, value, never in PATH_VALUES]
    return out


def _cases() -> list[Case]:
    cases = []
    for command, parser in sorted(COMMANDS.items()):
        base = BASES.get(command, Base({}))
        for action in _options(parser):
            option = action.option_strings[0]
            if _kind(action) == "flag":
                cases.append(Case(command, option, "=x", ("=x",), True, ("x",)))
                continue
            n = _arity(action)
            fill = list(base.options.get(option) or ["0"] * max(n, 1))
            for label, token, must in _values(command, action):
                if not must and not base.cheap:
                    continue  # an expensive run: only values that must be refused
                tokens = (token, *fill[1:]) if n else (token,)
                cases.append(Case(command, option, label, tokens, must, (token,)))
            # Wrong arity: none, or one value too few or too many.
            if action.nargs in ("+", None) or isinstance(action.nargs, int):
                cases.append(Case(command, option, "no-value", (), True))
            if isinstance(action.nargs, int) and action.nargs > 1:
                cases.append(Case(command, option, "too-few", tuple(fill[: n - 1]), True))
                extra = "7"
                cases.append(Case(command, option, "too-many", (*fill, extra), True, (extra,)))
            if action.required:
                cases.append(Case(command, option, "left-out", None, True))
    return list({c.id: c for c in cases}.values())


CASES = _cases()
TALLY = collections.Counter()


class WorkStarted(BaseException):
    """The run went past its checks into the work (a BaseException: `main` lets it through)."""


class Overran(BaseException):
    """The case ran past LIMIT_S."""


@contextmanager
def _work_refused(armed: bool):
    """While armed, the first step of any work raises WorkStarted: the simulator advancing or
    initialized, a process started, Ray started, the tool gallery drawn."""
    if not armed:
        yield
        return
    import multiprocessing.process

    from pydrake.systems.analysis import Simulator

    from drake_tooluse.experiments import tool_gallery

    targets = [
        (tool_gallery, "gallery_figure", "the gallery drawn"),
        (Simulator, "AdvanceTo", "the simulator advanced"),
        (Simulator, "Initialize", "the simulator initialized"),
        (subprocess.Popen, "__init__", "a process started"),
        (multiprocessing.process.BaseProcess, "start", "a process started"),
    ]
    try:
        import ray

        targets.append((ray, "init", "Ray started"))
    except ImportError:
        pass

    def trip(what):
        def refuse(*args, **kwargs):
            raise WorkStarted(what)

        return refuse

    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in targets]
    try:
        for obj, name, what in targets:
            setattr(obj, name, trip(what))
        yield
    finally:
        for obj, name, original in saved:
            setattr(obj, name, original)


@contextmanager
def _time_limit(seconds: float):
    def overran(signum, frame):
        raise Overran(f"ran past {seconds} s")

    previous = signal.signal(signal.SIGALRM, overran)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _snapshot(root: Path) -> dict:
    """Every file under `root` (size, time) and folder (a write probe, made and removed,
    changes a folder's time but leaves nothing)."""
    found = {}
    for folder, dirs, files in os.walk(root):
        found.update({str(Path(folder) / d): "dir" for d in dirs})
        for name in files:
            st_ = (Path(folder) / name).lstat()
            found[str(Path(folder) / name)] = (st_.st_size, st_.st_mtime_ns)
    return found


def _fixtures(root: Path, trajectory: Path, files: dict) -> dict:
    """The paths a case's tokens name (`{fx}/fifo`, `{new}`, ...), made under `root`."""
    fx = root / "fx"
    fx.mkdir()
    (fx / "dir").mkdir()
    (fx / "junk").write_bytes(b"\x00\xffnot what any command reads\n" * 4)
    os.mkfifo(fx / "fifo")
    for name, content in files.items():
        (fx / name).write_bytes(content)
    # A closed mesh (a tetrahedron, faces outward) and its sidecar, for `tools import`.
    (fx / "tool.obj").write_text(
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    (fx / "sidecar.yaml").write_text("frames: {tool_tip: [0, 0, 0.1]}\n")
    return {
        "mesh": str(fx / "tool.obj"),
        "sidecar": str(fx / "sidecar.yaml"),
        "fx": str(fx),
        "new": str(root / "new"),
        "policy": str(TRANSFER_POLICY),
        "trajectory": str(trajectory),
        "figures": str(FIGURES),
    }


def _filled(token: str, paths: dict) -> str:
    for key, value in paths.items():
        token = token.replace("{" + key + "}", value)
    return token


def _argv(case: Case, paths: dict) -> list[str]:
    base = BASES.get(case.command, Base({}))
    options = {k: v for k, v in base.options.items() if k not in base.drop.get(case.option, ())}
    options.update(base.extra.get(case.option, {}))
    if case.tokens is None:
        options.pop(case.option, None)
    else:
        options[case.option] = list(case.tokens)
    argv = case.command.split()
    for option, values in options.items():
        if values[:1] == ["=x"]:
            argv.append(option + "=x")
        else:
            argv += [option, *values]
    return [_filled(a, paths) for a in argv]


def _shown(token: str) -> list[str]:
    """The ways a message may show `token`: quoted (a blank one), as given (its start), and a
    number as formatted (`1e+30`)."""
    start = None if len(token) <= 80 else 30  # a long one: its start, as `shown` keeps
    shown = [repr(token)[:start]]
    if token.strip():
        shown += [token[:start], repr(token)[1:-1][:start], repr(str(Path(token)))[:start]]
    try:
        x = float(token)
        shown += [f"{x:g}", repr(x)] if math.isfinite(x) else [str(x)]
    except (ValueError, OverflowError):
        pass
    return shown


def _named(line: str, case: Case, paths: dict) -> bool:
    """Whether the error line names the option or the bad value: the token, the bad number
    swapped into a structured one, or a key of a JSON object."""
    if case.option in line:
        return True
    for token in case.named:
        token = _filled(token, paths)
        shown = _shown(token) + (_shown(IN_VALUE[token]) if token in IN_VALUE else [])
        try:
            value = json.loads(token)
            shown += [repr(k) for k in value] if isinstance(value, dict) else []
        except ValueError:
            pass
        if any(s and s in line for s in shown):
            return True
    return False


def _error_line(err: str) -> str | None:
    """The one error line of `err`, after argparse's usage (its first line "usage: …", the
    rest indented) where it refused the command line; None if there is anything else."""
    lines = err.rstrip("\n").split("\n")
    if lines and lines[0].startswith("usage: "):
        while len(lines) > 1 and lines[1].startswith(" "):
            del lines[1]
        del lines[0]
    if len(lines) != 1 or not lines[0].startswith("drake-tooluse") or "Traceback" in err:
        return None
    return lines[0]


def _strict_json(text: str):
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} is not strict JSON"))


def check(
    case: Case, root: Path, capsys, trajectory, files: dict | None = None, as_json=False
) -> str:
    """Runs `case` in the empty folder `root` (its `{fx}` paths made there, with `files`;
    `as_json`: with --json); fails the test where it breaks a promise, else returns "refused"
    or "ran"."""
    paths = _fixtures(root, trajectory, files or {})
    cwd = root / "cwd"
    cwd.mkdir()
    argv = _argv(case, paths) + (["--json"] if as_json else [])
    before = _snapshot(root)
    armed = case.must_refuse or not BASES.get(case.command, Base({})).cheap
    # A real stderr escapes what it cannot encode (a non-UTF-8 name); stdout stays strict,
    # as under a UTF-8 locale.
    sys.stderr.reconfigure(errors="backslashreplace")
    try:
        with pytest.MonkeyPatch.context() as mp:
            mp.chdir(cwd)
            with _time_limit(LIMIT_S), _work_refused(armed):
                code = main(argv)
    except WorkStarted as e:
        TALLY["failed"] += 1
        pytest.fail(f"{case.id}: {e} before any refusal: {argv!r}")
    except Overran as e:
        TALLY["failed"] += 1
        pytest.fail(f"{case.id}: {e} (work before the refusal, or a hang): {argv!r}")
    captured = capsys.readouterr()
    line = _error_line(captured.err)
    problems = []
    if code == EXIT_USAGE:
        if line is None:
            problems.append(f"not one line on stderr: {captured.err[-2000:]!r}")
        elif not _named(line, case, paths):
            problems.append(f"the line names neither {case.option} nor the value: {line!r}")
        written = sorted({p for p, _ in set(_snapshot(root).items()) ^ set(before.items())})
        if written:
            problems.append(f"written before the refusal: {written}")
    elif case.must_refuse or code not in (0, 3):
        problems.append(f"exit {code}, not {EXIT_USAGE}: {captured.err[-2000:]!r}")
    if as_json and not problems:
        out = _strict_json(captured.out)
        if code == EXIT_USAGE and out != {"error": line.split(": error: ", 1)[1], "exit_code": 2}:
            problems.append(f"--json's error is not the line's: {captured.out[-2000:]!r}")
    if problems:
        TALLY["failed"] += 1
        pytest.fail(f"{case.id}: {argv!r}: " + "; ".join(problems))
    outcome = "refused" if code == EXIT_USAGE else "ran"
    TALLY[outcome] += 1
    return outcome


@pytest.fixture(scope="module")
def trajectory(tmp_path_factory):
    """A short tool-tip trajectory `export-csv` takes."""
    from pydrake.math import RollPitchYaw

    from drake_tooluse.robot.model import TOOL_DOWN_RPY
    from drake_tooluse.systems.tip_trajectory import TipTrajectory

    q = RollPitchYaw(*TOOL_DOWN_RPY).ToQuaternion().wxyz()
    path = tmp_path_factory.mktemp("trajectory") / "t.npz"
    p_WT = [[0.62, -0.3, -0.1], [0.63, -0.29, -0.1], [0.64, -0.28, -0.1]]
    return TipTrajectory([0, 0.5, 1.0], p_WT, [q] * 3).save(path)


@pytest.fixture(scope="module", autouse=True)
def _tally():
    yield
    print(f"\ncli fuzz: {len(CASES)} table cases;", dict(sorted(TALLY.items())))


# -- the table ---------------------------------------------------------------------------


def test_every_command_has_a_cheap_valid_command_line():
    """A new command with a required option needs its command line in BASES (the rest of its
    round comes from the parser)."""
    missing = [
        name
        for name, p in COMMANDS.items()
        if name not in BASES and any(a.required for a in p._actions)
    ]
    assert not missing, f"add a valid, cheap command line to BASES for {missing}"
    unknown = [name for name in BASES if name not in COMMANDS]
    assert not unknown, f"BASES names commands the parser does not have: {unknown}"


@pytest.mark.parametrize("command", sorted(BASES))
def test_each_command_line_in_bases_is_valid(command, tmp_path, capsys, trajectory):
    """The only bad thing in a case's command line is the value under test: each base runs
    whole (a cheap one) or gets past every check into the work (an expensive one)."""
    paths = _fixtures(tmp_path, trajectory, {})
    argv = _argv(Case(command, "", "base", None, False), paths)
    with pytest.MonkeyPatch.context() as mp, _time_limit(LIMIT_S * 4):
        mp.chdir(tmp_path)
        if BASES[command].cheap:
            assert main(argv) == 0, capsys.readouterr().err
            return
        with pytest.raises(WorkStarted), _work_refused(True):
            main(argv)


def test_the_walk_finds_every_command_and_option():
    found = {(c.command, c.option) for c in CASES}
    every = {(name, a.option_strings[0]) for name, p in COMMANDS.items() for a in _options(p)}
    assert found == every
    assert ("ik", "--quaternion") in found and ("dev render-figures", "--only") in found


@pytest.mark.parametrize(
    "case",
    [
        pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=XFAIL[c.id]))
        if c.id in XFAIL
        else c
        for c in CASES
    ],
    ids=[c.id for c in CASES],
)
def test_a_hostile_value_is_refused_at_the_boundary(case, tmp_path, capsys, trajectory):
    check(case, tmp_path, capsys, trajectory)


# -- drawn by Hypothesis ---------------------------------------------------------------------

# Each option of a command whose run is cheap: any value of it may run whole.
CHEAP_OPTIONS = [
    (name, a)
    for name, p in sorted(COMMANDS.items())
    if BASES.get(name, Base({})).cheap
    for a in _options(p)
    if _kind(a) != "flag"
]
_any_text = st.text(st.characters(codec=None, exclude_categories=()), max_size=40)
_any_number = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**40), max_value=10**40).map(str),
)
FUZZ = settings(
    max_examples=300,
    deadline=None,
    database=None,  # (nothing written into the checkout)
    derandomize=True,  # the same draws in every run: CI is reproducible
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@FUZZ
@given(data=st.data())
def test_any_value_of_a_cheap_command_is_a_result_or_a_named_refusal(
    data, tmp_path_factory, capsys, trajectory
):
    command, action = data.draw(st.sampled_from(CHEAP_OPTIONS), label="option")
    kind = _kind(action)
    value = data.draw(_any_number if kind in ("float", "int") else _any_text, label="value")
    if kind == "path":
        value = data.draw(st.sampled_from([value, "{fx}/" + value]), label="where")
    fill = BASES[command].options.get(action.option_strings[0]) or ["0"] * max(_arity(action), 1)
    tokens = (value, *fill[1:]) if _arity(action) else (value,)
    case = Case(command, action.option_strings[0], "drawn", tokens, False, (value,))
    as_json = data.draw(st.booleans(), label="--json")
    check(case, tmp_path_factory.mktemp("drawn"), capsys, trajectory, as_json=as_json)


# The files the cheap commands read, each given any content: (command, option, file name).
READ_FILES = [
    (name, a.option_strings[0], Path(str(a.default or "f.yaml")).name)
    for name, a in CHEAP_OPTIONS
    if _kind(a) == "path" and _path_role(name, a.option_strings[0], a) == "input-file"
]
_yaml_value = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=12,
)
_content = st.one_of(
    st.binary(max_size=300),
    _yaml_value.map(lambda v: json.dumps(v).encode()),  # JSON is YAML too
    st.dictionaries(
        st.sampled_from(["tool", "box", "plant", "cells", "episodes", "times", "robot"]),
        _yaml_value,
    ).map(lambda v: json.dumps(v).encode()),
)


def test_the_commands_read_files():
    assert {o for _, o, _ in READ_FILES} >= {"--scenario", "--trajectory", "--cells"}


@FUZZ
@given(data=st.data())
def test_any_file_a_cheap_command_reads_is_a_result_or_a_named_refusal(
    data, tmp_path_factory, capsys, trajectory
):
    command, option, name = data.draw(st.sampled_from(READ_FILES), label="file")
    content = data.draw(_content, label="content")
    token = f"{{fx}}/{name}"
    case = Case(command, option, "drawn-file", (token,), False, (token,))
    check(case, tmp_path_factory.mktemp("file"), capsys, trajectory, {name: content})
