"""A tool description written as files: an SDFormat model (its pieces as primitive visual and
collision geometry, its inertia, its named frames) that `robot.model.load_tool_model` reads back,
and a triangle mesh of its solid pieces (Wavefront OBJ and binary STL) for other tools (a
slicer, a viewer, another simulator). SI units; the mesh in metres, in the handle frame H.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np
import yaml
from pydrake.geometry import ReadObjToTriangleSurfaceMesh
from pydrake.math import RollPitchYaw, RotationMatrix

from drake_tooluse.files import atomic_write_bytes, atomic_write_text
from drake_tooluse.robot.model import tool_spatial_inertia
from drake_tooluse.robot.tool import GRASP, BoxShape, CylinderShape, MeshShape, Piece, Pose, Tool

CYLINDER_SIDES = 32  # facets around a cylinder of the mesh
TOOL_RGBA = (0.55, 0.55, 0.6, 1.0)  # a piece's colour where it gives none


def _pose_text(X: Pose) -> str:
    """SDFormat's `x y z roll pitch yaw` (the same RPY convention as Drake's)."""
    rpy = RollPitchYaw(RotationMatrix(np.array(X.rotation))).vector()
    return " ".join(f"{v:.17g}" for v in (*X.translation, *rpy))


def _geometry(piece: Piece, base_dir: Path | None) -> str:
    shape = piece.shape
    if isinstance(shape, MeshShape):  # its path relative to the SDF's folder where it can be
        uri = Path(shape.path)
        if base_dir is not None and uri.is_absolute() and uri.is_relative_to(base_dir):
            uri = uri.relative_to(base_dir)
        convex = "<drake:declare_convex/>" if shape.convex else ""
        return f"<mesh><uri>{escape(str(uri))}</uri>{convex}</mesh>"
    if isinstance(shape, CylinderShape):
        return (
            f"<cylinder><radius>{shape.radius:.17g}</radius>"
            f"<length>{shape.length:.17g}</length></cylinder>"
        )
    return "<box><size>{}</size></box>".format(" ".join(f"{v:.17g}" for v in shape.size))


def tool_sdf(tool: Tool, name: str = "tool", base_dir=None) -> str:
    """The SDFormat text of `tool`: one model `name` of one link `tool` (H, the grasp frame),
    its inertia about its centre of mass (`robot.model.tool_spatial_inertia`), a visual and a
    collision geometry per piece, and a frame per named frame. A mesh piece's file is named
    relative to `base_dir` (the SDF's folder) where it lies below it."""
    base_dir = None if base_dir is None else Path(base_dir).absolute()
    M = tool_spatial_inertia(tool)
    p_com = M.get_com()
    I_Scm = M.Shift(p_com).CalcRotationalInertia()  # about the centre of mass, in H
    m = I_Scm.get_moments()
    products = I_Scm.get_products()
    inertia = "".join(
        f"<{k}>{v:.17g}</{k}>"
        for k, v in zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), (*m, *products))
    )
    lines = [
        '<?xml version="1.0"?>',
        '<sdf version="1.9" xmlns:drake="http://drake.mit.edu">',
        f"  <model name={quoteattr(name)}>",
        '    <link name="tool">',
        "      <inertial>",
        "        <pose>{} 0 0 0</pose>".format(" ".join(f"{v:.17g}" for v in p_com)),
        f"        <mass>{M.get_mass():.17g}</mass>",
        f"        <inertia>{inertia}</inertia>",
        "      </inertial>",
    ]
    for piece in tool.pieces():
        rgba = " ".join(f"{v:g}" for v in (piece.rgba or TOOL_RGBA))
        lines += [
            f"      <visual name={quoteattr(piece.name)}>",
            f"        <pose>{_pose_text(piece.X_HP)}</pose>",
            f"        <geometry>{_geometry(piece, base_dir)}</geometry>",
            f"        <material><diffuse>{rgba}</diffuse></material>",
            "      </visual>",
        ]
    for piece in tool.collision_pieces():
        lines += [
            f"      <collision name={quoteattr(piece.name)}>",
            f"        <pose>{_pose_text(piece.X_HP)}</pose>",
            f"        <geometry>{_geometry(piece, base_dir)}</geometry>",
            "      </collision>",
        ]
    lines.append("    </link>")
    for frame, X in tool.frames().items():
        lines += [
            f'    <frame name={quoteattr(frame)} attached_to="tool">',
            f"      <pose>{_pose_text(X)}</pose>",
            "    </frame>",
        ]
    lines += ["  </model>", "</sdf>", ""]
    return "\n".join(lines)


