"""Typed scenario: everything that defines a world, loaded from YAML with `yaml_load_typed`.

A typo in a YAML key is an error that names the key (Drake's typed loader), and every value is
range-checked by `validate_scenario` where it enters, with an error naming the value and the
allowed range.

Scenarios are layers: a file may name a `base` file (relative to itself) and then states only
the values it changes; the loader reads the base first and the file on top of it
(`yaml_load_typed(..., defaults=base)`, as `manipulation/station.py`'s `LoadScenario` does).
The plant's settings are Drake's own `MultibodyPlantConfig`.

Frames and units: the world frame W is Baxter's `base` frame (x forward, y left, z up); SI units.
"""

# No `from __future__ import annotations`: Drake's YAML loader reads the field types.
import dataclasses as dc
import math
import typing
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.files import read_yaml
from drake_tooluse.limits import MAX_NOISE_SIGMA
from drake_tooluse.paths import BAXTER_URL
from drake_tooluse.robot.baxter_model import LEFT_ARM_TUCKED, Q_LOWER, Q_UPPER
from drake_tooluse.robot.tool import (
    HOOK_ANGLE_RANGE,
    HOOK_HANDLE_RANGE,
    HOOK_LENGTH_RANGE,
    HookTool,
    StraightTool,
    Tool,
    check_tool_length,
)
from drake_tooluse.robot.tool_generator import (
    FAMILIES,
    REGIONS,
    GeneratedTool,
    generate_tool,
    measured_tool,
)
from drake_tooluse.validation import (
    check_bool,
    check_finite_vector,
    check_in_range,
    check_interval,
    check_one_of,
    check_positive,
    check_seed,
    refused_by_library,
    shown,
)
from drake_tooluse.world.paper import PAPER_TOOL_LENGTHS  # noqa: F401  (part of the schema's API)

TOOL_RADIUS_RANGE = (0.002, 0.0125)  # the closed fingers leave 12.5 mm either side (m)
CONTACT_MODELS = ("point", "hydroelastic_with_fallback")
# Every position in W (the box, the goal, the table's centre, the home tip) lies within this
# of the robot's base per coordinate (m): Baxter reaches about 1.3 m with its tool.
WORKSPACE = 2.0
# Drake's MultibodyPlantConfig, each field's allowed values: its own preconditions (strictly
# positive penetration allowance and stiction tolerance, a non-negative near-rigid threshold)
# bounded by what this world can use: (low, high, unit, low allowed).
PLANT_RANGES = {
    # Discrete (the in-plant PD needs it) and stable up to 20 ms.
    "time_step": (1e-4, 0.02, "s", True),
    # Drake's default is 1 mm; past 1 cm the 4 cm box sinks visibly into the table.
    "penetration_allowance": (0.0, 0.01, "m", False),
    "stiction_tolerance": (0.0, 0.1, "m/s", False),  # Drake's default 1e-4 m/s
    # Drake: "non-negative, typically in [0, 1], though larger values are allowed".
    "sap_near_rigid_threshold": (0.0, 10.0, "", True),
}
PLANT_CHOICES = {
    "contact_model": CONTACT_MODELS,
    # The in-plant PD controllers of the arm need a discrete plant solved with SAP.
    "discrete_contact_approximation": ("sap",),
    "contact_surface_representation": ("triangle", "polygon"),
}
PLANT_FLAGS = ("use_sampled_output_ports", "adjacent_bodies_collision_filters")
# The models this project ships: "package://drake_tooluse/".
TOOL_KINDS = ("straight", "hook", "generated")
PACKAGE_URL = BAXTER_URL[: BAXTER_URL.index("/", len("package://")) + 1]


