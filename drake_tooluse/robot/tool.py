"""Tools are geometry: a typed description of the tool a hand holds. No Drake here, so the
command line can check a tool before it imports anything heavy (`check_tool_length`).

A tool is one rigid body described in its handle frame H: H is at the grasp point (where the hand
holds it), +z along the tool axis. A description gives

- named frames, each a fixed pose X_HF in H: `grasp` (H itself), `tool_tip`, and the
  functional points a task names (`Tool.frames`);
- pieces: primitive shapes (cylinders along their own +z, boxes) at poses X_HP in H, which
  make its visual geometry and its inertia, the mass spread over them by volume
  (`Tool.pieces`); its collision geometry (`Tool.collision_pieces`, by default the same) and
  the camera's orange marker bands (`Tool.marker_pieces`, by default none).

Kinds: `StraightTool(length)` is a rod (a one-liner); `CompositeTool` is any tool given by its
frames and pieces (several pieces, frames anywhere: a hook's inner corner); a tool loaded
from a model file is a `CompositeTool` too (`robot.model.load_tool_model`).
`robot.model.add_tool_body` welds a description into a plant; `world.scene.add_tool` gives the
world's tool its geometry. Poses are plain tuples (`Pose`); SI units.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np

from drake_tooluse.validation import check_finite_vector, check_in_range, check_positive

TOOL_LENGTH_RANGE = (0.0, 0.60)  # exclusive lower bound, inclusive upper bound (m)
GRASP = "grasp"  # the frame H itself: where the hand holds the tool
TOOL_TIP = "tool_tip"
# A straight tool's defaults.
DEFAULT_TOOL_RADIUS = 0.006  # m
DEFAULT_TOOL_MASS = 0.05  # kg
DEFAULT_MARKER_LENGTH = 0.012  # m, each orange band at the grip end and at the tip
# The rod reaches this far into the closed fingers behind the grasp point (m).
TOOL_HANDLE_DEPTH = 0.03
# The rod's tip end is a collision geometry of its own, this long (m).
TIP_COLLISION_LENGTH = 0.04
MARKER_RADIUS_SCALE = 1.15  # a marker band's radius over the rod's


def check_tool_length(length, name="tool length") -> float:
    """A tool length in (0, 0.60] m; returns it as a float."""
    lo, hi = TOOL_LENGTH_RANGE
    return check_in_range(length, lo, hi, name, unit="m", lower_inclusive=False)


_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def _finite_floats(values, size: int) -> bool:
    return (
        type(values) is tuple
        and len(values) == size
        and all(isinstance(v, float) and math.isfinite(v) for v in values)
    )


def _is_plain(translation, rotation) -> bool:
    """Whether both are tuples of finite floats (3, and 3 rows of 3). A tool's poses are made
    a few dozen times an episode: numpy's cost per call on these nine numbers was most of a
    pull episode's tool building."""
    return (
        _finite_floats(translation, 3)
        and type(rotation) is tuple
        and len(rotation) == 3
        and all(_finite_floats(row, 3) for row in rotation)
    )


def _is_rotation(R) -> bool:
    """Whether the 3x3 rows R are orthonormal to 1e-9 and right-handed."""
    for i in range(3):
        for j in range(3):
            dot = R[i][0] * R[j][0] + R[i][1] * R[j][1] + R[i][2] * R[j][2]
            if abs(dot - (1.0 if i == j else 0.0)) > 1e-9:
                return False
    (a, b, c), (d, e, f), (g, h, k) = R
    return a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g) >= 0.0


