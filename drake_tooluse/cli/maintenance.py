"""`dev generate-models`, `dev render-diagrams` and `dev render-figures`: the files the project
writes into its own tree, for its maintainers, apart from the users' commands.

Each ran at the top level before (`drake-tooluse render-figures`); those names still run, with a
line on stderr naming the new one (`moved_command`)."""

from __future__ import annotations

from pathlib import Path

from drake_tooluse.cli.common import UsageError
from drake_tooluse.paths import BAXTER_URDF, MODELS_DIR, SCENARIOS_DIR


def cmd_generate_models(args) -> dict:
    from drake_tooluse.robot.baxter_model import baxter_urdf, write_models

    if args.check:
        if not BAXTER_URDF.is_file() or BAXTER_URDF.read_text() != baxter_urdf():
            raise UsageError(
                f"{BAXTER_URDF} is out of date; run `drake-tooluse dev generate-models`"
            )
        return {"current": True, "path": str(BAXTER_URDF)}
    return {"written": str(write_models(MODELS_DIR))}


def format_generate_models(out: dict) -> str:
    return f"{out['path']} is current" if out.get("current") else f"wrote {out['written']}"


def format_rendered(out: dict) -> str:
    """One line per diagram or screenshot: current, or the files written."""
    return "\n".join(
        f"{name}: current"
        if files.get("current")
        else f"{name}: "
        + ", ".join(str(v) for k, v in files.items() if k in ("dot", "svg", "png", "json"))
        for name, files in out.items()
    )


def cmd_render_diagrams(args) -> dict:
    from drake_tooluse.experiments.block_diagrams import render_all

    return render_all(SCENARIOS_DIR, check=args.check)


def cmd_render_figures(args) -> dict:
    from drake_tooluse.experiments.screenshots import render_all

    return render_all(args.figures_dir, check=args.check, names=args.only)


GROUP = "dev"
COMMANDS = ("generate-models", "render-diagrams", "render-figures")


def moved_command(argv: list[str]) -> tuple[list[str], str | None]:
    """`argv` with a maintainers' command given at the top level (its old place) moved under
    `dev`, and the line that says so (None if `argv` needed no change)."""
    if not argv or argv[0] not in COMMANDS:
        return argv, None
    return [GROUP, *argv], (
        f"drake-tooluse {argv[0]} is now `drake-tooluse {GROUP} {argv[0]}` (a maintainers' "
        "command); the old name still runs"
    )


def add_parsers(top) -> None:
    group = top.add_parser(
        GROUP,
        help="maintainers' commands: regenerate the files the project writes into its own tree "
        f"({', '.join(COMMANDS)})",
    )
    sub = group.add_subparsers(dest="dev_command", required=True, metavar="COMMAND")
    p = sub.add_parser("generate-models", help="write models/baxter/baxter.urdf")
    p.add_argument("--check", action="store_true", help="only check it is current")
    p.set_defaults(
        run=cmd_generate_models, show=format_generate_models, command="dev generate-models"
    )

    p = sub.add_parser(
        "render-diagrams", help="render each diagram's block diagram to diagrams/*.dot and .svg"
    )
    p.add_argument("--check", action="store_true", help="only check the .dot files are current")
    p.set_defaults(run=cmd_render_diagrams, show=format_rendered, command="dev render-diagrams")

    p = sub.add_parser(
        "render-figures",
        help="take the docs' Meshcat screenshots (docs/figures/*.png) from fresh recordings "
        "with headless Chromium, each with a .json of what it shows",
    )
    p.add_argument(
        "--figures-dir",
        type=Path,
        default=Path("docs/figures"),
        metavar="DIR",
        help="the checkout's figure folder (default: %(default)s)",
    )
    p.add_argument(
        "--only", nargs="+", metavar="NAME", help="only these screenshots (default: all)"
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="only check each screenshot's .json matches a fresh recording (no browser needed)",
    )
    p.set_defaults(run=cmd_render_figures, show=format_rendered, command="dev render-figures")
