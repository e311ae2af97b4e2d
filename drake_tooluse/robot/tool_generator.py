"""Tools the robot has never seen: a seeded generator of tool geometries by family.

Each family draws its parameters from its ranges (`FAMILIES`: name -> `Family`) and builds a
`robot.tool.CompositeTool` of cylinders (and boxes) in the handle frame H (the grasp point,
+z along the handle, as every tool here), with the working frames its tasks name:

- `straight`: a rod; `tool_tip` at its end.
- `hook`: today's L and J hooks (`robot.tool.HookTool`'s geometry): `hook_corner`, `tool_tip`.
- `t_head`: a handle and a crossbar across its end along y, off centre by up to a quarter of
  its width; `tool_tip` at the crossing, `head_left` / `head_right` at the bar's ends.
- `rake`: a handle, a crossbar along y, and 2-4 tines along +x (the hook's side); `hook_corner`
  at the crossing (where a pulled object rests), `tool_tip` at the middle of the tines' ends,
  `tine_line_start` / `tine_line_end` at the outer tines' ends.
- `two_bend`: a handle offset sideways (along x) by a slanted middle segment, a Z (90° bends)
  to a gentle S (45°); `bend_1`, `bend_2`, `tool_tip`.
- `arc`: a handle and a curved hook of short segments (at most 15° each) bending towards +x;
  `hook_corner` where the curve starts, `tool_tip` at its end.

Every tool also has `push_point`, where it meets a box it pushes: every family reaches towards
+x (the hook's side), which the push holds towards the box (`world.scene.TOOL_DOWN_RPY` turns
H's x to W's y, the push's direction). Of the skeleton within PUSH_BAND of its lowest point as
held pointing down (+z of H downwards), the point farthest along +x (of those that tie, the
nearest the tip, and of those as near, the one farthest along -y), brought down to that
lowest point's height: a rod's, a T-head's, a J-hook's and a three-tined rake's tip itself; a
two- or four-tined rake's inner tine's end (its tip, the middle of the tines' ends, is in the
air between two tines: a box held there passes between them to the crossbar); a curled arc's
front at the height of its bottom; a back-bent hook's front, in the band, at the height of its
corner. The tip policy holds its rod's tip, front and
bottom in one, where the push point holds both.

Every tool keeps H's orientation in its frames (a tip target's orientation is the handle's). The
fabrication bounds hold for every draw (`check_fabrication`): a rod's radius within what the
closed gripper holds, the mass of solid PLA, every point within TOOL_LENGTH_RANGE's reach of the
grasp, and the static moment about the grasp bounded. No Drake here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from itertools import islice

import numpy as np

from drake_tooluse.robot.tool import (
    GRASP,
    HOOK_ANGLE_RANGE,
    HOOK_CORNER,
    HOOK_HANDLE_RANGE,
    HOOK_LENGTH_RANGE,
    TIP_COLLISION_LENGTH,
    TOOL_HANDLE_DEPTH,
    TOOL_LENGTH_RANGE,
    TOOL_TIP,
    CompositeTool,
    CylinderShape,
    HookTool,
    Piece,
    Pose,
)
from drake_tooluse.validation import check_in_range, check_one_of, check_seed

# Fabrication bounds. A rod thinner than 4 mm bends under a push; the closed fingers leave
# 12.5 mm either side (world.scenario.TOOL_RADIUS_RANGE), 10 mm keeps a margin.
RADIUS_RANGE = (0.004, 0.010)  # m
DENSITY = 1240.0  # kg/m³, solid PLA (a printed tool)
MAX_MASS = 0.30  # kg
# kg·m, the mass times its centre's distance from the grasp: 0.03 kg·m is 0.3 N·m against
# gravity, a bound we set (what a parallel gripper's friction holds, with margin), not a
# figure of Baxter's.
MAX_STATIC_MOMENT = 0.03
HANDLE_RANGE = HOOK_HANDLE_RANGE  # m, grasp to the working end, every family with a handle
MAX_ARC_SEGMENT_DEG = 15.0
PUSH_POINT = "push_point"
# m: what of a tool meets the box's 4 cm face, over the ~7 mm the tip policy keeps its tip
# above the table.
PUSH_BAND = 0.03
PUSH_POINT_TIE = 0.001  # m: points this near the front are as far (the nearest the tip is taken)


@dataclass(frozen=True)
class Skeleton:
    """A tool as segments of one radius: `segments` (name, a, b) from point a to point b, and
    `frames` name -> origin, all in H (m); every frame keeps H's orientation."""

    frames: dict
    segments: list

    def working_frames(self) -> dict:
        """`frames` and the push point (computed here, not in every skeleton: a fit builds
        thousands and needs only their segments)."""
        return {**self.frames, PUSH_POINT: self.push_point()}

    def push_point(self) -> tuple:
        """The push point (module docstring), in H."""
        A, B = self.end_points()
        z_low = float(max(A[:, 2].max(), B[:, 2].max()))  # farthest along +z: the lowest
        z_band = z_low - PUSH_BAND
        band = []  # each segment's part within the band
        for a, b in zip(A, B):
            if min(a[2], b[2]) < z_band <= max(a[2], b[2]):
                inside, outside = (a, b) if a[2] >= z_band else (b, a)
                cut = outside + (inside - outside) * (z_band - outside[2]) / (
                    inside[2] - outside[2]
                )
                band += [inside, cut]
            elif a[2] >= z_band:
                band += [a, b]
        tip = np.asarray(self.frames[TOOL_TIP], float)
        points = np.array(band)  # the tool's own material: its tip may be in the air (a rake)
        front = points[points[:, 0] >= points[:, 0].max() - PUSH_POINT_TIE]
        distance = np.linalg.norm(front - tip, axis=1)
        # Of those as near the tip (a four-tined rake's two inner tines, mirrored about it:
        # which is nearer is the rounding's), the one on the -y side, so that a measured
        # tool's push point is on the same tine as the truth's.
        nearest = front[distance <= distance.min() + PUSH_POINT_TIE]
        x, y, _ = nearest[np.argmin(nearest[:, 1])]
        return (float(x), float(y), z_low)

    def end_points(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B): the segments' end points, (k, 3) each."""
        return (
            np.array([a for _, a, _ in self.segments], float),
            np.array([b for _, _, b in self.segments], float),
        )


