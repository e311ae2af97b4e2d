"""The open-loop trajectory made to push with the tool's shaft, through the box's centre line
(issue 13, item 2).

The paper's averaged trajectory brings the tool down vertically, so its point meets the box:
a point contact, along which the box turns and slides off the push line, with nothing to bring
it back open loop. Two changes make the open-loop push stable (Lynch & Mason 1996, "Stable
pushing": a line contact through the centre of friction):

- **centred**: the episodes' mean pushes ~0.4 cm to one side of the box's centre (each closed-
  loop episode corrects its own way; their mean corrects nothing), and 0.5-1 cm off the centre
  line an open-loop push slides the box off it; the trajectory is moved across the push so that
  the tool, while it pushes, runs through the box's centre line;
- **tilted**: the tool turned about the push direction, its tip leaning away from the robot,
  about the point of its axis at the box's mid-height, which lays the shaft across the box's
  face: a line contact. The tilt is ramped in over the first RAMP_STEPS steps (the approach:
  it must be complete before the tool meets the box, ~12-16 steps in).

How steep: the first of TILTS_DEG (30 degrees, then shallower) at which the IK follows the
whole trajectory for the tool, not only from the nominal box start but shifted to every corner
and edge midpoint of the box start's randomization square (a replay is shifted to the box start
the camera measures): every pose reached under the conservative real-robot limits, with no
joint moving more than MAX_JOINT_STEP in a control step. A larger step is the IK leaving one
branch of solutions for another (its warm start fails, a library start finds a distant one,
2-5 rad away): the arm swings across the table. Steeper tilts push no better once the push is
centred and bring the arm to its limits (`python benchmarks/open_loop_variants.py --tilts`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix

from drake_tooluse.experiments.trajectory import filter_reachable, shifted
from drake_tooluse.robot.baxter_model import (
    Q_LOWER_CONSERVATIVE,
    Q_UPPER_CONSERVATIVE,
    RIGHT_ARM_JOINTS,
)
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import initial_box_pose

TILTS_DEG = (30, 25, 20, 15, 10)  # tried in this order
RAMP_STEPS = 10  # the recorded tip first meets the box ~12-16 steps in
# rad per control step: a jump between IK branches is 2-5 rad; the end of the tilt's ramp
# turns the wrist by up to ~0.5 rad in a step.
MAX_JOINT_STEP = 1.0


def centred(traj: TipTrajectory, push_direction, p_WB, box_size) -> TipTrajectory:
    """The trajectory moved across the push so that its tool axis, at the height of the box
    centre `p_WB`, runs on average through the box's centre line over the poses that push:
    the tip below the box's top and the axis no further back than 1 cm behind its face (the
    box is `box_size` (m, x y z), its faces square to W's axes, as at its nominal start)."""
    u = np.array([push_direction[0], push_direction[1], 0.0])
    u /= np.linalg.norm(u)
    side = np.cross([0.0, 0.0, 1.0], u)
    half_along = 0.5 * float(np.abs(u[:2]) @ np.asarray(box_size, float)[:2])  # centre to face
    half_height = 0.5 * float(box_size[2])
    axis_points = _axis_points(traj, p_WB[2]) - p_WB
    pushing = (axis_points @ u >= -(half_along + 0.01)) & (
        traj.positions[:, 2] <= p_WB[2] + half_height
    )
    if not pushing.any():
        raise ValueError("the trajectory never pushes the box: nothing to centre on it")
    offset = float((axis_points[pushing] @ side).mean())
    return shifted(traj, -offset * side[:2])


def _axis_points(traj: TipTrajectory, height: float) -> np.ndarray:
    """Where each pose's tool axis (T's z) passes the height `height` (m)."""
    points = []
    for p_WT, q in zip(traj.positions, traj.quaternions):
        tool_axis = RotationMatrix(Quaternion(q)).matrix()[:, 2]
        if tool_axis[2] > -0.1:
            raise ValueError(f"the tool does not point down (axis {tool_axis.round(3)})")
        points.append(p_WT + (height - p_WT[2]) / tool_axis[2] * tool_axis)
    return np.array(points)


