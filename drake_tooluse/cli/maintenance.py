"""`generate-models`, `render-diagrams` and `render-figures`: the files the project writes into
its own tree."""

from __future__ import annotations

from pathlib import Path

from drake_tooluse.cli.common import UsageError
from drake_tooluse.paths import BAXTER_URDF, MODELS_DIR, SCENARIOS_DIR


def cmd_generate_models(args) -> dict:
    from drake_tooluse.robot.baxter_model import baxter_urdf, write_models

    if args.check:
        if not BAXTER_URDF.is_file() or BAXTER_URDF.read_text() != baxter_urdf():
            raise UsageError(f"{BAXTER_URDF} is out of date; run `drake-tooluse generate-models`")
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


def add_parsers(sub) -> None:
    p = sub.add_parser("generate-models", help="write models/baxter/baxter.urdf")
    p.add_argument("--check", action="store_true", help="only check it is current")
    p.set_defaults(run=cmd_generate_models, show=format_generate_models)

    p = sub.add_parser(
        "render-diagrams", help="render each diagram's block diagram to diagrams/*.dot and .svg"
    )
    p.add_argument("--check", action="store_true", help="only check the .dot files are current")
    p.set_defaults(run=cmd_render_diagrams, show=format_rendered)

    p = sub.add_parser(
        "render-figures",
        help="take the README's Meshcat screenshots (docs/figures/*.png) from fresh recordings "
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
    p.set_defaults(run=cmd_render_figures, show=format_rendered)