@dataclass(frozen=True)
class Family:
    """A family of tools: its parameters' ranges ((low, high) floats; a tuple of choices for
    a discrete one) and `skeleton(params) -> Skeleton`, its geometry (the segments' radius is
    the parameter `radius`); `build(params)` is the tool."""

    name: str
    ranges: dict
    skeleton: Callable[[dict], Skeleton] = field(repr=False)

    def sample(self, rng: np.random.Generator) -> dict:
        """Parameters drawn uniformly in the ranges (a choice uniformly among the choices)."""
        params = {}
        for name, spec in self.ranges.items():
            if isinstance(spec[0], str):  # choices
                params[name] = spec[int(rng.integers(len(spec)))]
            elif all(isinstance(v, int) for v in spec):  # an integer range, both ends included
                params[name] = int(rng.integers(spec[0], spec[1] + 1))
            else:
                params[name] = float(rng.uniform(*spec))
        return params

    def checked(self, params: dict) -> dict:
        """`params` (e.g. a measured tool's, read from a scenario file) checked against the
        family's ranges, integer ones made integers; raises ValueError naming a missing,
        unknown or out-of-range one."""
        unknown = sorted(set(params) - set(self.ranges))
        missing = sorted(set(self.ranges) - set(params))
        if unknown or missing:
            raise ValueError(
                f"a {self.name} tool's parameters are {sorted(self.ranges)}; got {sorted(params)}"
            )
        out = {}
        for name, spec in self.ranges.items():
            value = params[name]
            check_in_range(value, spec[0], spec[1], f"{self.name} {name}")
            integer = all(isinstance(v, int) for v in spec)
            if integer and value != int(value):
                raise ValueError(f"{self.name} {name}={value} must be a whole number")
            out[name] = int(value) if integer else float(value)
        return out

    def build(self, params: dict) -> CompositeTool:
        """The tool of `params`: its skeleton's segments as cylinders, a mass of solid PLA."""
        skeleton = self.skeleton(params)
        pieces = [segment(name, a, b, params["radius"]) for name, a, b in skeleton.segments]
        volume = sum(piece.shape.volume() for piece in pieces)
        frames = {
            name: Pose(tuple(float(v) for v in p)) for name, p in skeleton.working_frames().items()
        }
        return CompositeTool(
            {GRASP: Pose(), **frames},
            solids=tuple(pieces),
            mass=DENSITY * volume,
            collisions=collision_segments(skeleton.segments, params["radius"]),
        )


