"""Typed scenario: everything that defines a world, loaded from YAML with `yaml_load_typed`.

A typo in a YAML key is an error that names the key (Drake's typed loader), and every value is
range-checked by `validate_scenario` where it enters, with an error naming the value and the
allowed range.

Frames and units: the world frame W is Baxter's `base` frame (x forward, y left, z up); SI units.
"""

# No `from __future__ import annotations`: Drake's YAML loader reads the field types.
import dataclasses as dc
import math
from pathlib import Path

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from drake_tooluse.validation import (
    check_finite_vector,
    check_in_range,
    check_one_of,
    check_positive,
)

TOOL_LENGTH_RANGE = (0.0, 0.60)  # exclusive lower bound, inclusive upper bound (m)
TOOL_RADIUS_RANGE = (0.002, 0.0125)  # the closed fingers leave 12.5 mm either side (m)
CONTACT_MODELS = ("point", "hydroelastic_with_fallback")
# The paper's two tools (m).
PAPER_TOOL_LENGTHS = (0.125, 0.175)


@dc.dataclass
class ToolConfig:
    """A straight rod gripped at one end.

    `length` runs from the grasp point (the `right_gripper` frame origin, between the fingertips)
    to the tip. With zero grasp offsets the tool axis is +z of `right_gripper`.
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


@dc.dataclass
class PlantConfig:
    # SAP is stable at this step for the arm's PD and the box's quasi-static pushing; the
    # scripted push behaves the same at 10 ms (see docs/BENCHMARKS.md), at half the cost.
    time_step: float = 0.02
    contact_model: str = "point"


@dc.dataclass
class ControlConfig:
    """Joint PD gains of the seven right-arm joints (s0 … w2) and the control period."""

    kp: list[float] = dc.field(
        default_factory=lambda: [1500.0, 1500.0, 800.0, 800.0, 200.0, 200.0, 100.0])
    kd: list[float] = dc.field(
        default_factory=lambda: [120.0, 120.0, 50.0, 50.0, 8.0, 8.0, 3.0])
    control_period: float = 0.04
    # Joint targets reach the motors this late (s): a real robot's command latency. A multiple
    # of plant.time_step, in [0, 0.2].
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
        default_factory=lambda: [0.712, -1.106, 0.005, 1.75, -0.003, 0.927, 1.504])
    # The left arm is welded at this pose (s0 … w2), rad: tucked beside the body.
    left_arm_q: list[float] = dc.field(
        default_factory=lambda: [-0.6, -1.0, 0.0, 2.0, 0.0, 0.6, 0.0])
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
    0.60 m tool at the measurement poses of `drake_tooluse.measure`; the resolution gives
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
    tool: ToolConfig = dc.field(default_factory=ToolConfig)
    box: BoxConfig = dc.field(default_factory=BoxConfig)
    # Goal of the box centre relative to its initial position (m), in W.
    goal_offset: list[float] = dc.field(default_factory=lambda: [0.0, 0.20, 0.0])
    table: TableConfig = dc.field(default_factory=TableConfig)
    plant: PlantConfig = dc.field(default_factory=PlantConfig)
    control: ControlConfig = dc.field(default_factory=ControlConfig)
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    randomization: RandomizationConfig = dc.field(default_factory=RandomizationConfig)
    camera: CameraConfig = dc.field(default_factory=CameraConfig)
    seed: int = 0


def check_tool_length(length, name="tool length") -> float:
    """A tool length in (0, 0.60] m; returns it as a float."""
    lo, hi = TOOL_LENGTH_RANGE
    value = check_in_range(length, lo, hi, name, unit="m", lower_inclusive=False)
    return value


def validate_scenario(s: Scenario) -> Scenario:
    """Range-checks every field; raises ValueError naming the field, its value and the range."""
    check_tool_length(s.tool.length, "tool.length")
    check_in_range(s.tool.radius, *TOOL_RADIUS_RANGE, "tool.radius", unit="m")
    check_positive(s.tool.mass, "tool.mass", unit="kg")
    check_in_range(s.tool.grasp_offset_along, -0.03, 0.03, "tool.grasp_offset_along", unit="m")
    check_in_range(s.tool.grasp_offset_across, -0.01, 0.01, "tool.grasp_offset_across", unit="m")
    check_in_range(s.tool.marker_length, 0.004, 0.03, "tool.marker_length", unit="m")
    if s.tool.marker_length * 2 >= s.tool.length:
        raise ValueError(
            f"tool.length={s.tool.length} m must exceed twice tool.marker_length="
            f"{s.tool.marker_length} m so the two markers do not overlap")
    size = check_finite_vector(s.box.size, 3, "box.size")
    for i, v in enumerate(size):
        check_in_range(v, 0.01, 0.30, f"box.size[{i}]", unit="m")
    check_in_range(s.box.mass, 0.01, 10.0, "box.mass", unit="kg")
    check_in_range(s.box.friction, 0.0, 2.0, "box.friction")
    check_finite_vector(s.box.position, 3, "box.position")
    check_in_range(s.box.yaw, -math.pi, math.pi, "box.yaw", unit="rad")
    check_finite_vector(s.goal_offset, 3, "goal_offset")
    check_in_range(s.table.top_z, -1.0, 0.5, "table.top_z", unit="m")
    check_finite_vector(s.table.center_xy, 2, "table.center_xy")
    for i, v in enumerate(check_finite_vector(s.table.size_xy, 2, "table.size_xy")):
        check_in_range(v, 0.1, 3.0, f"table.size_xy[{i}]", unit="m")
    check_in_range(s.table.thickness, 0.005, 0.5, "table.thickness", unit="m")
    check_in_range(s.table.friction, 0.0, 2.0, "table.friction")
    check_in_range(s.plant.time_step, 1e-4, 0.02, "plant.time_step", unit="s")
    check_one_of(s.plant.contact_model, CONTACT_MODELS, "plant.contact_model")
    for name in ("kp", "kd"):
        gains = check_finite_vector(getattr(s.control, name), 7, f"control.{name}")
        for i, g in enumerate(gains):
            check_in_range(g, 0.0, 1e5, f"control.{name}[{i}]")
    check_in_range(s.control.control_period, s.plant.time_step, 1.0, "control.control_period",
                   unit="s")
    delay = check_in_range(s.control.actuation_delay, 0.0, 0.2, "control.actuation_delay",
                           unit="s")
    steps = delay / s.plant.time_step
    if abs(steps - round(steps)) > 1e-6:
        raise ValueError(f"control.actuation_delay={delay} s must be a multiple of "
                         f"plant.time_step={s.plant.time_step} s")
    check_finite_vector(s.robot.home_tip_xy, 2, "robot.home_tip_xy")
    check_in_range(s.robot.home_tip_height, 0.0, 0.5, "robot.home_tip_height", unit="m")
    check_finite_vector(s.robot.posture_seed, 7, "robot.posture_seed")
    check_finite_vector(s.robot.left_arm_q, 7, "robot.left_arm_q")
    r = s.randomization
    check_in_range(r.box_xy, 0.0, 0.10, "randomization.box_xy", unit="m")
    check_in_range(r.box_yaw, 0.0, math.pi, "randomization.box_yaw", unit="rad")
    for name in ("box_mass_scale", "box_friction_scale"):
        lo, hi = check_finite_vector(getattr(r, name), 2, f"randomization.{name}")
        check_in_range(lo, 0.1, 1.0, f"randomization.{name}[0]")
        check_in_range(hi, 1.0, 3.0, f"randomization.{name}[1]")
    check_in_range(r.grasp_along, 0.0, 0.03 - abs(s.tool.grasp_offset_along),
                   "randomization.grasp_along", unit="m")
    check_in_range(r.grasp_across, 0.0, 0.01 - abs(s.tool.grasp_offset_across),
                   "randomization.grasp_across", unit="m")
    c = s.camera
    for name in ("width", "height"):
        value = getattr(c, name)
        if not isinstance(value, int) or isinstance(value, bool) or not 16 <= value <= 4096:
            raise ValueError(f"camera.{name}={value!r} must be an integer in [16, 4096] pixels")
    check_in_range(c.fov_y, 0.1, 2.5, "camera.fov_y", unit="rad")
    check_in_range(c.clipping_near, 0.01, 1.0, "camera.clipping_near", unit="m")
    check_in_range(c.clipping_far, c.clipping_near, 100.0, "camera.clipping_far", unit="m",
                   lower_inclusive=False)
    check_in_range(c.depth_min, c.clipping_near, c.clipping_far, "camera.depth_min", unit="m")
    check_in_range(c.depth_max, c.depth_min, c.clipping_far, "camera.depth_max", unit="m",
                   lower_inclusive=False)
    check_in_range(c.noise_sigma, 0.0, 50.0, "camera.noise_sigma", unit="grey levels")
    if not isinstance(s.seed, int) or s.seed < 0:
        raise ValueError(f"seed={s.seed!r} must be a non-negative integer")
    return s


def load_scenario(filename) -> Scenario:
    """Loads and validates a scenario YAML file."""
    path = Path(filename)
    if not path.is_file():
        raise FileNotFoundError(f"scenario file not found: {str(path)!r}")
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path))
    except RuntimeError as e:  # Drake's loader names the offending key.
        raise ValueError(f"invalid scenario {str(path)!r}: {e}") from None
    return validate_scenario(scenario)


def scenario_to_yaml(scenario: Scenario) -> str:
    return yaml_dump_typed(scenario)


def tool_length_or_none(scenario: Scenario) -> float | None:
    """The scenario's tool length (m), or None when no tool is attached."""
    return scenario.tool.length if scenario.tool.attached else None