@dc.dataclass
class ToolConfig:
    """The tool in the hand: a straight rod gripped at one end, or a tool model file.

    `length` runs from the grasp point (the `right_gripper` frame origin, between the fingertips)
    to the tip. With zero grasp offsets the tool axis is +z of `right_gripper`.
    `model`, when given, is an SDFormat or URDF file (a path, relative to the scenario file
    that names it, or a `package://` URL) of one body with a `tool_tip` frame and any other
    named frames (`robot.model.load_tool_model`); it replaces the rod (`length`, `radius`,
    `mass` and `marker_length` are then not used), welded at the same grasp.
    """

    length: float = 0.175
    # False: no tool in the hand; the tool-tip frame is the gripper frame.
    attached: bool = True
    radius: float = 0.006
    mass: float = 0.05
    # Where the hand really holds the tool (truth only; the robot believes both are 0):
    # along the tool axis (+ pushes the tip further out) and across it (along gripper x).
    grasp_offset_along: float = 0.0
    grasp_offset_across: float = 0.0
    # Length of each orange marker band, at the grip end and at the tip (m).
    marker_length: float = 0.012
    model: str = ""
    # "straight" (a rod), "hook" (`robot.tool.HookTool`: `length` is then its handle's, with
    # a hook `hook_length` m long at `hook_angle` degrees to it) or "generated" (the tool
    # `robot.tool_generator.generate_tool(family, seed, region)` draws, or, where `params`
    # are given, the family's tool of those parameters (a measured tool's); `length`,
    # `radius` and `mass` are then its own).
    kind: str = "straight"
    hook_length: float = 0.05
    hook_angle: float = 90.0
    family: str = "straight"
    seed: int = 0
    region: str = "any"
    params: dict[str, float] = dc.field(default_factory=dict)

    def description(self) -> Tool:
        """The tool this describes, as geometry (`robot.tool`): the rod, the hook or the
        generated tool, its frames and pieces (whether or not it is `attached`)."""
        if self.kind == "generated":
            if self.params:
                return measured_tool(self.family, self.params).tool
            return generate_tool(self.family, self.seed, self.region).tool
        if self.kind == "hook":
            return HookTool(
                self.length,
                self.hook_length,
                self.hook_angle,
                self.radius,
                self.mass,
                self.marker_length,
            )
        return StraightTool(self.length, self.radius, self.mass, self.marker_length)


@dc.dataclass
class BoxConfig:
    """The wooden box the robot pushes."""

    size: list[float] = dc.field(default_factory=lambda: [0.04, 0.04, 0.04])
    mass: float = 0.2
    friction: float = 0.4
    # Initial position of the box centre in W; z is set so the box rests on the table when
    # `on_table` is true.
    position: list[float] = dc.field(default_factory=lambda: [0.70, -0.25, 0.0])
    yaw: float = 0.0
    on_table: bool = True


@dc.dataclass
class TableConfig:
    top_z: float = -0.20
    center_xy: list[float] = dc.field(default_factory=lambda: [0.75, 0.0])
    size_xy: list[float] = dc.field(default_factory=lambda: [0.70, 1.40])
    thickness: float = 0.04
    friction: float = 0.4


def default_plant_config() -> MultibodyPlantConfig:
    """A discrete plant with SAP (which the in-plant PD controllers need). SAP is stable at a
    20 ms step for the arm's PD and the box's quasi-static pushing; the scripted push behaves
    the same at 10 ms (see docs/BENCHMARKS.md), at half the cost. Point contact: the box
    stands on corner spheres."""
    return MultibodyPlantConfig(
        time_step=0.02, contact_model="point", discrete_contact_approximation="sap"
    )


MAX_ACTUATION_DELAY = 0.2  # s


@dc.dataclass
class ControlConfig:
    """Joint PD gains of the seven right-arm joints (s0 … w2) and the control period."""

    kp: list[float] = dc.field(
        default_factory=lambda: [1500.0, 1500.0, 800.0, 800.0, 200.0, 200.0, 100.0]
    )
    kd: list[float] = dc.field(default_factory=lambda: [120.0, 120.0, 50.0, 50.0, 8.0, 8.0, 3.0])
    control_period: float = 0.04
    # Joint targets reach the motors this late (s): a real robot's command latency. A multiple
    # of plant.time_step, in [0, MAX_ACTUATION_DELAY].
    actuation_delay: float = 0.0