@dataclass(frozen=True)
class GeneratedTool:
    """A drawn tool: its family, the seed that drew it, its parameters, the tool, and the
    region of its family's parameters it was drawn in (`REGIONS`). A tool the camera measured
    (`measured_tool`) has no seed: its parameters are the fit's."""

    family: str
    seed: int | None
    params: dict
    tool: CompositeTool
    region: str = "any"

    def label(self) -> str:
        """`rake#3`, `hook#5 (corner)` where the draw was held to a region, or `rake
        (measured)`."""
        if self.seed is None:
            return f"{self.family} (measured)"
        return f"{self.family}#{self.seed}" + ("" if self.region == "any" else f" ({self.region})")

    def as_dict(self) -> dict:
        out = {"family": self.family, "seed": self.seed, "params": dict(self.params)}
        return out if self.region == "any" else {**out, "region": self.region}


def equivalent_hook(generated: GeneratedTool) -> HookTool:
    """The hook (`robot.tool.HookTool`) a tool with a hook corner pulls as: its handle up to
    the corner, its hook the chord from the corner to the tip (length and angle), each held
    within HookTool's ranges; the hook family's own hook. Raises ValueError for a tool
    without a hook corner."""
    frames = generated.tool.frames()
    if HOOK_CORNER not in frames:
        raise ValueError(f"a {generated.family} tool has no {HOOK_CORNER}: it pulls as no hook")
    corner = np.asarray(frames[HOOK_CORNER].translation, float)
    chord = np.asarray(frames[TOOL_TIP].translation, float) - corner
    angle = math.degrees(math.atan2(chord[0], -chord[2]))  # HookTool.direction's angle
    return HookTool(
        float(np.clip(corner[2], *HOOK_HANDLE_RANGE)),
        float(np.clip(np.linalg.norm(chord), *HOOK_LENGTH_RANGE)),
        float(np.clip(angle, *HOOK_ANGLE_RANGE)),
        radius=generated.params["radius"],
    )


def measured_tool(family: str, params: dict) -> GeneratedTool:
    """The tool of `family` with `params` (a fit's, `robot.tool_fit.FamilyFit`), checked
    against the family's ranges (`Family.checked`)."""
    f = FAMILIES[check_one_of(family, tuple(FAMILIES), "tool family")]
    params = f.checked(params)
    return GeneratedTool(family, None, params, f.build(params))


def _rotation_z_to(d) -> tuple:
    """A rotation matrix (rows) taking +z onto the direction d: its columns an orthonormal
    frame with z along d (x from y × d, or from x × d where d is nearly along y)."""
    z = np.asarray(d, float) / np.linalg.norm(d)
    helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    R = np.column_stack([x, np.cross(z, x), z])
    return tuple(map(tuple, R))


