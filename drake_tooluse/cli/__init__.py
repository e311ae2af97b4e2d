"""`drake-tooluse`: the command line, a thin dispatcher over one module per command group.

Each group module adds its commands' parsers and imports the library only when a command
runs, so `--help` and argument errors come fast. This is the one place where errors become
exit codes and messages: 0 success, 2 an error (its message on stderr, and as
`{"error": ...}` on stdout with `--json`). Nothing in the library imports this package.
"""

from __future__ import annotations

import argparse
import json
import sys

from drake_tooluse.cli import experiments, learning, maintenance, measure, robot

GROUPS = (robot, learning, experiments, measure, maintenance)
DESCRIPTION = (
    "A Baxter robot that uses a straight tool of any length, in Drake: tool-tip IK, "
    "simulation, camera measurement, training, transfer."
)


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="drake-tooluse", description=DESCRIPTION)
    sub = parser.add_subparsers(dest="command", required=True)
    for group in GROUPS:
        group.add_parsers(sub)
    for p in sub.choices.values():
        p.add_argument("--json", action="store_true", help="print JSON")
    return parser


def main(argv=None) -> int:
    args = make_parser().parse_args(argv)
    try:
        out = args.run(args)
    except (ValueError, FileNotFoundError, FileExistsError, RuntimeError) as e:
        if args.json:
            print(json.dumps({"error": str(e)}))
        print(f"drake-tooluse {args.command}: error: {e}", file=sys.stderr)
        return 2
    show = getattr(args, "show", None)
    if args.json or show is None:
        print(json.dumps(out, indent=2))
    else:
        print(show(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