@dc.dataclass
class RobotConfig:
    # Home: the tool tip this high above the table top at this (x, y), pointing down. The
    # initial joint angles are solved for by IK, warm-started from `posture_seed`, so the arm
    # starts in the same posture whatever the tool length.
    home_tip_xy: list[float] = dc.field(default_factory=lambda: [0.62, -0.30])
    home_tip_height: float = 0.10
    # Right-arm joint angles s0 … w2 (rad) of a comfortable posture near home.
    posture_seed: list[float] = dc.field(
        default_factory=lambda: [0.712, -1.106, 0.005, 1.75, -0.003, 0.927, 1.504]
    )
    # The left arm is welded at this pose (s0 … w2), rad: tucked beside the body.
    left_arm_q: list[float] = dc.field(default_factory=lambda: list(LEFT_ARM_TUCKED))
    # True: the robot's IK keeps s1 in [-1.35, 1.0] rad, the range a real Baxter beside a
    # table can use safely (the paper's conservative limits), instead of Baxter's full range.
    conservative_limits: bool = False


@dc.dataclass
class RandomizationConfig:
    """Domain randomization of the envs (`randomize=True`): half-widths of uniform draws
    around the nominal values, or [low, high] scale factors, drawn per reset from the env's
    seeded generator."""

    box_xy: float = 0.02  # m, offset of the box's start position
    box_yaw: float = 0.2  # rad
    box_mass_scale: list[float] = dc.field(default_factory=lambda: [0.7, 1.3])
    box_friction_scale: list[float] = dc.field(default_factory=lambda: [0.7, 1.3])
    grasp_along: float = 0.01  # m, the true grasp shifted along the tool
    grasp_across: float = 0.005  # m, and across it


@dc.dataclass
class CameraConfig:
    """Baxter's head camera as a Drake RgbdSensor (RenderEngineVtk): intrinsics, clipping and
    depth ranges, and the colour image noise. The field of view is wide enough to hold a
    0.60 m tool at the measurement poses of `drake_tooluse.builders.measurement`; the resolution gives
    about 0.9 mm per pixel there."""

    width: int = 1280  # pixels
    height: int = 800  # pixels
    fov_y: float = 1.0  # vertical field of view, rad
    clipping_near: float = 0.05  # m
    clipping_far: float = 5.0  # m
    # Depths outside [depth_min, depth_max] read as 0 (too close) or inf (too far), m.
    depth_min: float = 0.1
    depth_max: float = 3.0
    # Standard deviation of the Gaussian noise added to each colour channel, grey levels.
    noise_sigma: float = 0.0


@dc.dataclass
class Scenario:
    # A scenario file this one is written on top of (a path relative to this file, or empty):
    # the values this file leaves out are the base's.
    base: str = ""
    tool: ToolConfig = dc.field(default_factory=ToolConfig)
    box: BoxConfig = dc.field(default_factory=BoxConfig)
    # Goal of the box centre relative to its initial position (m), in W.
    goal_offset: list[float] = dc.field(default_factory=lambda: [0.0, 0.20, 0.0])
    table: TableConfig = dc.field(default_factory=TableConfig)
    plant: MultibodyPlantConfig = dc.field(default_factory=default_plant_config)
    control: ControlConfig = dc.field(default_factory=ControlConfig)
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    randomization: RandomizationConfig = dc.field(default_factory=RandomizationConfig)
    camera: CameraConfig = dc.field(default_factory=CameraConfig)