def segment(name: str, a, b, radius: float) -> Piece:
    """A cylinder of `radius` from point a to point b (m, in H)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    return Piece(
        name,
        CylinderShape(radius, float(np.linalg.norm(d))),
        Pose(tuple((a + b) / 2), _rotation_z_to(d)),
    )


def collision_segments(segments: list, radius: float) -> tuple[Piece, ...]:
    """The collision cylinders of `segments` (name, a, b): each segment's, but where its end b
    is free (no other segment meets it there: a tip), that end's last TIP_COLLISION_LENGTH is
    a cylinder of its own (`<name>_end`), as a rod's tip is (`robot.tool.StraightTool`). Why:
    a point contact between a box's face and a cylinder lying along it falls anywhere along
    their overlap, so on one long cylinder it may act far above the tip and lift the tool
    over the box. A generated 0.40 m rod as one cylinder pushed 2 of 12 boxes to the goal
    under the tip policy, with its own tip piece 12 of 12, as the rod of `StraightTool`."""
    lines = [(np.asarray(a, float), np.asarray(b, float)) for _, a, b in segments]
    pieces = []
    for i, (name, _, _) in enumerate(segments):
        a, b = lines[i]
        meets = any(_distance_to_segment(b, *line) < 1e-9 for j, line in enumerate(lines) if j != i)
        length = float(np.linalg.norm(b - a))
        if meets or length <= 2 * TIP_COLLISION_LENGTH:
            pieces.append(segment(name, a, b, radius))
            continue
        cut = b - TIP_COLLISION_LENGTH * (b - a) / length
        pieces += [segment(name, a, cut, radius), segment(f"{name}_end", cut, b, radius)]
    return tuple(pieces)


def _distance_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = float(np.clip(np.dot(p - a, d) / np.dot(d, d), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * d)))


def handle(length: float) -> tuple:
    """The handle: from TOOL_HANDLE_DEPTH behind the grasp point (inside the hand) to
    `length` in front of it, along +z."""
    return ("tool_handle", (0.0, 0.0, -TOOL_HANDLE_DEPTH), (0.0, 0.0, length))


def _straight(p: dict) -> Skeleton:
    L = p["length"]
    return Skeleton({TOOL_TIP: (0, 0, L)}, [handle(L)])


def _hook(p: dict) -> Skeleton:
    h = HookTool(p["handle_length"], p["hook_length"], p["angle"], radius=p["radius"])
    corner = np.array([0.0, 0.0, h.handle_length])
    tip = corner + h.hook_length * h.direction()
    return Skeleton(
        {HOOK_CORNER: tuple(corner), TOOL_TIP: tuple(tip)},
        [handle(h.handle_length), ("tool_hook", corner, tip)],
    )


def _t_head(p: dict) -> Skeleton:
    L, w = p["handle_length"], p["head_width"]
    centre = p["head_offset"] * w  # along y, the bar's centre from the handle's axis
    left, right = (0, centre + w / 2, L), (0, centre - w / 2, L)
    return Skeleton(
        {TOOL_TIP: (0, 0, L), "head_left": left, "head_right": right},
        [handle(L), ("tool_head", right, left)],
    )


def _rake(p: dict) -> Skeleton:
    L, w, n, t = p["handle_length"], p["width"], p["tines"], p["tine_length"]
    ys = np.linspace(-w / 2, w / 2, n)
    segments = [handle(L), ("tool_bar", (0, -w / 2, L), (0, w / 2, L))]
    segments += [(f"tool_tine_{i}", (0, y, L), (t, y, L)) for i, y in enumerate(ys)]
    return Skeleton(
        {
            TOOL_TIP: (t, 0, L),
            HOOK_CORNER: (0, 0, L),
            "tine_line_start": (t, ys[0], L),
            "tine_line_end": (t, ys[-1], L),
        },
        segments,
    )


def _two_bend(p: dict) -> Skeleton:
    a, d, b = p["first_length"], p["offset"], p["second_length"]
    slant = math.radians(p["bend_angle"])  # the middle segment's angle to the handle's axis
    bend_1 = np.array([0.0, 0.0, a])
    bend_2 = bend_1 + np.array([d, 0.0, d / math.tan(slant)])
    tip = bend_2 + np.array([0.0, 0.0, b])
    return Skeleton(
        {TOOL_TIP: tuple(tip), "bend_1": tuple(bend_1), "bend_2": tuple(bend_2)},
        [handle(a), ("tool_middle", bend_1, bend_2), ("tool_end", bend_2, tip)],
    )


def arc_points(handle_length: float, arc_radius: float, sweep_deg: float) -> np.ndarray:
    """The arc's polyline (n + 1, 3) in H: from the handle's end, tangent to it, bending towards
    +x about a centre at [arc_radius, 0, handle_length], in steps of at most
    MAX_ARC_SEGMENT_DEG."""
    n = max(1, math.ceil(sweep_deg / MAX_ARC_SEGMENT_DEG))
    phi = np.radians(np.linspace(0.0, sweep_deg, n + 1))
    x = arc_radius * (1.0 - np.cos(phi))
    z = handle_length + arc_radius * np.sin(phi)
    return np.stack([x, np.zeros_like(x), z], axis=1)


def _arc(p: dict) -> Skeleton:
    L = p["handle_length"]
    points = arc_points(L, p["arc_radius"], p["sweep_deg"])
    segments = [handle(L)]
    segments += [(f"tool_arc_{i}", a, b) for i, (a, b) in enumerate(zip(points, points[1:]))]
    return Skeleton({TOOL_TIP: tuple(points[-1]), HOOK_CORNER: (0, 0, L)}, segments)


FAMILIES = {
    f.name: f
    for f in (
        Family("straight", {"length": (0.10, 0.45), "radius": RADIUS_RANGE}, _straight),
        Family(
            "hook",
            {
                "handle_length": HOOK_HANDLE_RANGE,
                "hook_length": HOOK_LENGTH_RANGE,
                "angle": HOOK_ANGLE_RANGE,
                "radius": RADIUS_RANGE,
            },
            _hook,
        ),
        Family(
            "t_head",
            {
                "handle_length": HANDLE_RANGE,
                "head_width": (0.06, 0.16),
                "head_offset": (-0.25, 0.25),
                "radius": RADIUS_RANGE,
            },
            _t_head,
        ),
        Family(
            "rake",
            {
                "handle_length": HANDLE_RANGE,
                "width": (0.06, 0.16),
                "tines": (2, 4),
                "tine_length": (0.02, 0.05),
                "radius": RADIUS_RANGE,
            },
            _rake,
        ),
        Family(
            "two_bend",
            {
                "first_length": (0.06, 0.20),
                "offset": (0.03, 0.10),
                "bend_angle": (45.0, 90.0),
                "second_length": (0.06, 0.20),
                "radius": RADIUS_RANGE,
            },
            _two_bend,
        ),
        Family(
            "arc",
            {
                "handle_length": HANDLE_RANGE,
                "arc_radius": (0.02, 0.05),
                "sweep_deg": (90.0, 200.0),
                "radius": RADIUS_RANGE,
            },
            _arc,
        ),
    )
}


def _extent(piece: Piece) -> float:
    """The farthest point of a cylinder piece from H's origin (m), bounded from its ends."""
    R = np.array(piece.X_HP.rotation)
    p = np.array(piece.X_HP.translation)
    half = R[:, 2] * piece.shape.length / 2
    return max(np.linalg.norm(p + half), np.linalg.norm(p - half)) + piece.shape.radius


