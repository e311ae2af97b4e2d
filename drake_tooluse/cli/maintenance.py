"""`generate-models` and `render-diagrams`: the files the project writes into its own tree."""

from __future__ import annotations

from drake_tooluse.cli.common import UsageError
from drake_tooluse.paths import BAXTER_URDF, MODELS_DIR, SCENARIOS_DIR


def cmd_generate_models(args) -> dict:
    from drake_tooluse.robot.baxter_model import baxter_urdf, write_models

    if args.check:
        if not BAXTER_URDF.is_file() or BAXTER_URDF.read_text() != baxter_urdf():
            raise UsageError(f"{BAXTER_URDF} is out of date; run `drake-tooluse generate-models`")
        return {"current": True, "path": str(BAXTER_URDF)}
    return {"written": str(write_models(MODELS_DIR))}


def cmd_render_diagrams(args) -> dict:
    from drake_tooluse.experiments.block_diagrams import render_all

    return render_all(SCENARIOS_DIR, check=args.check)


def add_parsers(sub) -> None:
    p = sub.add_parser("generate-models", help="write models/baxter/baxter.urdf")
    p.add_argument("--check", action="store_true", help="only check it is current")
    p.set_defaults(run=cmd_generate_models)

    p = sub.add_parser(
        "render-diagrams", help="render each diagram's block diagram to diagrams/*.dot and .svg"
    )
    p.add_argument("--check", action="store_true", help="only check the .dot files are current")
    p.set_defaults(run=cmd_render_diagrams)