def validate_scenario(s: Scenario) -> Scenario:
    """Range-checks every field; raises ValueError naming the field, its value and the range."""
    check_tool_length(s.tool.length, "tool.length")
    check_in_range(s.tool.radius, *TOOL_RADIUS_RANGE, "tool.radius", unit="m")
    check_positive(s.tool.mass, "tool.mass", unit="kg")
    check_in_range(s.tool.grasp_offset_along, -0.03, 0.03, "tool.grasp_offset_along", unit="m")
    check_in_range(s.tool.grasp_offset_across, -0.01, 0.01, "tool.grasp_offset_across", unit="m")
    check_in_range(s.tool.marker_length, 0.004, 0.03, "tool.marker_length", unit="m")
    check_one_of(s.tool.kind, TOOL_KINDS, "tool.kind")
    if s.tool.kind == "generated":
        check_one_of(s.tool.family, tuple(FAMILIES), "tool.family")
        check_seed(s.tool.seed, "tool.seed")
        check_one_of(s.tool.region, REGIONS, "tool.region")
        if s.tool.params:
            FAMILIES[s.tool.family].checked(s.tool.params)
    elif s.tool.params:
        raise ValueError(f"tool.params are a generated tool's; tool.kind is {s.tool.kind!r}")
    if s.tool.kind == "hook":
        check_in_range(
            s.tool.length, *HOOK_HANDLE_RANGE, "tool.length (the hook's handle)", unit="m"
        )
        check_in_range(s.tool.hook_length, *HOOK_LENGTH_RANGE, "tool.hook_length", unit="m")
        check_in_range(s.tool.hook_angle, *HOOK_ANGLE_RANGE, "tool.hook_angle", unit="°")
    if s.tool.model:
        model = s.tool.model
        if not model.endswith((".sdf", ".urdf")):
            raise ValueError(
                f"tool.model={model!r} must be an SDFormat (.sdf) or URDF (.urdf) file"
            )
        if not model.startswith("package://") and not Path(model).is_file():
            raise ValueError(f"tool.model={model!r} is not a file")
    if s.tool.marker_length * 2 >= s.tool.length:
        raise ValueError(
            f"tool.length={s.tool.length} m must exceed twice tool.marker_length="
            f"{s.tool.marker_length} m so the two markers do not overlap"
        )
    size = check_finite_vector(s.box.size, 3, "box.size")
    for i, v in enumerate(size):
        check_in_range(v, 0.01, 0.30, f"box.size[{i}]", unit="m")
    check_in_range(s.box.mass, 0.01, 10.0, "box.mass", unit="kg")
    check_in_range(s.box.friction, 0.0, 2.0, "box.friction")
    box = check_position(s.box.position, 3, "box.position")
    check_in_range(s.box.yaw, -math.pi, math.pi, "box.yaw", unit="rad")
    goal = check_finite_vector(s.goal_offset, 3, "goal_offset")
    check_position(box + goal, 3, "the goal (box.position + goal_offset)")
    check_in_range(s.table.top_z, -1.0, 0.5, "table.top_z", unit="m")
    check_position(s.table.center_xy, 2, "table.center_xy")
    for i, v in enumerate(check_finite_vector(s.table.size_xy, 2, "table.size_xy")):
        check_in_range(v, 0.1, 3.0, f"table.size_xy[{i}]", unit="m")
    check_in_range(s.table.thickness, 0.005, 0.5, "table.thickness", unit="m")
    check_in_range(s.table.friction, 0.0, 2.0, "table.friction")
    check_plant(s.plant)
    for name in ("kp", "kd"):
        gains = check_finite_vector(getattr(s.control, name), 7, f"control.{name}")
        for i, g in enumerate(gains):
            check_in_range(g, 0.0, 1e5, f"control.{name}[{i}]")
    check_in_range(
        s.control.control_period, s.plant.time_step, 1.0, "control.control_period", unit="s"
    )
    delay = check_in_range(
        s.control.actuation_delay, 0.0, MAX_ACTUATION_DELAY, "control.actuation_delay", unit="s"
    )
    steps = delay / s.plant.time_step
    if abs(steps - round(steps)) > 1e-6:
        raise ValueError(
            f"control.actuation_delay={delay} s must be a multiple of "
            f"plant.time_step={s.plant.time_step} s"
        )
    check_position(s.robot.home_tip_xy, 2, "robot.home_tip_xy")
    check_in_range(s.robot.home_tip_height, 0.0, 0.5, "robot.home_tip_height", unit="m")
    for name in ("posture_seed", "left_arm_q"):  # in Baxter's joint limits
        q = check_finite_vector(getattr(s.robot, name), 7, f"robot.{name}")
        for i, (v, lo, hi) in enumerate(zip(q, Q_LOWER, Q_UPPER)):
            check_in_range(v, lo, hi, f"robot.{name}[{i}]", unit="rad")
    r = s.randomization
    check_in_range(r.box_xy, 0.0, 0.10, "randomization.box_xy", unit="m")
    check_in_range(r.box_yaw, 0.0, math.pi, "randomization.box_yaw", unit="rad")
    for name in ("box_mass_scale", "box_friction_scale"):
        lo, hi = check_finite_vector(getattr(r, name), 2, f"randomization.{name}")
        check_in_range(lo, 0.1, 1.0, f"randomization.{name}[0]")
        check_in_range(hi, 1.0, 3.0, f"randomization.{name}[1]")
    # Every draw must be a valid world: the largest scaled mass and friction stay in range.
    check_in_range(
        s.box.mass * r.box_mass_scale[1],
        0.01,
        10.0,
        "box.mass x randomization.box_mass_scale[1]",
        unit="kg",
    )
    check_in_range(
        s.box.friction * r.box_friction_scale[1],
        0.0,
        2.0,
        "box.friction x randomization.box_friction_scale[1]",
    )
    check_in_range(
        r.grasp_along,
        0.0,
        0.03 - abs(s.tool.grasp_offset_along),
        "randomization.grasp_along",
        unit="m",
    )
    check_in_range(
        r.grasp_across,
        0.0,
        0.01 - abs(s.tool.grasp_offset_across),
        "randomization.grasp_across",
        unit="m",
    )
    c = s.camera
    for name in ("width", "height"):
        value = getattr(c, name)
        if not isinstance(value, int) or isinstance(value, bool) or not 16 <= value <= 4096:
            raise ValueError(f"camera.{name}={value!r} must be an integer in [16, 4096] pixels")
    check_in_range(c.fov_y, 0.1, 2.5, "camera.fov_y", unit="rad")
    check_in_range(c.clipping_near, 0.01, 1.0, "camera.clipping_near", unit="m")
    check_in_range(
        c.clipping_far,
        c.clipping_near,
        100.0,
        "camera.clipping_far",
        unit="m",
        lower_inclusive=False,
    )
    check_in_range(c.depth_min, c.clipping_near, c.clipping_far, "camera.depth_min", unit="m")
    check_in_range(
        c.depth_max,
        c.depth_min,
        c.clipping_far,
        "camera.depth_max",
        unit="m",
        lower_inclusive=False,
    )
    check_noise_sigma(c.noise_sigma, "camera.noise_sigma")
    return s


