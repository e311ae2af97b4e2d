"""A tool from a mesh file (OBJ or STL): the mesh as its visual geometry, a convex decomposition
of it as its collision geometry, its inertia from the closed mesh, and its working frames from a
sidecar file, written as an SDFormat model that `robot.model.load_tool_model` reads (and a
scenario holds with `tool: {model: DIR/tool.sdf}`).

Why a decomposition: Drake's point contact takes a `Mesh`'s convex hull, and a `Convex` is a
hull by definition; Drake offers no decomposition. A hull fills a hook's concavity, the very
part it works with: `benchmarks/mesh_collision.py` measures how much of it each fills. CoACD
(PyPI `coacd`, approximate convex decomposition) splits the mesh into convex parts that follow
the concavity within its `threshold`.

The sidecar (YAML) names the frames in the mesh's own coordinates (after `scale`):

    frames: {tool_tip: [x, y, z], hook_corner: [x, y, z]}   # tool_tip required
    grasp: [x, y, z]    # where the hand holds it (default the mesh's origin)
    mass: 0.08          # kg (default: solid PLA, DENSITY, times the mesh's volume)
    scale: 0.001        # the mesh's units in metres (default 1)

The handle frame H is the mesh's frame moved to `grasp`, axes kept: +z must run along the
handle, away from the hand, as for every tool here.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from pydrake.geometry import Mesh
from pydrake.multibody.tree import CalcSpatialInertia, SpatialInertia

from drake_tooluse.files import atomic_dir, atomic_write_text, read_yaml
from drake_tooluse.robot.tool import (
    GRASP,
    TOOL_TIP,
    CompositeTool,
    MassProperties,
    MeshShape,
    Piece,
    Pose,
)
from drake_tooluse.robot.tool_files import tool_sdf
from drake_tooluse.robot.tool_generator import DENSITY, MAX_MASS
from drake_tooluse.validation import check_finite_vector, check_in_range, check_one_of

COLLISIONS = ("coacd", "hull")
COACD_THRESHOLD = 0.03  # CoACD's concavity threshold (its default 0.05; smaller: more parts)
MAX_VERTICES = 200_000
SIDECAR_KEYS = {"frames", "grasp", "mass", "scale"}


def _trimesh():
    try:
        import trimesh
    except ImportError:
        raise ImportError(
            "importing a mesh tool needs trimesh and coacd: pip install 'drake-tooluse[meshes]'"
        ) from None
    return trimesh


def read_sidecar(path) -> dict:
    """The sidecar's frames (name -> 3 floats), grasp, mass and scale, checked."""
    data = read_yaml(path, "tool sidecar")
    if not isinstance(data, dict) or not set(data) <= SIDECAR_KEYS:
        raise ValueError(f"{path}: a tool sidecar is a mapping of {sorted(SIDECAR_KEYS)}")
    frames = data.get("frames")
    if not isinstance(frames, dict) or TOOL_TIP not in frames:
        raise ValueError(f"{path}: frames must be a mapping with a {TOOL_TIP!r} frame")
    if GRASP in frames:
        raise ValueError(f"{path}: give the grasp as `grasp:`, not as a frame")
    out = {
        "frames": {
            str(k): check_finite_vector(v, 3, f"{path}: frames.{k}") for k, v in frames.items()
        },
        "grasp": check_finite_vector(data.get("grasp", [0, 0, 0]), 3, f"{path}: grasp"),
        "scale": check_in_range(
            data.get("scale", 1.0), 0.0, 1e3, f"{path}: scale", lower_inclusive=False
        ),
        "mass": None,
    }
    if data.get("mass") is not None:
        out["mass"] = check_in_range(
            data["mass"], 0.0, MAX_MASS, f"{path}: mass", unit="kg", lower_inclusive=False
        )
    return out


