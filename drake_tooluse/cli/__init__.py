"""`drake-tooluse`: the command line, a thin dispatcher over one module per command group.

The users' commands are at the top level; the maintainers' (which regenerate the project's own
files) under `drake-tooluse dev`. `drake-tooluse --version` prints the package's version and the
Drake and Python it runs on. The commands that show a scene (`demo`, `simulate`, `evaluate`)
take `--meshcat`: a live view whose URL they print, kept open after the result until the user
is done with it (`common.wait_for_user`).

Each group module adds its commands' parsers and imports the library only when a command
runs, so `--help` and argument errors come fast. This is the one place where errors become
exit codes and messages, one line on stderr (and `{"error": ...}` on stdout with `--json`),
never a traceback:

| exit code | meaning |
| --- | --- |
| 0 | success |
| 1 | an internal error (a bug: `DRAKE_TOOLUSE_TRACEBACK=1` shows its traceback) |
| 2 | a usage error (a bad option, value, file or path) or an environment problem (a missing dependency, a busy run directory), named in the message |
| 3 | target not reached: `ik` found no joint angles for the pose, `simulate` none for a waypoint; a `sweep` cell or `study` run failed |
| 130 | interrupted (Ctrl-C); a training run resumes from its last checkpoint |

The library raises ValueError or OSError (FileNotFoundError, FileExistsError, ...) for bad
input, and `validation.EnvironmentProblem` (a RuntimeError) for an environment problem (Ray,
Chromium or Graphviz missing; a run directory locked by another process): these are exit 2.
Any other RuntimeError (from Drake's C++, torch, or a bug of ours) is exit 1.

Every command prints human-readable text by default and JSON with `--json` (strict JSON: a
non-finite number is `null`), an argument error included; every `--help` shows the options'
defaults and these exit codes. Options are never abbreviated (`--tool` is not `--tool-length`).
A failed Drake precondition (which pydrake raises as SystemExit) is a bug's exit 1 like any
other: the library checks every value before it reaches Drake. The warnings a command raises
(torch's, Drake's) are shown after its result, and not at all when it fails: the error is the
one line. Nothing in the library imports this package.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import warnings
from pathlib import Path

from drake_tooluse.cli import experiments, learning, maintenance, measure, robot, study, tools
from drake_tooluse.cli.common import (  # noqa: F401 (the codes' one definition, exported here)
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_NOT_REACHED,
    EXIT_OK,
    EXIT_USAGE,
    path_arg,
)
from drake_tooluse.limits import OPTION_RANGES
from drake_tooluse.validation import EnvironmentProblem, clipped, drake_failure

GROUPS = (robot, learning, experiments, study, measure, tools, maintenance)
DESCRIPTION = (
    "A Baxter robot that uses tools in Drake (straight tools of any length, hooks): tool-tip "
    "IK, simulation, camera measurement, training, transfer, push and pull tasks, tool choice."
)
EPILOG = (
    "exit codes: 0 success, 1 internal error (a bug), 2 usage error (bad option, value, file "
    "or path; or an environment problem the message names: a missing optional dependency, a "
    "busy run directory), 3 target not reached (ik: no joint angles put the tip at the pose; "
    "simulate: none for a waypoint; sweep, study: a cell's run failed), 130 interrupted"
)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """argparse's defaults formatter, leaving out the defaults that say nothing (None, a flag's
    False) and those the help already states."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default  # (`is`: 0 is a default to show, False is a flag's)
        says_nothing = default is None or default is False or default == []
        if not ("%(default)" in text or "default" in text or says_nothing):
            text = super()._get_help_string(action)
        bounds = OPTION_RANGES.get(action.option_strings[0] if action.option_strings else "")
        if bounds and text:  # a count option's range, as `common.count_arg` checks it
            text = f"{text} [{bounds[0]:,} to {bounds[1]:,}]"
        return text


MAX_MESSAGE = 1000  # characters of an error's one line


class ArgumentsRefused(Exception):
    """argparse's refusal of the command line (its `error`), for `main` to report."""

    def __init__(self, parser: argparse.ArgumentParser, message: str):
        super().__init__(message)
        self.parser = parser


class VersionShown(Exception):
    """`--version` printed its line: `main` returns exit code 0."""


def version_line() -> str:
    """The package's version, the Drake and Python it runs on, in one line (no Drake import:
    the installed distribution's metadata)."""
    import importlib.metadata
    import platform

    from drake_tooluse import __version__

    try:
        drake = importlib.metadata.version("drake")
    except importlib.metadata.PackageNotFoundError:  # a Drake not installed by pip
        drake = "unknown (no 'drake' distribution installed)"
    return f"drake-tooluse {__version__} (Drake {drake}, Python {platform.python_version()})"


# What argparse takes for a negative number, not an option (its attribute, read by 3.11-3.13).
NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.I)


class _Version(argparse.Action):
    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_line())
        raise VersionShown


