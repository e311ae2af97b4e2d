"""The open-loop trajectory made to push with the tool's shaft, through the box's centre line.

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

Which IK branch: from Baxter's posture seed the IK follows the trajectory with tools up to
~0.20 m. A longer tool, held higher and leaning its grip towards the robot, takes the shoulder
(s1) to its conservative limit in the first steps; the IK then drives s0 and w0 to theirs and
jumps to another branch mid-push. Where the seed's path is not followed, the arm starts on the
branch it ends on instead (`branch_start`: the IK warm-started backwards from the path's end),
kept as the trajectory's `arm_start` (the replay's home posture is solved from it, as a
planned motion starts from its own configuration): 30 deg with a 0.25 m tool, 25 with 0.30.

Where across the push (`calibrated`): the geometric centring runs the tool's axis through the
box's centre line, but the arm yields under the push, each posture its own way: on the other
branch the box slides ~2 cm sideways along the shaft and off it. The trajectory is moved across
the push to the offset (within ±1 cm) that brings the most boxes to the goal over randomized
replays in the nominal simulation (never reality); with the paper's tools that is the geometric
centring itself.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix

from drake_tooluse.experiments.choices import CALIBRATION_DRAWS
from drake_tooluse.experiments.trajectory_extraction import filter_reachable, shifted
from drake_tooluse.robot.baxter_model import (
    Q_LOWER_CONSERVATIVE,
    Q_UPPER_CONSERVATIVE,
    RIGHT_ARM_JOINTS,
)
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.tasks.push.diagram import run_open_loop
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import Scenario, with_tool_length
from drake_tooluse.world.scene import initial_box_pose

TILTS_DEG = (30, 25, 20, 15, 10)  # tried in this order
RAMP_STEPS = 10  # the recorded tip first meets the box ~12-16 steps in
# rad per control step: a jump between IK branches is 2-5 rad; the end of the tilt's ramp
# turns the wrist by up to ~0.5 rad in a step.
MAX_JOINT_STEP = 1.0
# Where across the push the tool runs, tried in the nominal simulation (m from the geometric
# centring, along `side_of`): the draws' seeds CALIBRATION_SEED + i lie apart from the
# transfer's runs (seeds 0 … runs - 1 by default).
CALIBRATION_OFFSETS = tuple(round(mm * 1e-3, 3) for mm in range(-10, 11, 2))
CALIBRATION_SEED = 1000


def centred(traj: TipTrajectory, push_direction, p_WB, box_size) -> TipTrajectory:
    """The trajectory moved across the push so that its tool axis, at the height of the box
    centre `p_WB`, runs on average through the box's centre line over the poses that push:
    the tip below the box's top and the axis no further back than 1 cm behind its face (the
    box is `box_size` (m, x y z), its faces square to W's axes, as at its nominal start)."""
    u = np.array([push_direction[0], push_direction[1], 0.0])
    u /= np.linalg.norm(u)
    side = side_of(push_direction)
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


def side_of(push_direction) -> np.ndarray:
    """The horizontal unit vector z × u across the push direction u (to its left)."""
    u = np.array([push_direction[0], push_direction[1], 0.0])
    return np.cross([0.0, 0.0, 1.0], u / np.linalg.norm(u))


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
    q_end: np.ndarray  # the arm's posture at the last pose, for the nominal box start
    across_offset: float = 0.0  # m along `side_of` the push, from the geometric centring
    calibration: list[dict] | None = None  # per offset tried (`calibrated`); None: not tried

    def as_dict(self) -> dict:
        arm_start = self.trajectory.arm_start
        return {
            "tilt_deg": self.tilt_deg,
            "followed": self.followed,
            "poses": self.poses,
            "reachable": self.reachable,
            "worst_joint_step_rad": self.worst_joint_step,
            "joints_at_limit": self.joints_at_limit,
            "arm_start": None if arm_start is None else arm_start.tolist(),
            "across_offset_m": self.across_offset,
            "calibration": self.calibration,
        }


def box_start_shifts(box_xy: float) -> list[tuple[float, float]]:
    """The nominal box start (first) and the corners and edge midpoints of the square of
    half-width `box_xy` (m) around it: the shifts a replay is checked at."""
    steps = (0.0, -box_xy, box_xy) if box_xy > 0 else (0.0,)
    return [(dx, dy) for dx in steps for dy in steps]


def _reversed(traj: TipTrajectory) -> TipTrajectory:
    """The poses of `traj` in reverse order (at its times: only the order matters to the IK)."""
    return TipTrajectory(traj.times, traj.positions[::-1], traj.quaternions[::-1])


def branch_start(trajectory: TipTrajectory, tool: float, q_end) -> np.ndarray:
    """The arm posture at the trajectory's first pose on the IK branch it ends on at `q_end`:
    the IK warm-started backwards along it from there."""
    return filter_reachable(_reversed(trajectory), tool, q_start=q_end).joint_positions[-1]