def check_fabrication(tool: CompositeTool) -> None:
    """Raises ValueError, naming the bound, where `tool` breaks a fabrication bound: its mass
    (MAX_MASS), its reach (every point within TOOL_LENGTH_RANGE's upper end of the grasp) or
    its static moment about the grasp (MAX_STATIC_MOMENT)."""
    if tool.mass > MAX_MASS:
        raise ValueError(f"tool mass {tool.mass:.3f} kg exceeds {MAX_MASS} kg")
    reach = max(_extent(p) for p in tool.pieces())
    if reach > TOOL_LENGTH_RANGE[1]:
        raise ValueError(
            f"the tool reaches {reach:.3f} m from the grasp; at most {TOOL_LENGTH_RANGE[1]}"
        )
    centre = sum(
        m * np.array(p.X_HP.translation) for p, m in zip(tool.pieces(), tool.piece_masses())
    )
    moment = float(np.linalg.norm(centre))
    if moment > MAX_STATIC_MOMENT:
        raise ValueError(
            f"the tool's static moment about the grasp, {moment:.4f} kg·m, exceeds "
            f"{MAX_STATIC_MOMENT} kg·m"
        )


MAX_DRAWS = 1000  # draws of one seed's generator before it gives up (none has needed 30)

# What a policy trained over the generator never sees, so that its test is on tools unseen in
# kind, not only in draw: one whole family (the rake: it can push with its tines and pull with
# its bar, so it tests every task) and a corner of every other family's parameters, the upper
# quarter of both of its two shape parameters at once (1/16 of the ranges' volume).
HELD_OUT_FAMILY = "rake"
CORNER_PARAMETERS = {
    "straight": ("length", "radius"),
    "hook": ("hook_length", "angle"),
    "t_head": ("head_width", "head_offset"),
    "rake": ("width", "tine_length"),
    "two_bend": ("offset", "bend_angle"),
    "arc": ("arc_radius", "sweep_deg"),
}
CORNER_FRACTION = 0.25
TRAINING_FAMILIES = tuple(f for f in FAMILIES if f != HELD_OUT_FAMILY)
# Where a draw's parameters may lie: anywhere, out of its family's corner (what training
# draws), or in it (what the test draws of a family trained on).
REGIONS = ("any", "training", "corner")
SPLITS = ("training", "held_out")


