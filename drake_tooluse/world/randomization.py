"""Domain randomization as a layer of its own: one draw of a scenario's `randomization`
ranges, and the world it makes.

The envs (`randomize=True`), the transfer experiment and the demo all draw here
(`draw_randomization`) and build the drawn world with `apply_draw`; the env then puts the
drawn scenario's box, mass, friction and grasp into its context (`world.scene`).
"""

import dataclasses as dc
import math

from drake_tooluse.world.scenario import Scenario, validate_scenario


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
    return RandomDraw(
        [float(dxy[0]), float(dxy[1])],
        float(dyaw),
        float(mass),
        float(friction),
        float(along),
        float(across),
    )


def apply_draw(scenario: Scenario, draw: RandomDraw, box_pose_only: bool = False) -> Scenario:
    """A copy of `scenario` with the draw built in: the box's start pose, and (unless
    `box_pose_only`) its mass and friction and the grasp."""
    b = scenario.box
    box = dc.replace(
        b,
        position=[b.position[0] + draw.box_dxy[0], b.position[1] + draw.box_dxy[1], b.position[2]],
        yaw=wrap_angle(b.yaw + draw.box_dyaw),
    )
    tool = scenario.tool
    if not box_pose_only:
        box = dc.replace(
            box, mass=b.mass * draw.box_mass_scale, friction=b.friction * draw.box_friction_scale
        )
        tool = dc.replace(
            tool,
            grasp_offset_along=tool.grasp_offset_along + draw.grasp_along,
            grasp_offset_across=tool.grasp_offset_across + draw.grasp_across,
        )
    return validate_scenario(dc.replace(scenario, box=box, tool=tool))


def wrap_angle(angle: float) -> float:
    """The same angle in [-pi, pi] (rad)."""
    if -math.pi <= angle <= math.pi:
        return angle
    return math.remainder(angle, 2 * math.pi)
