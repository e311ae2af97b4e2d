"""`tools sample` and `tools gallery`: tools the robot has never seen, drawn by family
(`robot.tool_generator`) and written as files a simulator, a viewer or a slicer reads."""

from __future__ import annotations

from pathlib import Path

from drake_tooluse.cli.common import choice_arg, output_dir_arg, output_file_arg, seed_arg
from drake_tooluse.robot.tool_generator import FAMILIES, generate_tool
from drake_tooluse.validation import check_one_of


def cmd_sample(args) -> dict:
    """A tool of the family drawn with the seed, written as tool.sdf, tool.obj, tool.stl,
    tool.json (its family, seed, parameters, frames and mass) and sidecar.yaml (its frames, as
    `tools import` reads them beside the OBJ) into a new directory."""
    from drake_tooluse.cli.common import UsageError

    try:
        check_one_of(args.family, tuple(FAMILIES), "--family")
    except ValueError as e:
        raise UsageError(str(e)) from None
    seed_arg(args.seed)
    out = output_dir_arg(args.out)
    from drake_tooluse.files import atomic_dir, atomic_write_json
    from drake_tooluse.robot.tool_files import write_tool_files

    generated = generate_tool(args.family, args.seed)
    tool = generated.tool
    description = {
        **generated.as_dict(),
        "mass_kg": tool.mass,
        "frames": {name: list(X.translation) for name, X in tool.frames().items()},
    }
    with atomic_dir(out) as work:
        files = write_tool_files(tool, work)
        atomic_write_json(Path(work) / "tool.json", description)
    files = {kind: str(out.absolute() / Path(path).name) for kind, path in files.items()}
    files["json"] = str(out.absolute() / "tool.json")
    return {**description, "files": files}


def format_sample(out: dict) -> str:
    params = ", ".join(
        f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in out["params"].items()
    )
    frames = ", ".join(out["frames"])
    return (
        f"{out['family']} tool, seed {out['seed']}: {params}; {out['mass_kg'] * 1000:.0f} g; "
        f"frames {frames}\nwrote " + ", ".join(out["files"].values())
    )


def cmd_gallery(args) -> dict:
    from drake_tooluse.experiments.tool_gallery import GALLERY_ROWS, write_gallery

    seed_arg(args.seed, "--seed", GALLERY_ROWS)
    path = output_file_arg(args.out, "--out", ".png")
    return write_gallery(path, args.seed)


def cmd_import(args) -> dict:
    """A tool from a mesh and its sidecar, written as an SDF model into a new directory."""
    from drake_tooluse.cli.common import UsageError
    from drake_tooluse.robot.mesh_import import COLLISIONS, import_mesh_tool

    choice_arg(args.collision, COLLISIONS, "--collision", "collision")
    for option, path in (("--mesh", args.mesh), ("--sidecar", args.sidecar)):
        if not path.is_file():
            raise UsageError(f"{option}: {str(path)!r} is not a file")
    out = output_dir_arg(args.out)
    return import_mesh_tool(args.mesh, args.sidecar, out, args.collision)


def format_import(out: dict) -> str:
    return (
        f"{out['sdf']}: {out['parts']} convex collision part(s) by {out['collision']} "
        f"({out['decomposition_s']:.1f} s; {out['parts_volume_m3'] / out['volume_m3']:.2f}x the "
        f"mesh's volume), {out['mass_kg'] * 1000:.0f} g, frames {', '.join(out['frames'])}"
    )


def add_parsers(top) -> None:
    group = top.add_parser(
        "tools", help="tools the robot has never seen: draw one by family, or a gallery"
    )
    sub = group.add_subparsers(dest="tools_command", required=True, metavar="COMMAND")
    p = sub.add_parser(
        "sample",
        help="draw a tool of a family and write it as SDF (primitives, inertia, working "
        "frames), OBJ and STL",
    )
    p.add_argument("--family", required=True, help=f"one of {list(FAMILIES)}")
    p.add_argument(
        "--seed", type=int, default=0, help="the draw's seed: the same seed, the same tool"
    )
    p.add_argument("--out", type=Path, required=True, help="new directory for the tool's files")
    p.set_defaults(run=cmd_sample, show=format_sample, command="tools sample")

    p = sub.add_parser(
        "import",
        help="a tool from a mesh (OBJ or STL) and a sidecar YAML of its frames: an SDF model "
        "with the mesh as visual, convex parts as collision, and its inertia",
    )
    p.add_argument("--mesh", type=Path, required=True, help="the tool's closed mesh (OBJ or STL)")
    p.add_argument(
        "--sidecar",
        type=Path,
        required=True,
        help="YAML: frames (tool_tip required), grasp, mass, scale (robot.mesh_import)",
    )
    p.add_argument(
        "--collision",
        default="coacd",
        help="coacd (CoACD's convex decomposition) or hull (Drake's convex hull)",
    )
    p.add_argument("--out", type=Path, required=True, help="new directory for tool.sdf and meshes")
    p.set_defaults(run=cmd_import, show=format_import, command="tools import")

    p = sub.add_parser(
        "gallery", help="a figure of 24 generated tools, 4 of each family (and a .json of them)"
    )
    p.add_argument("--seed", type=int, default=0, help="the first seed of each family's tools")
    p.add_argument("--out", type=Path, required=True, help="the figure (PNG)")
    p.set_defaults(
        run=cmd_gallery,
        show=lambda out: f"wrote {out['png']} and {out['json']}",
        command="tools gallery",
    )