def in_corner(family: str, params: dict) -> bool:
    """Whether `params` lie in `family`'s held-out corner: each of its CORNER_PARAMETERS in
    the upper CORNER_FRACTION of its range."""
    ranges = FAMILIES[family].ranges
    return all(
        params[name] >= ranges[name][1] - CORNER_FRACTION * (ranges[name][1] - ranges[name][0])
        for name in CORNER_PARAMETERS[family]
    )


def _in_region(family: str, params: dict, region: str) -> bool:
    return region == "any" or in_corner(family, params) == (region == "corner")


def generate_tool(family: str, seed: int, region: str = "any") -> GeneratedTool:
    """The tool of `family` (a name of FAMILIES) drawn with `seed` (0 … 2³²−1): the same
    seed, the same tool. Parameters are drawn uniformly in the family's ranges and drawn
    again until the tool keeps every fabrication bound (`check_fabrication`) and lies in
    `region` (REGIONS: "training" draws outside the family's corner, `in_corner`; "corner"
    inside it): the long, thick and heavy corner of a family's ranges is rarer than
    uniform."""
    f = FAMILIES[check_one_of(family, tuple(FAMILIES), "tool family")]
    seed = check_seed(seed, "seed")
    check_one_of(region, REGIONS, "region")
    # The family's place in FAMILIES beside the seed: each family's draws its own stream.
    rng = np.random.default_rng([seed, list(FAMILIES).index(family)])
    for _ in range(MAX_DRAWS):
        params = f.sample(rng)
        if not _in_region(family, params, region):
            continue
        tool = f.build(params)
        try:
            check_fabrication(tool)
        except ValueError:
            continue
        return GeneratedTool(family, seed, params, tool, region)
    raise RuntimeError(
        f"no {family} tool in region {region!r} within the fabrication bounds in {MAX_DRAWS} draws"
    )


def split_draw(
    split: str, rng: np.random.Generator, families: tuple | None = None
) -> tuple[str, int, str]:
    """(family, seed, region) of a tool drawn from `split` (SPLITS) with `rng`: "training",
    a family of TRAINING_FAMILIES outside its corner; "held_out", any family uniformly, the
    held-out family anywhere and another in its corner. `families` (names of FAMILIES; None:
    all) keeps the draw to those a task uses (the pull's hooks and arcs); a split holding
    none of them is a ValueError. `generate_tool(*split_draw(...))` is the tool."""
    check_one_of(split, SPLITS, "tool split")
    families = _split_families(split, families)
    family = families[int(rng.integers(len(families)))]
    seed = int(rng.integers(2**32))
    if split == "training":
        return family, seed, "training"
    return family, seed, held_out_region(family)


def _split_families(split: str, families: tuple | None) -> tuple:
    """The families `split` draws from, kept to `families` where given (in FAMILIES' order)."""
    of_split = TRAINING_FAMILIES if split == "training" else tuple(FAMILIES)
    if families is None:
        return of_split
    for family in families:
        check_one_of(family, tuple(FAMILIES), "tool family")
    kept = tuple(f for f in of_split if f in families)
    if not kept:
        raise ValueError(f"the {split} split draws none of the families {list(families)}")
    return kept


def held_out_region(family: str) -> str:
    """The region (REGIONS) of `family` that training never draws: the whole held-out family,
    or another family's corner."""
    return "any" if family == HELD_OUT_FAMILY else "corner"


def held_out_draws(seed: int = 0) -> Iterator[GeneratedTool]:
    """The tools of the held-out split, drawn in turn from `seed`'s generator, without end."""
    rng = np.random.default_rng(check_seed(seed, "seed"))

    def draws():
        while True:
            yield generate_tool(*split_draw("held_out", rng))

    return draws()


def held_out_tools(count: int, seed: int = 0) -> list[GeneratedTool]:
    """The first `count` tools of `held_out_draws(seed)`: the test set of a policy trained on
    the "training" split."""
    return list(islice(held_out_draws(seed), count))