@dataclass(frozen=True)
class Pose:
    """A rigid transform X_AB as plain tuples: translation p_AB (m) and rotation R_AB (rows)."""

    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[tuple[float, float, float], ...] = _IDENTITY

    def __post_init__(self):
        if _is_plain(self.translation, self.rotation):  # the common case, without numpy
            p, R = self.translation, self.rotation
        else:
            p = check_finite_vector(self.translation, 3, "pose translation")
            R = check_finite_vector(self.rotation, 9, "pose rotation").reshape(3, 3).tolist()
        if not _is_rotation(R):
            raise ValueError(f"pose rotation {[list(row) for row in R]} is not a rotation matrix")
        object.__setattr__(self, "translation", tuple(float(v) for v in p))
        object.__setattr__(self, "rotation", tuple(tuple(float(v) for v in row) for row in R))

    @staticmethod
    def from_rpy(rpy, xyz=(0.0, 0.0, 0.0)) -> Pose:
        """Roll-pitch-yaw (rad) as Drake's RollPitchYaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
        r, p, y = check_finite_vector(rpy, 3, "roll-pitch-yaw")
        cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
        R = np.array(
            [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ]
        )
        return Pose(tuple(xyz), tuple(map(tuple, R)))

    @staticmethod
    def from_matrix(X) -> Pose:
        """From a 4x4 homogeneous matrix."""
        X = check_finite_vector(X, 16, "pose matrix").reshape(4, 4)
        if not np.array_equal(X[3], [0.0, 0.0, 0.0, 1.0]):
            raise ValueError(f"pose matrix last row {X[3].tolist()} must be [0, 0, 0, 1]")
        return Pose(tuple(X[:3, 3]), tuple(map(tuple, X[:3, :3])))

    def matrix(self) -> np.ndarray:
        """The 4x4 homogeneous matrix."""
        X = np.eye(4)
        X[:3, :3] = self.rotation
        X[:3, 3] = self.translation
        return X

    def is_translation(self) -> bool:
        """Whether R_AB is exactly the identity."""
        return self.rotation == _IDENTITY

    def __matmul__(self, other: Pose) -> Pose:
        """X_AC = X_AB @ X_BC."""
        return Pose.from_matrix(self.matrix() @ other.matrix())

    def inverse(self) -> Pose:
        R = np.array(self.rotation)
        return Pose(tuple(-R.T @ np.array(self.translation)), tuple(map(tuple, R.T)))


@dataclass(frozen=True)
class CylinderShape:
    """A solid cylinder centred on its frame's origin, its axis along the frame's +z (m)."""

    radius: float
    length: float

    def __post_init__(self):
        object.__setattr__(self, "radius", check_positive(self.radius, "cylinder radius", "m"))
        object.__setattr__(self, "length", check_positive(self.length, "cylinder length", "m"))

    def volume(self) -> float:
        return math.pi * self.radius**2 * self.length


@dataclass(frozen=True)
class BoxShape:
    """A solid box centred on its frame's origin, its sides (m) along the frame's x, y, z."""

    size: tuple[float, float, float]

    def __post_init__(self):
        size = check_finite_vector(self.size, 3, "box size")
        for i, v in enumerate(size):
            check_positive(v, f"box size[{i}]", "m")
        object.__setattr__(self, "size", tuple(float(v) for v in size))

    def volume(self) -> float:
        return self.size[0] * self.size[1] * self.size[2]


@dataclass(frozen=True)
class MeshShape:
    """A triangle mesh file (Wavefront OBJ, metres, in its piece's frame): visual geometry, or
    with `convex` a convex collision piece (Drake's `Convex`: the hull of its vertices). A
    mesh's volume is not computed here: a tool of meshes gives its inertia outright
    (`MassProperties`, as `robot.mesh_import` does)."""

    path: str
    convex: bool = False

    def __post_init__(self):
        if not isinstance(self.path, str) or not self.path.lower().endswith(".obj"):
            raise ValueError(f"mesh {self.path!r} must be the path of an OBJ file")

    def volume(self) -> float:
        raise ValueError(f"mesh {self.path!r}: a tool of meshes gives its mass properties outright")


@dataclass(frozen=True)
class Piece:
    """A primitive shape of a tool at X_HP in its handle frame H. `name` is its geometry's
    name; `rgba` its colour (None: the scene's tool colour)."""

    name: str
    shape: CylinderShape | BoxShape | MeshShape
    X_HP: Pose = Pose()
    rgba: tuple[float, float, float, float] | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"a tool piece's name must be a non-empty string, not {self.name!r}")
        if not isinstance(self.shape, (CylinderShape, BoxShape, MeshShape)):
            raise ValueError(
                f"tool piece {self.name!r}: shape {self.shape!r} must be a CylinderShape, a "
                "BoxShape or a MeshShape"
            )
        if not isinstance(self.X_HP, Pose):
            raise ValueError(f"tool piece {self.name!r}: X_HP must be a Pose")
        if self.rgba is not None:
            rgba = check_finite_vector(self.rgba, 4, f"tool piece {self.name!r} rgba")
            object.__setattr__(self, "rgba", tuple(float(v) for v in rgba))


@dataclass(frozen=True)
class MassProperties:
    """A tool's inertia given outright (a model file's) instead of made from its pieces: mass
    (kg), the centre of mass p_HScm (m) and the unit inertia about Ho expressed in H, G_SHo_H
    (moments Ixx Iyy Izz, then products Ixy Ixz Iyz, m²), as Drake's SpatialInertia holds it."""

    mass: float
    p_HScm: tuple[float, float, float]
    G_SHo_H: tuple[float, float, float, float, float, float]

    def __post_init__(self):
        object.__setattr__(self, "mass", check_positive(self.mass, "tool mass", "kg"))
        p = check_finite_vector(self.p_HScm, 3, "tool centre of mass")
        G = check_finite_vector(self.G_SHo_H, 6, "tool unit inertia")
        object.__setattr__(self, "p_HScm", tuple(float(v) for v in p))
        object.__setattr__(self, "G_SHo_H", tuple(float(v) for v in G))


class Tool(abc.ABC):
    """A rigid tool held in the hand: named frames and primitive pieces in its handle frame H.

    Subclasses give `frames` and `pieces` and have a `mass` (kg); the others have defaults."""

    @abc.abstractmethod
    def frames(self) -> dict[str, Pose]:
        """X_HF of each named frame: `grasp` (the identity) first, `tool_tip`, then any others."""

    @abc.abstractmethod
    def pieces(self) -> tuple[Piece, ...]:
        """The solid pieces: the visual geometry and (unless `mass_properties`) the inertia."""

    def collision_pieces(self) -> tuple[Piece, ...]:
        """The collision geometry (default: the solid pieces)."""
        return self.pieces()

    def marker_pieces(self) -> tuple[Piece, ...]:
        """The camera's orange marker bands (visual only; default: none)."""
        return ()

    def mass_properties(self) -> MassProperties | None:
        """The inertia given outright, or None: made from the pieces and `mass`."""
        return None

    def piece_masses(self) -> tuple[float, ...]:
        """Each solid piece's mass (kg): `mass` spread by volume."""
        pieces = self.pieces()
        if len(pieces) == 1:
            return (float(self.mass),)
        volumes = [p.shape.volume() for p in pieces]
        return tuple(float(self.mass) * v / sum(volumes) for v in volumes)

    def frame_names(self) -> list[str]:
        return list(self.frames())

    def X_HF(self, name: str) -> Pose:
        """The pose of frame `name` in H; an unknown name is an error naming the frames."""
        frames = self.frames()
        if name not in frames:
            raise ValueError(
                f"frame {name!r} is not a frame of the tool; choose one of {list(frames)}"
            )
        return frames[name]

    def reach(self) -> float:
        """‖p_HT‖: how far the tip is from the grasp point (m); a straight tool's length."""
        return float(np.linalg.norm(self.X_HF(TOOL_TIP).translation))

    def check(self) -> None:
        """Raises ValueError unless the frames and pieces make a tool: `grasp` is H, a
        `tool_tip` frame, non-empty unique frame names, unique piece names, some pieces (or
        the inertia given outright)."""
        frames = self.frames()
        for name in frames:
            if not isinstance(name, str) or not name:
                raise ValueError(f"a tool frame's name must be a non-empty string, not {name!r}")
        if frames.get(GRASP) != Pose():
            raise ValueError(f"a tool's {GRASP!r} frame must be its handle frame H (the identity)")
        if TOOL_TIP not in frames:
            raise ValueError(f"a tool needs a {TOOL_TIP!r} frame; it has {list(frames)}")
        for kind, pieces in (
            ("solid", self.pieces()),
            ("collision", self.collision_pieces()),
            ("marker", self.marker_pieces()),
        ):
            names = [p.name for p in pieces]
            if len(set(names)) != len(names):
                raise ValueError(f"the tool's {kind} pieces have repeated names: {names}")
        if not self.pieces() and self.mass_properties() is None:
            raise ValueError("a tool needs solid pieces or its mass properties")


@dataclass(frozen=True)
class StraightTool(Tool):
    """A rod of `length` m from the grasp point to the tip along +z of H, reaching
    TOOL_HANDLE_DEPTH behind the grasp point into the hand; a solid cylinder of `radius` and
    `mass`, with orange bands `marker_length` long at the grip end and at the tip. Its
    collision geometry starts at the grasp point (the handle is inside the hand); the tip
    end is a short cylinder of its own (a single long thin cylinder gives FCL's penetration
    query wrong normals: a 0.40 m tool pressed into the box's side came out through its top
    face and pinned the box to the table). Frames: `grasp`, `tool_tip` at [0, 0, length]."""

    length: float
    radius: float = DEFAULT_TOOL_RADIUS
    mass: float = DEFAULT_TOOL_MASS
    marker_length: float = DEFAULT_MARKER_LENGTH

    def __post_init__(self):
        object.__setattr__(self, "length", check_tool_length(self.length))
        object.__setattr__(self, "radius", check_positive(self.radius, "tool radius", "m"))
        object.__setattr__(self, "mass", check_positive(self.mass, "tool mass", "kg"))
        object.__setattr__(
            self, "marker_length", check_positive(self.marker_length, "tool marker length", "m")
        )

    def frames(self) -> dict[str, Pose]:
        return {GRASP: Pose(), TOOL_TIP: Pose((0.0, 0.0, self.length))}

    def dimensions(self) -> dict[str, float]:
        """What the head camera measures of it, named with their units (m)."""
        return {"length_m": self.length}

    def center(self) -> tuple[float, float, float]:
        """p_HC: the rod's centre (it runs from TOOL_HANDLE_DEPTH behind H to `length`)."""
        return (0.0, 0.0, (self.length - TOOL_HANDLE_DEPTH) / 2)

    def pieces(self) -> tuple[Piece, ...]:
        shape = CylinderShape(self.radius, self.length + TOOL_HANDLE_DEPTH)
        return (Piece("tool_visual", shape, Pose(self.center())),)

    def collision_pieces(self) -> tuple[Piece, ...]:
        L = self.length
        tip = min(L, TIP_COLLISION_LENGTH)
        pieces = [
            Piece("tool_tip_collision", CylinderShape(self.radius, tip), Pose((0, 0, L - tip / 2)))
        ]
        if L > tip:
            pieces.append(
                Piece(
                    "tool_collision",
                    CylinderShape(self.radius, L - tip),
                    Pose((0, 0, (L - tip) / 2)),
                )
            )
        return tuple(pieces)

    def marker_pieces(self) -> tuple[Piece, ...]:
        m, L = self.marker_length, self.length
        shape = CylinderShape(self.radius * MARKER_RADIUS_SCALE, m)
        return tuple(
            Piece(name, shape, Pose((0, 0, z)))
            for name, z in (("grip_marker", m / 2), ("tip_marker", L - m / 2))
        )

    def reach(self) -> float:
        return self.length


@dataclass(frozen=True)
class CompositeTool(Tool):
    """Any tool given by its parts: `named_frames` (name -> X_HF; `grasp`, the identity, is
    added first if missing; `tool_tip` is required), `solids` (its solid pieces), `mass` (kg,
    spread over the solids by volume; default 0.05) or `inertia` (given outright; then `mass`
    is its mass), `collisions` (None: the solids) and `markers`."""

    named_frames: tuple[tuple[str, Pose], ...]
    solids: tuple[Piece, ...] = ()
    mass: float | None = None
    collisions: tuple[Piece, ...] | None = None
    markers: tuple[Piece, ...] = ()
    inertia: MassProperties | None = None

    def __post_init__(self):
        items = (
            self.named_frames.items()
            if isinstance(self.named_frames, dict)
            else tuple(self.named_frames)
        )
        frames = dict(items)
        if GRASP not in frames:
            frames = {GRASP: Pose(), **frames}
        else:
            frames = {GRASP: frames.pop(GRASP), **frames}
        for name, X in frames.items():
            if not isinstance(X, Pose):
                raise ValueError(f"tool frame {name!r}: its pose must be a Pose, not {X!r}")
        object.__setattr__(self, "named_frames", tuple(frames.items()))
        object.__setattr__(self, "solids", tuple(self.solids))
        object.__setattr__(self, "markers", tuple(self.markers))
        if self.collisions is not None:
            object.__setattr__(self, "collisions", tuple(self.collisions))
        if self.inertia is not None:
            if self.mass is not None and float(self.mass) != self.inertia.mass:
                raise ValueError(
                    f"tool mass={self.mass} kg differs from its inertia's {self.inertia.mass} kg"
                )
            object.__setattr__(self, "mass", self.inertia.mass)
        else:
            mass = self.mass if self.mass is not None else DEFAULT_TOOL_MASS
            object.__setattr__(self, "mass", check_positive(mass, "tool mass", "kg"))
        self.check()

    def frames(self) -> dict[str, Pose]:
        return dict(self.named_frames)

    def pieces(self) -> tuple[Piece, ...]:
        return self.solids

    def collision_pieces(self) -> tuple[Piece, ...]:
        return self.solids if self.collisions is None else self.collisions

    def marker_pieces(self) -> tuple[Piece, ...]:
        return self.markers

    def mass_properties(self) -> MassProperties | None:
        return self.inertia


# A hook's ranges (handle and hook lengths in m, the angle in degrees).
HOOK_HANDLE_RANGE = (0.15, 0.35)
HOOK_LENGTH_RANGE = (0.03, 0.08)
HOOK_ANGLE_RANGE = (60.0, 120.0)
HOOK_CORNER = "hook_corner"


@dataclass(frozen=True)
class HookTool(Tool):
    """A hook: a straight handle `handle_length` m from the grasp point along +z of H (reaching
    TOOL_HANDLE_DEPTH behind it into the hand, as a straight tool does), and at its end a hook
    `hook_length` m long at `angle` degrees to the handle, in the x–z plane of H: 90° is an L
    (the hook along +x), less bends it back towards the hand (a J, which holds what it pulls),
    more opens it. Both are cylinders of `radius`; `mass` is spread over them by volume.

    Frames: `grasp`; `hook_corner` at [0, 0, handle_length], the inside of the bend, where a
    pulled object rests; `tool_tip` at the hook's end, [sin a, 0, −cos a] · hook_length from
    the corner. All keep H's orientation (a tip target's orientation is the handle's). Marker
    bands: at the grip end, at the corner and at the hook's end (what the camera finds)."""

    handle_length: float
    hook_length: float
    angle: float = 90.0
    radius: float = DEFAULT_TOOL_RADIUS
    mass: float = DEFAULT_TOOL_MASS
    marker_length: float = DEFAULT_MARKER_LENGTH

    def __post_init__(self):
        check = check_in_range
        object.__setattr__(
            self,
            "handle_length",
            check(self.handle_length, *HOOK_HANDLE_RANGE, "hook handle length", unit="m"),
        )
        object.__setattr__(
            self,
            "hook_length",
            check(self.hook_length, *HOOK_LENGTH_RANGE, "hook length", unit="m"),
        )
        object.__setattr__(
            self, "angle", check(self.angle, *HOOK_ANGLE_RANGE, "hook angle", unit="°")
        )
        object.__setattr__(self, "radius", check_positive(self.radius, "tool radius", "m"))
        object.__setattr__(self, "mass", check_positive(self.mass, "tool mass", "kg"))
        object.__setattr__(
            self, "marker_length", check_positive(self.marker_length, "tool marker length", "m")
        )

    def dimensions(self) -> dict[str, float]:
        """What the head camera measures of it, named with their units (m, deg)."""
        return {
            "handle_length_m": self.handle_length,
            "hook_length_m": self.hook_length,
            "angle_deg": self.angle,
        }

    def direction(self) -> np.ndarray:
        """The unit vector from the corner to the hook's end, in H."""
        a = math.radians(self.angle)
        return np.array([math.sin(a), 0.0, -math.cos(a)])

    def _hook_pose(self, along: float) -> Pose:
        """A pose on the hook `along` m from the corner, its +z along the hook."""
        d = self.direction()
        phi = math.atan2(d[0], d[2])  # the rotation about y that takes +z onto d
        c, s = math.cos(phi), math.sin(phi)
        p = np.array([0.0, 0.0, self.handle_length]) + along * d
        return Pose(tuple(p), ((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c)))

    def frames(self) -> dict[str, Pose]:
        corner = (0.0, 0.0, self.handle_length)
        tip = tuple(np.array(corner) + self.hook_length * self.direction())
        return {GRASP: Pose(), TOOL_TIP: Pose(tip), HOOK_CORNER: Pose(corner)}

    def pieces(self) -> tuple[Piece, ...]:
        handle = CylinderShape(self.radius, self.handle_length + TOOL_HANDLE_DEPTH)
        hook = CylinderShape(self.radius, self.hook_length)
        return (
            Piece(
                "tool_handle", handle, Pose((0, 0, (self.handle_length - TOOL_HANDLE_DEPTH) / 2))
            ),
            Piece("tool_hook", hook, self._hook_pose(self.hook_length / 2)),
        )

    def collision_pieces(self) -> tuple[Piece, ...]:
        # The handle from the grasp point (the part behind it is inside the hand).
        L = self.handle_length
        return (
            Piece("tool_collision", CylinderShape(self.radius, L), Pose((0, 0, L / 2))),
            Piece(
                "tool_hook_collision",
                CylinderShape(self.radius, self.hook_length),
                self._hook_pose(self.hook_length / 2),
            ),
        )

    def marker_pieces(self) -> tuple[Piece, ...]:
        m = self.marker_length
        shape = CylinderShape(self.radius * MARKER_RADIUS_SCALE, m)
        return (
            Piece("grip_marker", shape, Pose((0, 0, m / 2))),
            Piece("corner_marker", shape, Pose((0, 0, self.handle_length - m / 2))),
            Piece("tip_marker", shape, self._hook_pose(self.hook_length - m / 2)),
        )


# -- tools as text ------------------------------------------------------------------------


def tool_label(tool) -> str:
    """`straight:0.3` or `hook:0.25,0.05,90` (what `parse_tool` reads)."""
    if isinstance(tool, HookTool):
        return f"hook:{tool.handle_length:g},{tool.hook_length:g},{tool.angle:g}"
    return f"straight:{tool.length:g}"


def parse_tool(text: str):
    """A tool from `straight:L` (m) or `hook:HANDLE,HOOK,ANGLE` (m, m, °); ValueError names the
    text and the forms allowed."""
    forms = "straight:L (m) or hook:HANDLE,HOOK,ANGLE (m, m, deg), e.g. hook:0.25,0.05,90"
    kind, _, values = str(text).partition(":")
    try:
        numbers = [float(v) for v in values.split(",")]
    except ValueError:
        raise ValueError(f"tool {text!r} is not {forms}") from None
    if kind == "straight" and len(numbers) == 1:
        return StraightTool(numbers[0])
    if kind == "hook" and len(numbers) == 3:
        return HookTool(*numbers)
    raise ValueError(f"tool {text!r} is not {forms}")