def tilted(traj: TipTrajectory, angle: float, push_direction, p_WB) -> TipTrajectory:
    """The trajectory with the tool turned by `angle` (rad, ramped in over RAMP_STEPS) about
    the horizontal `push_direction`, about the point of the tool's axis at the height of the box
    centre `p_WB`, the tip leaning away from the robot (W's origin, Baxter's base): to the side
    of the push line that points away from the base, chosen once for the whole trajectory."""
    u = np.array([push_direction[0], push_direction[1], 0.0])
    u /= np.linalg.norm(u)
    # A turn by +angle about u swings a downward tool's tip along side = z × u (for small
    # angles, d' = d + angle u × d with d = -z); lean to whichever of ±side points away from
    # the base.
    side = np.cross([0.0, 0.0, 1.0], u)[:2]
    away = float(side @ p_WB[:2]) / np.linalg.norm(p_WB[:2])
    if abs(away) < 0.1:
        raise ValueError(
            f"push direction {list(np.round(push_direction, 3))} runs (nearly) towards or away "
            "from the robot: no side of it leans away from the robot (need its angle to the "
            "line from the base to the box over ~6 deg)"
        )
    sign = 1.0 if away > 0 else -1.0
    positions, quaternions = [], []
    pivots = _axis_points(traj, p_WB[2])
    for k, (p_WT, q, p_WPivot) in enumerate(zip(traj.positions, traj.quaternions, pivots)):
        R_turn = RotationMatrix(AngleAxis(sign * angle * min(1.0, k / RAMP_STEPS), u))
        positions.append(p_WPivot + R_turn.matrix() @ (p_WT - p_WPivot))
        quaternions.append((R_turn @ RotationMatrix(Quaternion(q))).ToQuaternion().wxyz())
    return TipTrajectory(traj.times, np.array(positions), np.array(quaternions))


def joints_at_limit(q: np.ndarray) -> list[str]:
    """The arm joints that reach a conservative limit (within 1 mrad) anywhere on the path."""
    lower = np.any(q <= Q_LOWER_CONSERVATIVE + 1e-3, axis=0)
    upper = np.any(q >= Q_UPPER_CONSERVATIVE - 1e-3, axis=0)
    return [name for name, hit in zip(RIGHT_ARM_JOINTS, lower | upper) if hit]


@dataclass
class LineContact:
    """A tool's line-contact trajectory and how it was chosen."""

    trajectory: TipTrajectory  # for the nominal box start, the poses the IK reaches
    tilt_deg: int
    followed: bool  # every shifted replay reached in full with no jump (else the least bad)
    poses: int  # of the trajectory before the reachability filter
    reachable: int  # of them, the IK reaches from the nominal box start
    worst_joint_step: float  # rad per control step, over every shifted replay
    joints_at_limit: list[str]  # for the nominal box start

    def as_dict(self) -> dict:
        return {
            "tilt_deg": self.tilt_deg,
            "followed": self.followed,
            "poses": self.poses,
            "reachable": self.reachable,
            "worst_joint_step_rad": self.worst_joint_step,
            "joints_at_limit": self.joints_at_limit,
        }


def box_start_shifts(box_xy: float) -> list[tuple[float, float]]:
    """The nominal box start (first) and the corners and edge midpoints of the square of
    half-width `box_xy` (m) around it: the shifts a replay is checked at."""
    steps = (0.0, -box_xy, box_xy) if box_xy > 0 else (0.0,)
    return [(dx, dy) for dx in steps for dy in steps]


def line_contact(
    base: TipTrajectory,
    tool: float,
    push_direction,
    p_WB,
    box_xy: float,
    box_size,
    tilts_deg=TILTS_DEG,
) -> LineContact:
    """The tool's line-contact trajectory of `base` (a trajectory in the frame of the nominal
    box start `p_WB`): centred on the box, at the first tilt of `tilts_deg` that the IK
    follows for every box start within ±`box_xy` (see the module docstring); where none does,
    the tilt whose worst replay has the most poses reached, then the smallest joint step
    (`followed` False)."""
    base = centred(base, push_direction, p_WB, box_size)
    best = None
    for deg in tilts_deg:
        trajectory = tilted(base, np.radians(deg), push_direction, p_WB)
        reports = []  # one per shift, the nominal first; None: no pose reachable
        for dxy in box_start_shifts(box_xy):
            try:
                reports.append(filter_reachable(shifted(trajectory, dxy), tool))
            except ValueError:
                reports.append(None)
        nominal = reports[0]
        if nominal is None:
            continue
        reached = min(r.reachable if r is not None else 0 for r in reports)
        worst_step = max(
            np.abs(np.diff(r.joint_positions, axis=0)).max(initial=0.0) if r else np.inf
            for r in reports
        )
        candidate = LineContact(
            nominal.kept,
            deg,
            bool(reached == len(base) and worst_step <= MAX_JOINT_STEP),
            len(base),
            nominal.reachable,
            float(worst_step),
            joints_at_limit(nominal.joint_positions),
        )
        if candidate.followed:
            return candidate
        rank = (reached, -worst_step)
        if best is None or rank > best[0]:
            best = (rank, candidate)
    if best is None:
        raise ValueError(
            f"no tilt of {tuple(tilts_deg)} degrees is reachable with the {tool} m tool"
        )
    return best[1]


def line_contact_for_task(
    base: TipTrajectory, tool: float, scenario: Scenario, tilts_deg=TILTS_DEG
) -> LineContact:
    """`line_contact` for the push task of `scenario`: its push direction (the goal's offset),
    nominal box start, the randomization of that start and the box's size along the push."""
    return line_contact(
        base,
        tool,
        scenario.goal_offset,
        initial_box_pose(scenario).translation(),
        scenario.randomization.box_xy,
        scenario.box.size,
        tilts_deg,
    )
