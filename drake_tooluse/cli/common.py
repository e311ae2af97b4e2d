"""What the commands share: usage errors, the tool and scenario options, pose printing."""

from __future__ import annotations

import argparse
import contextlib
import shlex
import sys
from pathlib import Path

from drake_tooluse.limits import OPTION_RANGES
from drake_tooluse.paths import DEFAULT_SCENARIO

# The exit codes (their table is in `drake_tooluse.cli`'s docstring and every --help).
EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_NOT_REACHED, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


class UsageError(ValueError):
    """Bad input at the command line."""


def add_tool_args(p: argparse.ArgumentParser) -> None:
    """--tool-length L or --no-tool: the tool the robot model holds."""
    p.add_argument("--tool-length", type=float, metavar="L", help="tool length in m, in (0, 0.60]")
    p.add_argument("--no-tool", action="store_true", help="the tip frame is the gripper frame")


def path_arg(text: str) -> Path:
    """A path option's value (argparse's `type=Path`, as `cli.Parser` registers it for every
    option): an empty or blank one — an unset shell variable — would name the current
    directory, and one holding a NUL byte no file at all; both are refused at the parse, with
    the option named."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is not a path (it is empty or blank)")
    if "\x00" in text:
        from drake_tooluse.validation import shown

        raise argparse.ArgumentTypeError(f"{shown(text)} holds a NUL byte, which no path can")
    return Path(text)


def tool_length_arg(value, option: str = "--tool-length") -> float:
    """A tool-length option: a number in (0, 0.60] m (`robot.tool`: checked before Drake is
    imported)."""
    from drake_tooluse.robot.tool import check_tool_length

    return check_tool_length(value, option)


def tool_length_from_args(args) -> float | None:
    if args.no_tool:
        if args.tool_length is not None:
            raise UsageError("give either --tool-length or --no-tool, not both")
        return None
    if args.tool_length is None:
        raise UsageError("give --tool-length L (m, in (0, 0.60]) or --no-tool")
    return tool_length_arg(args.tool_length)


def add_scenario_args(p: argparse.ArgumentParser) -> None:
    """--scenario FILE and --tool-length L (the world's true tool)."""
    p.add_argument(
        "--scenario",
        type=Path,
        default=DEFAULT_SCENARIO,
        help="scenario YAML (default: %(default)s)",
    )
    p.add_argument(
        "--tool-length",
        type=float,
        metavar="L",
        help="override the scenario's true tool length (m, in (0, 0.60])",
    )


def scenario_from_args(args):
    """The scenario of `add_scenario_args`' options, validated."""
    from drake_tooluse.world.scenario import load_scenario, with_tool, with_tool_length

    scenario = load_scenario(args.scenario)
    if getattr(args, "tool_kind", None) == "straight" and scenario.tool.kind != "straight":
        # A straight tool in a world made for another (the pull world's hook): its length is
        # a straight tool's, not the hook handle's.
        length = scenario.tool.length if args.tool_length is None else args.tool_length
        return with_tool(scenario, tool_length_arg(length))
    if args.tool_length is not None:
        scenario = with_tool_length(scenario, args.tool_length)
    return scenario


def measured_belief(scenario) -> tuple[object, dict]:
    """Measures the scenario's (true) tool with the head camera: the robot's belief (its
    length and where the hand holds it along it) and the figures to print."""
    from drake_tooluse.builders.measurement import measure_belief

    belief, result = measure_belief(scenario)
    return belief, {
        "measured_tool_length_m": result.length,
        "true_tool_length_m": scenario.tool.length,
        "measured_grasp_along_m": result.grasp_along,
        "true_grasp_along_m": scenario.tool.grasp_offset_along,
        "measurement_spread_m": result.spread,
        "measurement_time_s": result.wall_time,
    }


def pose_dict(X) -> dict:
    from pydrake.math import RollPitchYaw

    return {
        "position_m": X.translation().tolist(),
        "quaternion_wxyz": X.rotation().ToQuaternion().wxyz().tolist(),
        "rpy_rad": RollPitchYaw(X.rotation()).vector().tolist(),
    }


def policy_env_id(path) -> str | None:
    """The env id a policy directory's policy.json names (None where it names none), read
    without loading the policy."""
    from drake_tooluse.files import read_json

    meta = read_json(Path(path) / "policy.json", "policy metadata")
    return meta.get("env_id") if isinstance(meta, dict) else None


def serves_arg(env_id, command: str, given: str) -> None:
    """`env_id`'s task serves `command` (`tasks.contract.check_serves`); else a usage error
    saying what the command needs, after `given` (the option and its value)."""
    from drake_tooluse.tasks.contract import check_serves

    try:
        check_serves(env_id, command)
    except ValueError as e:
        raise UsageError(f"{given}: {e}") from None


def serving_policy_arg(path, command: str, option: str = "--policy") -> Path:
    """A policy directory (`policy_dir_arg`) whose task serves `command`, read from its
    policy.json before any work (`serves_arg`)."""
    path = policy_dir_arg(path, option)
    serves_arg(policy_env_id(path), command, f"{option} {str(path)!r}")
    return path


def parse_json_arg(text: str | None, name: str) -> dict | None:
    """A JSON object option's value (None if not given); bad JSON, or JSON that is not an
    object of names to values, is a usage error naming the option."""
    from drake_tooluse.files import parse_json
    from drake_tooluse.validation import shown

    if text is None:
        return None
    try:
        value = parse_json(text, name)
    except ValueError as e:
        raise UsageError(f"{e}: {shown(text)}") from None  # (the option's text, shortened)
    if not isinstance(value, dict):
        raise UsageError(
            f"{name} must be a JSON object of names to values, e.g. '{{\"key\": 1}}'; got "
            f"{shown(text)}"
        )
    return value


def seed_arg(value, option: str = "--seed", count: int = 1) -> int:
    """A seed option: an integer in [0, 2**32 - 1] (with `count` runs or episodes, the last
    seed, value + count - 1, too)."""
    from drake_tooluse.validation import check_seed

    return check_seed(value, option, count)


def count_arg(value, option: str, what: str | None = None) -> int:
    """A count option (episodes, runs, steps): an integer in its range (`limits.OPTION_RANGES`,
    which the option's help shows too). The message names `what` (default: the option)."""
    from drake_tooluse.validation import check_int

    lo, hi = OPTION_RANGES[option]
    return check_int(value, lo, hi, what or option)


def choice_arg(value, allowed, option: str, what: str):
    """An option that takes one of `allowed` names of `what`s (checked before the library
    that defines them is imported; the library's words)."""
    if value not in allowed:
        raise UsageError(f"{option}: unknown {what} {value!r}; choose one of {list(allowed)}")
    return value


def env_arg(value, option: str) -> str:
    """An env id option: a registered id (an earlier version of one is refused naming the git
    tag that runs it)."""
    from drake_tooluse.tasks.contract import check_env_id

    try:
        return check_env_id(value)
    except ValueError as e:
        raise UsageError(f"{option}: {e}") from None


def policy_dir_arg(path, option: str = "--policy") -> Path:
    """A policy directory option: a directory holding policy.json (either format has it; the
    library checks the rest when it loads it), checked before torch is imported."""
    path = Path(path)
    if not path.exists():
        why = "it does not exist"
    elif not path.is_dir():
        why = "it is a file"
    elif not (path / "policy.json").is_file():
        why = "it has no policy.json"
    else:
        return path
    raise UsageError(f"{option} {str(path)!r} is not a policy directory: {why}")


def output_dir_arg(path, option: str = "--out", must_be_new: bool = True):
    """A directory a command writes, checked before any work (not a file, writable, new)."""
    from drake_tooluse.files import check_output_dir

    return check_output_dir(path, option, must_be_new)


def output_file_arg(path, option: str, suffix: str | None = None):
    """A file a command writes, checked before any work (not a directory, writable)."""
    from drake_tooluse.files import check_output_file

    return check_output_file(path, option, suffix)


class _Renamed(argparse.Action):
    """An option under its old name: refused, with the line `message` (naming the new one)."""

    def __init__(self, option_strings, dest, message: str = "", **kwargs):
        super().__init__(option_strings, dest, nargs="?", help=argparse.SUPPRESS, **kwargs)
        self.message = message

    def __call__(self, parser, namespace, values, option_string=None):
        parser.error(self.message)


def add_renamed_option(p: argparse.ArgumentParser, old: str, message: str) -> None:
    """Refuses the option `old` (hidden from --help) with `message`, one line that names the
    option to use now."""
    p.add_argument(old, action=_Renamed, dest=f"renamed_{old.lstrip('-')}", message=message)


def add_meshcat_arg(p: argparse.ArgumentParser, what: str) -> None:
    """--meshcat: show `what` live in a browser (`open_meshcat`)."""
    p.add_argument(
        "--meshcat",
        action="store_true",
        help=f"show {what} in Meshcat: print its URL (on stderr) and, after the result, keep "
        "the view open until Enter is pressed (stdin not a terminal: until a line or the end "
        "of stdin)",
    )


def open_meshcat(args):
    """With --meshcat: a Meshcat server on a free loopback port, its URL printed on stderr now
    (open it while the command runs) and `args.keep_open` set, which `main` calls after the
    result is printed (`wait_for_user`). Without: None."""
    if not getattr(args, "meshcat", False):
        return None
    from drake_tooluse.builders.visualization import start_meshcat

    meshcat = start_meshcat()
    print(f"Meshcat: open {meshcat.web_url()} in a browser", file=sys.stderr, flush=True)
    args.keep_open = lambda: wait_for_user(meshcat)
    return meshcat


def wait_for_user(meshcat, stdin=None) -> None:
    """Keeps `meshcat` (its server, and the view in the browser) open until the user is done:
    Enter at a terminal; otherwise (CI, a pipe) a line or the end of `stdin` (default
    sys.stdin), so that a command with no one at it does not wait forever."""
    stdin = sys.stdin if stdin is None else stdin
    if stdin is None or stdin.closed:
        return
    how = "press Enter to close it" if stdin.isatty() else "send a line or close stdin to close it"
    print(f"Meshcat: {meshcat.web_url()} stays open; {how}", file=sys.stderr, flush=True)
    try:
        stdin.readline()
    except (OSError, ValueError):  # a stdin that cannot be read: no one to wait for
        pass


def add_trust_pickle_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--trust-pickle",
        action="store_true",
        help="load a policy directory of the older pickle format (policy.zip, vecnormalize.pkl); "
        "its files can run code when loaded: only for files you trust. Convert it once with "
        "`drake-tooluse convert-policy` instead",
    )


@contextlib.contextmanager
def goes_on_with(command: str, kept: str):
    """Ctrl-C inside says what was `kept` and the `command` that goes on from it (as
    KeyboardInterrupt's text, which `main` prints with exit code 130)."""
    try:
        yield
    except KeyboardInterrupt:
        raise KeyboardInterrupt(f"{kept}; go on with `{command}`") from None


def this_command(args) -> str:
    """The command line `args` were parsed from (`main` keeps it), as `drake-tooluse …`."""
    return shlex.join(["drake-tooluse", *args.argv])


def run_script(main) -> int:
    """Runs a script's `main()` (the benchmarks'): Ctrl-C ends it with one line on stderr and
    exit code 130, not a traceback; returns the exit code (`main`'s, 0 for None)."""
    try:
        code = main()
    except KeyboardInterrupt:
        name = Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "script"
        print(f"{name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return code or 0
