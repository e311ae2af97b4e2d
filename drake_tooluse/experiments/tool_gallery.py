"""The gallery of generated tools: a grid of tools drawn by `robot.tool_generator`, a column per
family, each tool's mesh (`robot.tool_files.tool_mesh`) seen from the same side with its
working frames marked. `drake-tooluse tools gallery` writes it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from drake_tooluse.files import atomic_write_figure, atomic_write_json
from drake_tooluse.robot.tool import GRASP
from drake_tooluse.robot.tool_files import tool_mesh
from drake_tooluse.robot.tool_generator import FAMILIES, generate_tool
from drake_tooluse.validation import check_int, check_seed

GALLERY_ROWS = 4  # tools per family: 6 families, 24 tools
MAX_GALLERY_ROWS = 20
GREY = (0.6, 0.6, 0.65)


def gallery_figure(seed: int = 0, rows: int = GALLERY_ROWS) -> Figure:
    """`rows` tools of every family (seeds seed … seed + rows − 1), a column per family."""
    rows = check_int(rows, 1, MAX_GALLERY_ROWS, "rows")
    check_seed(seed, "seed", rows)
    families = list(FAMILIES)
    fig = Figure(figsize=(2.2 * len(families), 2.4 * rows))
    for col, family in enumerate(families):
        for row in range(rows):
            generated = generate_tool(family, seed + row)
            ax = fig.add_subplot(
                rows, len(families), row * len(families) + col + 1, projection="3d"
            )
            vertices, faces = tool_mesh(generated.tool)
            ax.add_collection3d(
                Poly3DCollection(
                    vertices[faces], facecolors=GREY, edgecolors=GREY, linewidths=0, shade=True
                )
            )
            frames = {k: v for k, v in generated.tool.frames().items() if k != GRASP}
            points = np.array([X.translation for X in frames.values()])
            ax.scatter(*points.T, color="tab:orange", s=12, depthshade=False)
            ax.scatter([0], [0], [0], color="tab:blue", s=12, depthshade=False)  # the grasp
            centre = (vertices.max(0) + vertices.min(0)) / 2
            half = (vertices.max(0) - vertices.min(0)).max() / 2
            for axis, c in zip("xyz", centre):
                getattr(ax, f"set_{axis}lim")(c - half, c + half)
            ax.set_box_aspect((1, 1, 1), zoom=1.5)
            ax.view_init(elev=20, azim=-60)
            ax.set_axis_off()
            ax.set_title(f"{family} s{seed + row}", fontsize=8)
    fig.suptitle(
        "Generated tools, a family per column (blue: the grasp; orange: the working frames)",
        fontsize=10,
    )
    fig.subplots_adjust(left=0, right=1, bottom=0, top=0.93, wspace=0, hspace=0.1)
    return fig


def gallery_contents(seed: int = 0, rows: int = GALLERY_ROWS) -> list[dict]:
    """What the gallery shows: each tool's family, seed and parameters (`GeneratedTool`)."""
    return [
        generate_tool(family, seed + row).as_dict() for row in range(rows) for family in FAMILIES
    ]


def write_gallery(path, seed: int = 0, rows: int = GALLERY_ROWS) -> dict:
    """The gallery (`gallery_figure`) written to `path` (PNG) and what it shows beside it
    (`gallery_contents`, the same name with .json), each atomically. Returns both paths."""
    path = Path(path)
    figure = gallery_figure(seed, rows)
    atomic_write_figure(path, figure)
    contents = path.with_suffix(".json")
    atomic_write_json(contents, {"seed": seed, "rows": rows, "tools": gallery_contents(seed, rows)})
    return {"png": str(path), "json": str(contents)}