def _cylinder_mesh(shape: CylinderShape) -> tuple[np.ndarray, np.ndarray]:
    n, r, h = CYLINDER_SIDES, shape.radius, shape.length / 2
    angles = 2 * math.pi * np.arange(n) / n
    ring = np.stack([r * np.cos(angles), r * np.sin(angles)], axis=1)
    bottom = np.column_stack([ring, np.full(n, -h)])
    top = np.column_stack([ring, np.full(n, h)])
    vertices = np.vstack([bottom, top, [[0, 0, -h], [0, 0, h]]])
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [(i, j, n + j), (i, n + j, n + i)]  # the side, outward
        faces += [(2 * n, j, i), (2 * n + 1, n + i, n + j)]  # the caps, outward
    return vertices, np.array(faces)


def _box_mesh(shape: BoxShape) -> tuple[np.ndarray, np.ndarray]:
    half = np.array(shape.size) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    # Each side as two triangles, counter-clockwise seen from outside.
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return corners, np.array(faces)


def _file_mesh(shape: MeshShape) -> tuple[np.ndarray, np.ndarray]:
    mesh = ReadObjToTriangleSurfaceMesh(shape.path)
    faces = np.array([[t.vertex(i) for i in range(3)] for t in mesh.triangles()])
    return np.array(mesh.vertices()), faces


def tool_mesh(tool: Tool) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) in H, m; triangles (k, 3) of vertex indices, outward) of the tool's
    solid pieces, each closed on its own."""
    all_vertices, all_faces, offset = [], [], 0
    for piece in tool.pieces():
        mesh = {CylinderShape: _cylinder_mesh, BoxShape: _box_mesh, MeshShape: _file_mesh}
        vertices, faces = mesh[type(piece.shape)](piece.shape)
        R, p = np.array(piece.X_HP.rotation), np.array(piece.X_HP.translation)
        all_vertices.append(vertices @ R.T + p)
        all_faces.append(faces + offset)
        offset += len(vertices)
    return np.vstack(all_vertices), np.vstack(all_faces)


def obj_text(vertices: np.ndarray, faces: np.ndarray) -> str:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    return "\n".join(["# drake-tooluse tool mesh, metres, handle frame H", *lines, ""])


def stl_bytes(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """Binary STL: an 80-byte header, the triangle count, each triangle's normal and corners."""
    out = [b"drake-tooluse tool mesh, metres, handle frame H".ljust(80, b" ")]
    out.append(struct.pack("<I", len(faces)))
    for a, b, c in faces:
        p, q, r = vertices[a], vertices[b], vertices[c]
        normal = np.cross(q - p, r - p)
        norm = np.linalg.norm(normal)
        normal = normal / norm if norm > 0 else normal
        out.append(struct.pack("<12fH", *normal, *p, *q, *r, 0))
    return b"".join(out)


def sidecar_text(tool: Tool) -> str:
    """The sidecar `robot.mesh_import` reads beside the tool's OBJ: its frames but the grasp,
    in the mesh's coordinates (H, where the grasp is the origin)."""
    frames = {k: list(X.translation) for k, X in tool.frames().items() if k != GRASP}
    return yaml.safe_dump({"frames": frames})


def write_tool_files(tool: Tool, out_dir, name: str = "tool") -> dict:
    """Writes `tool.sdf`, `tool.obj`, `tool.stl` and `sidecar.yaml` (`sidecar_text`) into
    `out_dir` (made if missing), each atomically. Returns their paths by kind."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    vertices, faces = tool_mesh(tool)
    paths = {kind: out_dir / f"{name}.{kind}" for kind in ("sdf", "obj", "stl")}
    paths["sidecar"] = out_dir / "sidecar.yaml"
    atomic_write_text(paths["sdf"], tool_sdf(tool, name, out_dir))
    atomic_write_text(paths["obj"], obj_text(vertices, faces))
    atomic_write_bytes(paths["stl"], stl_bytes(vertices, faces))
    atomic_write_text(paths["sidecar"], sidecar_text(tool))
    return {kind: str(path) for kind, path in paths.items()}