def _load_mesh(mesh_path, scale: float, grasp: np.ndarray):
    """The mesh (trimesh), in metres, moved so that the grasp is at the origin; a mesh that
    is not closed (no volume, no inertia) is refused."""
    trimesh = _trimesh()
    try:  # as written: an OBJ of closed pieces that touch stays closed piece by piece
        mesh = trimesh.load(str(mesh_path), force="mesh", process=False)
    except Exception as e:  # trimesh raises many kinds for a file it cannot read
        raise ValueError(f"{mesh_path}: not a readable OBJ or STL mesh ({e})") from None
    if not mesh.is_watertight:  # an STL repeats each triangle's corners: join them
        mesh.merge_vertices()
    if len(mesh.vertices) == 0 or len(mesh.vertices) > MAX_VERTICES:
        raise ValueError(f"{mesh_path}: {len(mesh.vertices)} vertices; 1 to {MAX_VERTICES} allowed")
    mesh.apply_scale(scale)
    mesh.apply_translation(-grasp)
    if not mesh.is_watertight:
        raise ValueError(f"{mesh_path}: the mesh is not closed; its volume and inertia need it")
    return mesh


def convex_parts(mesh, collision: str) -> list:
    """The collision parts (trimesh meshes, each convex): CoACD's decomposition, or the hull."""
    if collision == "hull":
        return [mesh.convex_hull]
    import coacd

    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)),
        threshold=COACD_THRESHOLD,
        seed=0,
    )
    trimesh = _trimesh()
    return [trimesh.Trimesh(vertices, faces) for vertices, faces in parts]


def import_mesh_tool(mesh_path, sidecar_path, out_dir, collision: str = "coacd") -> dict:
    """Writes the tool of `mesh_path` (OBJ or STL) and its sidecar into the new directory
    `out_dir`: `visual.obj`, `collision_NN.obj` (the convex parts), `tool.sdf`. Returns what
    it wrote and measured: the parts, the mass, the decomposition's seconds."""
    check_one_of(collision, COLLISIONS, "collision")
    if any(c in str(Path(out_dir).absolute()) for c in "\n\r"):
        raise ValueError(
            f"out_dir={str(out_dir)!r} holds a line break, which Drake's mesh file names cannot"
        )
    sidecar = read_sidecar(sidecar_path)
    mesh = _load_mesh(mesh_path, sidecar["scale"], np.array(sidecar["grasp"]))
    start = time.perf_counter()
    parts = convex_parts(mesh, collision)
    seconds = time.perf_counter() - start
    out_dir = Path(out_dir)
    with atomic_dir(out_dir) as work:
        work = Path(work)
        atomic_write_text(work / "visual.obj", mesh.export(file_type="obj"))
        names = []
        for i, part in enumerate(parts):
            names.append(f"collision_{i:02d}.obj")
            atomic_write_text(work / names[-1], part.export(file_type="obj"))
        # The inertia of the closed mesh, by Drake, at the sidecar's mass or solid PLA's.
        M = CalcSpatialInertia(Mesh(str(work / "visual.obj")), DENSITY)
        if sidecar["mass"] is not None:  # the same shape of inertia, the mass given
            M = SpatialInertia(sidecar["mass"], M.get_com(), M.get_unit_inertia())
        G = M.get_unit_inertia()
        inertia = MassProperties(
            M.get_mass(), tuple(M.get_com()), (*G.get_moments(), *G.get_products())
        )
        grasp = np.array(sidecar["grasp"])
        frames = {name: Pose(tuple(np.array(p) - grasp)) for name, p in sidecar["frames"].items()}
        final = out_dir.absolute()
        tool = CompositeTool(
            frames,
            solids=(Piece("tool_visual", MeshShape(str(final / "visual.obj"))),),
            collisions=tuple(
                Piece(f"tool_collision_{i:02d}", MeshShape(str(final / n), convex=True))
                for i, n in enumerate(names)
            ),
            inertia=inertia,
        )
        atomic_write_text(work / "tool.sdf", tool_sdf(tool, "tool", final))
    return {
        "sdf": str(final / "tool.sdf"),
        "collision": collision,
        "parts": len(parts),
        "decomposition_s": seconds,
        "mass_kg": float(M.get_mass()),
        "volume_m3": float(mesh.volume),
        "parts_volume_m3": float(sum(p.volume for p in parts)),
        "frames": list(frames),
    }