def _tried(trajectory, deg, tool, box_xy, q_start) -> tuple[LineContact, tuple] | None:
    """`trajectory` (at tilt `deg`) replayed through the IK from `q_start` (None: the posture
    seed), shifted to every box start of `box_start_shifts`: (the candidate, its rank: poses
    reached by the worst replay, then minus the largest joint step), or None where the IK
    reaches no pose of it from the nominal box start."""
    reports = []
    for dxy in box_start_shifts(box_xy):
        try:
            reports.append(filter_reachable(shifted(trajectory, dxy), tool, q_start=q_start))
        except ValueError:
            reports.append(None)
    nominal = reports[0]
    if nominal is None:
        return None
    reached = min(r.reachable if r is not None else 0 for r in reports)
    worst_step = max(
        np.abs(np.diff(r.joint_positions, axis=0)).max(initial=0.0) if r else np.inf
        for r in reports
    )
    kept = nominal.kept
    candidate = LineContact(
        TipTrajectory(kept.times, kept.positions, kept.quaternions, q_start),
        deg,
        bool(reached == len(trajectory) and worst_step <= MAX_JOINT_STEP),
        len(trajectory),
        nominal.reachable,
        float(worst_step),
        joints_at_limit(nominal.joint_positions),
        nominal.joint_positions[-1],
    )
    return candidate, (reached, -worst_step)


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
    follows for every box start within ±`box_xy` (see the module docstring), from the arm's
    posture seed or else from the start of the branch the seed's path ends on
    (`branch_start`, kept as the trajectory's `arm_start`); where none does, the tilt and
    start whose worst replay has the most poses reached, then the smallest joint step
    (`followed` False)."""
    base = centred(base, push_direction, p_WB, box_size)
    best = None
    for deg in tilts_deg:
        trajectory = tilted(base, np.radians(deg), push_direction, p_WB)
        tried = [_tried(trajectory, deg, tool, box_xy, None)]
        if tried[0] is not None and not tried[0][0].followed:
            # From the seed the path left its branch (a jump, or a conservative limit that
            # cut it short): try the branch it ends on, from that branch's own start.
            q_start = branch_start(trajectory, tool, tried[0][0].q_end)
            tried.append(_tried(trajectory, deg, tool, box_xy, q_start))
        for candidate, rank in filter(None, tried):
            if candidate.followed:
                return candidate
            if best is None or rank > best[0]:
                best = (rank, candidate)
    if best is None:
        raise ValueError(
            f"no tilt of {tuple(tilts_deg)} degrees is reachable with the {tool} m tool"
        )
    return best[1]


def nominal_replays(trajectory, tool: float, scenario: Scenario, draws: int, seed: int):
    """The trajectory (made for the nominal box start of `scenario`) replayed in the nominal
    simulation as the transfer replays it, at the box start of each of `draws` randomization
    draws of `scenario` (seeds `seed` + i: box start, mass, friction and grasp; the robot knows
    its tool and grasp): (boxes at the goal, mean final box-goal distance in m)."""
    p_WB = initial_box_pose(scenario).translation()
    at_goal, distances = 0, []
    for i in range(draws):
        draw = draw_randomization(scenario, np.random.default_rng(seed + i))
        world = apply_draw(with_tool_length(scenario, tool), draw)
        replay = shifted(trajectory, initial_box_pose(world).translation()[:2] - p_WB[:2])
        push = run_open_loop(world, replay, RobotBelief(tool, (0.0, world.tool.grasp_offset_along)))
        at_goal += push.success and not push.sim_error
        distances.append(push.final_object_to_goal)
    return at_goal, float(np.mean(distances))


def calibrated(
    contact: LineContact,
    tool: float,
    scenario: Scenario,
    draws: int = CALIBRATION_DRAWS,
    seed: int = CALIBRATION_SEED,
    offsets=CALIBRATION_OFFSETS,
) -> LineContact:
    """`contact` moved across the push by the one of `offsets` (m) that pushes best in the
    nominal simulation (`nominal_replays`): the most boxes at the goal, then the smallest mean
    final distance; an offset the IK does not follow from every box start (where the unmoved
    trajectory is followed) is not tried. Why: the geometric centring puts the tool's axis
    through the box's centre line, but the arm yields under the push, and how depends on its
    posture (a long tool's other branch, `branch_start`, slides the box off to one side)."""
    side = side_of(scenario.goal_offset)
    box_xy = scenario.randomization.box_xy
    rows, best = [], None
    for offset in offsets:
        moved = replace(contact, trajectory=shifted(contact.trajectory, offset * side[:2]))
        if contact.followed:  # the IK's figures of the moved trajectory, if it follows it
            t = moved.trajectory
            tried = _tried(t, contact.tilt_deg, tool, box_xy, t.arm_start)
            if tried is None or not tried[0].followed:
                rows.append({"offset_m": offset, "followed": False})
                continue
            moved = tried[0]
        at_goal, distance = nominal_replays(moved.trajectory, tool, scenario, draws, seed)
        rows.append({"offset_m": offset, "at_goal": at_goal, "mean_final_distance_m": distance})
        if best is None or (at_goal, -distance) > best[0]:
            best = ((at_goal, -distance), replace(moved, across_offset=offset))
    return replace(contact if best is None else best[1], calibration=rows)


def describe_choice(contact: dict) -> str:
    """What `LineContact.as_dict` says beyond the tilt, as a clause: where the arm starts and
    how far the trajectory was moved across the push ('' if neither)."""
    text = ", the arm started on the IK branch it follows" if contact.get("arm_start") else ""
    if contact.get("calibration"):
        tried = [row for row in contact["calibration"] if "at_goal" in row]
        text += (
            f", moved {contact['across_offset_m'] * 1000:+.0f} mm across the push (best of "
            f"{len(tried)} offsets in the nominal simulation)"
        )
    return text


def line_contact_for_task(
    base: TipTrajectory,
    tool: float,
    scenario: Scenario,
    tilts_deg=TILTS_DEG,
    calibration_draws: int = CALIBRATION_DRAWS,
) -> LineContact:
    """`line_contact` for the push task of `scenario`: its push direction (the goal's offset),
    nominal box start, the randomization of that start and the box's size along the push;
    then `calibrated` across the push over `calibration_draws` nominal draws (0: not)."""
    contact = line_contact(
        base,
        tool,
        scenario.goal_offset,
        initial_box_pose(scenario).translation(),
        scenario.randomization.box_xy,
        scenario.box.size,
        tilts_deg,
    )
    if calibration_draws == 0:
        return contact
    return calibrated(contact, tool, scenario, calibration_draws)