class Parser(argparse.ArgumentParser):
    """argparse's parser that raises its errors for `main` to report (as JSON too, with
    `--json`) instead of printing them and exiting. A value such as `-inf`, `-nan` or `-1e-3`
    is taken as an option's value (argparse's own pattern knows only `-1` and `-.5`, and
    read `--hook-length -inf` as a missing value), so the option's range check names it.
    Every `type=Path` option parses with `common.path_arg` (no empty path, no NUL byte)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER
        self.register("type", Path, path_arg)

    def error(self, message):
        raise ArgumentsRefused(self, message)


def make_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="drake-tooluse",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=HelpFormatter,
        allow_abbrev=False,
    )
    parser.add_argument(
        "--version", action=_Version, help="print the version, Drake's and Python's, and exit"
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for group in GROUPS:
        group.add_parsers(sub)
    for p in commands(sub):
        p.add_argument(
            "--json", action="store_true", help="print JSON (default: human-readable text)"
        )
    return parser


def commands(sub) -> list[argparse.ArgumentParser]:
    """The parsers of the commands under the subparsers `sub`, a group's (`dev`'s) included,
    each given the help's formatter and epilog on the way."""
    found = []
    for p in sub.choices.values():
        p.formatter_class = HelpFormatter
        p.epilog = EPILOG
        p.allow_abbrev = False  # `--tool 0.2` is an error, not --tool-length
        nested = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
        found += commands(nested[0]) if nested else [p]
    return found


def _strict(value):
    """`value` with non-finite floats as None: JSON has no NaN or Infinity."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict(v) for v in value]
    return value


def _one_line(text: str) -> str:
    return clipped(text, MAX_MESSAGE)


def _message(e: BaseException) -> str:
    if isinstance(e, OSError) and e.filename is not None and e.strerror:
        return f"{str(e.filename)!r}: {e.strerror}"
    return _one_line(str(e)) or type(e).__name__


def _usage_error(e: Exception) -> bool:
    """Whether `e` is exit 2: a ValueError or OSError (every check at the boundary raises one,
    naming the value and what is allowed; OSError: a file or directory the system refused, named
    with the reason), or an `EnvironmentProblem` (a missing program or package, a busy run
    directory, named). Any other RuntimeError — from Drake's C++, torch, or our code — is a bug."""
    return isinstance(e, (ValueError, OSError, EnvironmentProblem))


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    argv, moved = maintenance.moved_command(argv)
    if moved:
        print(moved, file=sys.stderr)
    try:
        parser = make_parser()  # it lists the registered env ids
    except ValueError as e:  # DRAKE_TOOLUSE_TASKS names a module that cannot be imported
        text = _one_line(e)
        if "--json" in argv:
            print(json.dumps({"error": text, "exit_code": EXIT_USAGE}))
        print(f"drake-tooluse: error: {text}", file=sys.stderr)
        return EXIT_USAGE
    try:
        args = parser.parse_args(argv)
        args.argv = argv  # the command line, as a command says how to go on from a stop
    except VersionShown:
        return EXIT_OK
    except ArgumentsRefused as e:
        text = _one_line(e)
        if "--json" in argv:
            print(json.dumps({"error": text, "exit_code": EXIT_USAGE}))
        else:
            e.parser.print_usage(sys.stderr)
        print(f"{e.parser.prog}: error: {text}", file=sys.stderr)
        return EXIT_USAGE

    def fail(code: int, text: str) -> int:
        if args.json:
            print(json.dumps({"error": text, "exit_code": code}))
        print(f"drake-tooluse {args.command}: error: {text}", file=sys.stderr)
        return code

    def bug(kind: str, text: str) -> int:
        return fail(
            EXIT_INTERNAL,
            f"internal error {kind}: {text} (a bug; set DRAKE_TOOLUSE_TRACEBACK=1 to see where)",
        )

    with warnings.catch_warnings(record=True) as raised:  # (the filters as they are)
        try:
            out = args.run(args)
        except KeyboardInterrupt as e:  # (the library's may say how to continue)
            return fail(EXIT_INTERRUPTED, "interrupted" + (f": {_one_line(e)}" if str(e) else ""))
        except SystemExit as e:  # pydrake raises a failed Drake precondition as one
            condition = drake_failure(e)
            if condition is None or os.environ.get("DRAKE_TOOLUSE_TRACEBACK"):
                raise
            return bug("(a Drake precondition failed)", _one_line(condition))
        except Exception as e:
            if _usage_error(e):
                return fail(EXIT_USAGE, _message(e))
            if os.environ.get("DRAKE_TOOLUSE_TRACEBACK"):  # a bug: one line, the traceback
                raise
            return bug(type(e).__name__, _message(e))
    for w in raised:  # the command succeeded: its warnings, after the work
        sys.stderr.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno))
    show = getattr(args, "show", None)
    text = (
        json.dumps(_strict(out), indent=2, allow_nan=False)
        if args.json or show is None
        else show(out)
    )
    try:
        try:
            print(text)
        except UnicodeEncodeError:  # a name stdout cannot encode (a file name of non-UTF-8
            encoding = sys.stdout.encoding or "utf-8"  # bytes, a strict locale): escaped
            print(text.encode(encoding, "backslashreplace").decode(encoding))
        sys.stdout.flush()
    except BrokenPipeError:  # the reader left (`| head -1`): the work is done, quietly
        # Python would report the pipe again when it flushes stdout at exit: point it nowhere.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    keep_open = getattr(args, "keep_open", None)  # --meshcat: the view stays until the user
    if keep_open is not None:  # is done with it
        sys.stdout.flush()  # the result shows while the view stays open, in a pipe too
        try:
            keep_open()
        except KeyboardInterrupt:  # (Ctrl-C is done too)
            pass
    status = getattr(args, "status", None)  # a command whose result can miss its target
    return status(out) if status is not None else EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