def check_position(values, size: int, name: str):
    """A position in W: `size` finite coordinates, each within `WORKSPACE` m of the base."""
    p = check_finite_vector(values, size, name)
    for i, v in enumerate(p):
        check_in_range(v, -WORKSPACE, WORKSPACE, f"{name}[{i}]", unit="m")
    return p


def check_plant(plant: MultibodyPlantConfig) -> MultibodyPlantConfig:
    """Every field of Drake's MultibodyPlantConfig in its range (`PLANT_RANGES`, `PLANT_CHOICES`,
    `PLANT_FLAGS`), then Drake's own preconditions, met by a plant made with it (0.3 ms,
    once per process for the same settings; they cover a field a newer Drake adds): a value
    Drake refuses is a ValueError naming the plant's settings, never Drake's abort."""
    for name, (lo, hi, unit, low_allowed) in PLANT_RANGES.items():
        check_in_range(getattr(plant, name), lo, hi, f"plant.{name}", unit, low_allowed)
    for name, allowed in PLANT_CHOICES.items():
        check_one_of(getattr(plant, name), allowed, f"plant.{name}")
    for name in PLANT_FLAGS:
        check_bool(getattr(plant, name), f"plant.{name}")
    key = tuple(getattr(plant, f.name) for f in plant.__fields__)
    if key in _PLANTS_DRAKE_ACCEPTED:  # each episode's scenario is checked: once is enough
        return plant
    settings = ", ".join(f"{f.name}={shown(getattr(plant, f.name))}" for f in plant.__fields__)
    with refused_by_library(f"plant settings ({settings})"):
        AddMultibodyPlant(plant, DiagramBuilder())
    _PLANTS_DRAKE_ACCEPTED.add(key)
    return plant


# The plant settings a plant was made with (their values, in `__fields__` order).
_PLANTS_DRAKE_ACCEPTED: set[tuple] = set()


def check_noise_sigma(sigma, name: str = "noise sigma") -> float:
    """The camera's colour noise: a standard deviation in [0, 50] grey levels."""
    return check_in_range(sigma, 0.0, MAX_NOISE_SIGMA, name, unit="grey levels")


def load_scenario(filename, within=()) -> Scenario:
    """Loads and validates a scenario YAML file, on top of its `base` file if it names one.
    With `within` (folders), every file the scenario reads — itself, each base, its tool
    model — must lie inside one of them (symbolic links followed), and a tool model's
    `package://` URL must be this package's: a scenario from elsewhere (a policy directory)
    reads nothing outside the folders it is given."""
    roots = tuple(Path(r).resolve() for r in within)
    return validate_scenario(_load_layers(Path(filename), (), roots))