@dc.dataclass
class RandomDraw:
    """One draw of the scenario's `randomization`: offsets and scales around its nominal
    values."""

    box_dxy: list[float]  # m
    box_dyaw: float  # rad
    box_mass_scale: float
    box_friction_scale: float
    grasp_along: float  # m, added to tool.grasp_offset_along
    grasp_across: float  # m, added to tool.grasp_offset_across


def draw_randomization(scenario: Scenario, rng) -> RandomDraw:
    """Draws from `scenario.randomization` with the numpy Generator `rng` (uniform, in this
    order: box xy, box yaw, mass, friction, then the grasp if a tool is attached)."""
    r = scenario.randomization
    dxy = rng.uniform(-r.box_xy, r.box_xy, 2)
    dyaw = rng.uniform(-r.box_yaw, r.box_yaw)
    mass = rng.uniform(*r.box_mass_scale)
    friction = rng.uniform(*r.box_friction_scale)
    along = across = 0.0
    if scenario.tool.attached:
        along = rng.uniform(-r.grasp_along, r.grasp_along)
        across = rng.uniform(-r.grasp_across, r.grasp_across)
    return RandomDraw([float(dxy[0]), float(dxy[1])], float(dyaw), float(mass), float(friction),
                      float(along), float(across))


def apply_draw(scenario: Scenario, draw: RandomDraw, box_pose_only: bool = False) -> Scenario:
    """A copy of `scenario` with the draw built in: the box's start pose, and (unless
    `box_pose_only`) its mass and friction and the grasp."""
    b = scenario.box
    box = dc.replace(b, position=[b.position[0] + draw.box_dxy[0],
                                  b.position[1] + draw.box_dxy[1], b.position[2]],
                     yaw=b.yaw + draw.box_dyaw)
    tool = scenario.tool
    if not box_pose_only:
        box = dc.replace(box, mass=b.mass * draw.box_mass_scale,
                         friction=b.friction * draw.box_friction_scale)
        tool = dc.replace(tool, grasp_offset_along=tool.grasp_offset_along + draw.grasp_along,
                          grasp_offset_across=tool.grasp_offset_across + draw.grasp_across)
    return validate_scenario(dc.replace(scenario, box=box, tool=tool))


def with_tool_length(scenario: Scenario, length: float) -> Scenario:
    """A copy of `scenario` holding a tool of `length` m."""
    tool = dc.replace(scenario.tool, length=check_tool_length(length))
    return validate_scenario(dc.replace(scenario, tool=tool))