def _check_inside(path: Path, roots: tuple, name: str) -> None:
    if roots and not any(path.resolve().is_relative_to(r) for r in roots):
        raise ValueError(
            f"{name} {str(path)!r} is outside {' and '.join(repr(str(r)) for r in roots)}, "
            "the folders this scenario may read from"
        )


def _load_layers(path: Path, seen: tuple, roots: tuple = ()) -> Scenario:
    if path.resolve() in seen:
        chain = " -> ".join(str(p) for p in (*seen, path.resolve()))
        raise ValueError(f"scenario bases form a cycle: {chain}")
    _check_inside(path, roots, f"the scenario {'base ' if seen else ''}file")
    raw = read_yaml(path, "scenario file")  # size-limited, duplicate keys refused
    if raw is not None and not isinstance(raw, dict):
        raise ValueError(
            f"invalid scenario {str(path)!r}: it must be a mapping of groups "
            f"(tool, box, ...), not a {type(raw).__name__}"
        )
    _check_types(raw or {}, Scenario, "", path)
    base_name = (raw or {}).get("base") or ""
    defaults = (
        _load_layers(path.parent / base_name, (*seen, path.resolve()), roots)
        if base_name
        else Scenario()
    )
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path), defaults=defaults)
    except (RuntimeError, ValueError, TypeError, AssertionError, KeyError) as e:
        # Drake's loader names an unknown key; the types were checked above.
        raise ValueError(f"invalid scenario {str(path)!r}: {e}") from None
    tool = (raw or {}).get("tool") or {}
    # A hook's field set on a straight tool would be dropped unseen (the CLI refuses the same
    # combination). A whole scenario written out (a run's copy) holds their defaults: allowed.
    default = ToolConfig()
    hook_fields = [
        k for k in ("hook_length", "hook_angle") if k in tool and tool[k] != getattr(default, k)
    ]
    if hook_fields and scenario.tool.kind != "hook":
        raise ValueError(
            f"invalid scenario {str(path)!r}: tool.{hook_fields[0]}={shown(tool[hook_fields[0]])} "
            f"describes a hook, but tool.kind is {scenario.tool.kind!r}; set kind: hook, or "
            f"leave out {' and '.join(hook_fields)}"
        )
    model = tool.get("model")
    if model and not str(model).startswith("package://"):  # relative to the file naming it
        scenario.tool.model = str((path.parent / model).resolve())
        _check_inside(Path(scenario.tool.model), roots, f"{str(path)!r}: tool.model")
    elif model and roots and not str(model).startswith(PACKAGE_URL):
        raise ValueError(
            f"{str(path)!r}: tool.model={shown(model)} may only name this package's models "
            f"({PACKAGE_URL}...)"
        )
    return scenario


def _kind(t) -> str:
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(
        t, getattr(t, "__name__", str(t))
    )


def _fields(schema) -> dict:
    """{name: type} of a scenario group: a dataclass, or a Drake config struct (`__fields__`)."""
    if dc.is_dataclass(schema):
        return typing.get_type_hints(schema)
    return {f.name: f.type for f in getattr(schema, "__fields__", ())}


def _check_types(raw: dict, schema, where: str, path: Path) -> None:
    """Each value of `raw` must have the type its field in `schema` declares (a group where a
    group belongs, a number where a number does, a list of numbers ...): Drake's typed loader
    would fail on a wrong one without naming the field."""
    fields = _fields(schema)
    for key, value in raw.items():
        t = fields.get(key)
        if t is None:
            continue  # an unknown key: Drake's loader names it
        name = f"{where}{key}"
        expected = None
        if _fields(t):  # a group
            if not isinstance(value, dict):
                expected = f"a group of values ({', '.join(_fields(t))})"
            else:
                _check_types(value, t, name + ".", path)
        elif typing.get_origin(t) is list:
            (item,) = typing.get_args(t)
            if not isinstance(value, list) or not all(_is(v, item) for v in value):
                expected = f"a list of {_kind(item).split(' ', 1)[1]}s"
        elif t in (float, int, bool, str) and not _is(value, t):
            expected = _kind(t)
        if expected is not None:
            raise ValueError(
                f"invalid scenario {str(path)!r}: {name}={shown(value)} must be {expected}"
            )


def _is(value, t) -> bool:
    """Whether Drake's loader takes `value` for a field of type `t` (it parses strings with
    Python's number parsers, and takes a float for an int when it is whole)."""
    if isinstance(value, bool):
        return t is bool
    if t is float:  # (an integer past 1.8e308 is no float)
        return (
            isinstance(value, float)
            or (isinstance(value, int) and value.bit_length() <= 1023)
            or (isinstance(value, str) and _parses(float, value))
        )
    if t is int:
        return (
            isinstance(value, int)
            or (isinstance(value, float) and value.is_integer())
            or (isinstance(value, str) and _parses(int, value))
        )
    if t is bool:
        return value in ("true", "false")
    return isinstance(value, t)


def _parses(parse, text: str) -> bool:
    try:
        parse(text)
    except ValueError:
        return False
    return True


def tool_or_none(scenario: Scenario) -> StraightTool | None:
    """The scenario's (true) tool as geometry (`ToolConfig.description`), or None when no tool
    is attached."""
    return scenario.tool.description() if scenario.tool.attached else None


def tool_length_or_none(scenario: Scenario) -> float | None:
    """The scenario's tool length (m), or None when no tool is attached."""
    return scenario.tool.length if scenario.tool.attached else None


def with_tool_length(scenario: Scenario, length: float) -> Scenario:
    """A copy of `scenario` holding a tool of `length` m."""
    tool = dc.replace(scenario.tool, length=check_tool_length(length))
    return validate_scenario(dc.replace(scenario, tool=tool))


def check_delay_range(r) -> list[float]:
    """An env's `actuation_delay_range`: [lo, hi] s, each in [0, MAX_ACTUATION_DELAY]."""

    def check(value, name):
        return check_in_range(value, 0.0, MAX_ACTUATION_DELAY, name, unit="s")

    return check_interval(r, "actuation_delay_range", "s", check)


def delay_choices(delay_range, time_step: float) -> list[float]:
    """The actuation delays (s) an env's `actuation_delay_range` allows: the multiples of the
    plant's `time_step` in it (the delay is a whole number of plant steps)."""
    lo, hi = delay_range
    first, last = math.ceil(lo / time_step - 1e-9), math.floor(hi / time_step + 1e-9)
    if first > last:
        raise ValueError(
            f"actuation_delay_range={[lo, hi]} s holds no multiple of the plant's time step "
            f"{time_step} s"
        )
    return [k * time_step for k in range(first, last + 1)]


def with_actuation_delay(scenario: Scenario, delay: float) -> Scenario:
    """A copy of `scenario` whose joint targets reach the motors `delay` s late."""
    control = dc.replace(scenario.control, actuation_delay=delay)
    return validate_scenario(dc.replace(scenario, control=control))


def with_drawn_delay(scenario: Scenario, choices: list, rng) -> Scenario:
    """`scenario` with an actuation delay drawn uniformly among `choices` (`delay_choices`)
    by `rng` (a numpy Generator: an env's seeded `np_random`)."""
    return with_actuation_delay(scenario, choices[int(rng.integers(len(choices)))])


def with_tool(scenario: Scenario, tool) -> Scenario:
    """A copy of `scenario` holding `tool`: a StraightTool or a length (m), a HookTool, or a
    GeneratedTool (`robot.tool_generator`)."""
    if isinstance(tool, GeneratedTool) and tool.seed is None:  # a measured tool
        held = dc.replace(
            scenario.tool, kind="generated", family=tool.family, seed=0, params=dict(tool.params)
        )
    elif isinstance(tool, GeneratedTool):
        held = dc.replace(
            scenario.tool,
            kind="generated",
            family=tool.family,
            seed=tool.seed,
            region=tool.region,
            params={},
        )
    elif isinstance(tool, HookTool):
        held = dc.replace(
            scenario.tool,
            kind="hook",
            length=tool.handle_length,
            hook_length=tool.hook_length,
            hook_angle=tool.angle,
        )
    else:
        length = tool.length if isinstance(tool, StraightTool) else tool
        held = dc.replace(scenario.tool, kind="straight", length=check_tool_length(length))
    return validate_scenario(dc.replace(scenario, tool=held))
