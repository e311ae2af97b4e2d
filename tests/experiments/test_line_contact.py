"""The line-contact trajectory (`experiments.line_contact`): the tool is turned about the push
direction, about the point of its axis at the box's mid-height, the tip leaning away from the
robot, ramped in from the recorded start; the push is centred on the box; the tilt is the first
that the IK follows from every box start."""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix

from drake_tooluse.experiments import line_contact as variants
from drake_tooluse.experiments.trajectory_extraction import filter_reachable
from drake_tooluse.paths import DEFAULT_SCENARIO
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.world.scenario import load_scenario

Q_DOWN = RollPitchYaw(*TOOL_DOWN_RPY).ToQuaternion().wxyz()
P_WBOX = np.array([0.7, -0.25, -0.18])  # the nominal box centre (push.yaml)
BOX_SIZE = (0.04, 0.04, 0.04)  # m (push.yaml)


def _axis(q) -> np.ndarray:
    return RotationMatrix(Quaternion(q)).matrix()[:, 2]


@pytest.mark.parametrize("push", [(0.0, 0.2), (0.0, -0.2), (1.0, 1.0), (-1.0, 0.5)])
def test_the_tool_turns_about_its_point_at_the_box_mid_height_leaning_away_from_the_robot(push):
    T = variants.RAMP_STEPS + 5
    p_WBox = np.array([0.7, -0.25, -0.18])
    positions = np.column_stack(
        [np.full(T, 0.7), np.linspace(-0.3, -0.1, T), np.linspace(-0.1, -0.195, T)]
    )
    q_down = RollPitchYaw(*TOOL_DOWN_RPY).ToQuaternion().wxyz()
    traj = TipTrajectory(np.arange(T) * 0.04, positions, np.tile(q_down, (T, 1)))
    angle = np.radians(45)
    u = np.array([*push, 0.0]) / np.linalg.norm(push)
    out = variants.tilted(traj, angle, [*push, 0.0], p_WBox)

    np.testing.assert_allclose(out.positions[0], positions[0])  # the start is the recorded one
    np.testing.assert_allclose(out.quaternions[0], q_down, atol=1e-12)
    for k in range(T):
        axis_before, axis_after = _axis(q_down), _axis(out.quaternions[k])
        expected = angle * min(1.0, k / variants.RAMP_STEPS)
        assert np.isclose(np.arccos(np.clip(axis_before @ axis_after, -1, 1)), expected)
        assert abs(axis_after @ u) < 1e-12  # turned about the push direction only
        if k:
            assert axis_after[:2] @ p_WBox[:2] > 0  # the tip leans away from the base
        # the point of the tool's axis at the box's mid-height stays where it was
        pivot_before = positions[k] + (p_WBox[2] - positions[k][2]) / axis_before[2] * axis_before
        pivot_after = (
            out.positions[k] + (p_WBox[2] - out.positions[k][2]) / axis_after[2] * axis_after
        )
        np.testing.assert_allclose(pivot_after, pivot_before, atol=1e-12)


def test_a_push_towards_the_robot_has_no_side_to_lean_to():
    traj = TipTrajectory(
        [0.0], [[0.7, -0.25, -0.1]], [RollPitchYaw(*TOOL_DOWN_RPY).ToQuaternion().wxyz()]
    )
    with pytest.raises(ValueError, match="towards or away from the robot"):
        variants.tilted(traj, 0.7, [-0.7, 0.25, 0.0], np.array([0.7, -0.25, -0.18]))


def _push(across: float = 0.0, T: int = 40) -> TipTrajectory:
    """A push along +y like a policy's: down in front of the box, then 17 cm through it,
    `across` (m) to the +x side of its centre line."""
    approach = np.linspace([-0.06, -0.07, 0.06], [across, -0.03, -0.013], 12)
    push = np.linspace([across, -0.03, -0.013], [across, 0.17, -0.013], T - 12)
    positions = P_WBOX + np.vstack([approach, push])
    return TipTrajectory(np.arange(T) * 0.04, positions, np.tile(Q_DOWN, (T, 1)))


def test_centring_puts_the_push_on_the_box_centre_line():
    out = variants.centred(_push(across=0.005), [0.0, 0.2, 0.0], P_WBOX, BOX_SIZE)
    np.testing.assert_allclose(out.positions[12:, 0], P_WBOX[0], atol=1e-12)
    np.testing.assert_allclose(out.positions[:, 1:], _push().positions[:, 1:])  # across only
    never = TipTrajectory([0.0, 0.04], P_WBOX + [[0, -0.2, 0.1]] * 2, [Q_DOWN] * 2)
    with pytest.raises(ValueError, match="never pushes the box"):
        variants.centred(never, [0.0, 0.2, 0.0], P_WBOX, BOX_SIZE)


def test_centring_takes_the_box_size_along_the_push_not_across_it():
    """A box long along the push (+y) counts the approach's last poses as pushing; one wide
    across it (x) centres as the cube does."""
    push = _push(across=0.005)
    cube = variants.centred(push, [0.0, 0.2, 0.0], P_WBOX, BOX_SIZE)
    wide = variants.centred(push, [0.0, 0.2, 0.0], P_WBOX, (0.2, 0.04, 0.04))
    long = variants.centred(push, [0.0, 0.2, 0.0], P_WBOX, (0.04, 0.2, 0.04))
    np.testing.assert_array_equal(wide.positions, cube.positions)
    assert abs(long.positions[12, 0] - cube.positions[12, 0]) > 1e-4


def test_the_box_starts_checked_are_the_nominal_then_the_square_around_it():
    shifts = variants.box_start_shifts(0.02)
    assert shifts[0] == (0.0, 0.0) and len(set(shifts)) == 9
    assert {abs(v) for s in shifts for v in s} == {0.0, 0.02}
    assert variants.box_start_shifts(0.0) == [(0.0, 0.0)]


def test_line_contact_takes_the_first_tilt_the_ik_follows_from_every_box_start():
    contact = variants.line_contact(_push(0.004), 0.175, [0.0, 0.2, 0.0], P_WBOX, 0.02, BOX_SIZE)
    assert contact.followed and contact.tilt_deg == variants.TILTS_DEG[0]
    assert contact.reachable == contact.poses == len(contact.trajectory) == 40
    assert contact.worst_joint_step <= variants.MAX_JOINT_STEP
    tilt = np.degrees(np.arccos(-_axis(contact.trajectory.quaternions[-1])[2]))
    assert tilt == pytest.approx(contact.tilt_deg)
    # Centred, then tilted about the axis point at the box's mid-height: that point of every
    # pushing pose is on the box's centre line.
    for p_WT, q in zip(contact.trajectory.positions[12:], contact.trajectory.quaternions[12:]):
        axis = _axis(q)
        pivot = p_WT + (P_WBOX[2] - p_WT[2]) / axis[2] * axis
        assert pivot[0] == pytest.approx(P_WBOX[0], abs=1e-9)
    # A tilt the IK cannot follow (the tool lying flat) is reported, not hidden.
    flat = variants.line_contact(
        _push(), 0.175, [0.0, 0.2, 0.0], P_WBOX, 0.02, BOX_SIZE, tilts_deg=(85,)
    )
    assert not flat.followed and flat.tilt_deg == 85


def _largest_step(q: np.ndarray) -> float:
    return float(np.abs(np.diff(q, axis=0)).max())


def test_a_long_tool_starts_the_arm_on_the_ik_branch_that_follows_the_push():
    """With a 0.25 m tool the IK from Baxter's posture seed leaves its branch mid-push (the
    shoulder at its conservative limit); the arm starts instead where the branch the path ends
    on begins (`branch_start`), kept as the trajectory's `arm_start`, and from there the IK
    follows the steepest tilt. A tool the seed's path follows keeps the seed."""
    push = _push(0.004)
    contact = variants.line_contact(push, 0.25, [0.0, 0.2, 0.0], P_WBOX, 0.02, BOX_SIZE)
    assert contact.followed and contact.tilt_deg == variants.TILTS_DEG[0]
    start = contact.trajectory.arm_start
    assert start is not None and contact.as_dict()["arm_start"] == start.tolist()
    from_seed = filter_reachable(contact.trajectory, 0.25)
    assert _largest_step(from_seed.joint_positions) > variants.MAX_JOINT_STEP
    planned = filter_reachable(contact.trajectory, 0.25, q_start=start)
    assert planned.reachable == len(push)
    assert _largest_step(planned.joint_positions) <= variants.MAX_JOINT_STEP
    short = variants.line_contact(push, 0.175, [0.0, 0.2, 0.0], P_WBOX, 0.02, BOX_SIZE)
    assert short.trajectory.arm_start is None and short.as_dict()["arm_start"] is None


def test_calibration_moves_the_push_across_to_where_it_pushes_best_in_the_nominal_world():
    """`calibrated` replays the trajectory in the nominal simulation at each offset across the
    push and keeps the best: 15 mm beside the 4 cm box's centre line the tool catches only its
    corner and the box turns away; through the centre line it pushes on."""
    scenario = load_scenario(DEFAULT_SCENARIO)
    contact = variants.line_contact_for_task(_push(0.004), 0.175, scenario, calibration_draws=0)
    assert contact.calibration is None and contact.across_offset == 0.0
    assert variants.describe_choice(contact.as_dict()) == ""
    moved = variants.calibrated(contact, 0.175, scenario, draws=1, offsets=(0.015, 0.0))
    beside, through = moved.calibration
    assert (beside["offset_m"], through["offset_m"]) == (0.015, 0.0)
    assert through["mean_final_distance_m"] < beside["mean_final_distance_m"] - 0.01
    assert moved.across_offset == 0.0
    np.testing.assert_array_equal(moved.trajectory.positions, contact.trajectory.positions)
    assert "moved +0 mm across the push (best of 2 offsets" in variants.describe_choice(
        moved.as_dict()
    )
    # An offset moves the trajectory along z × the push direction (here -x).
    beside_only = variants.calibrated(contact, 0.175, scenario, draws=1, offsets=(0.015,))
    np.testing.assert_allclose(
        beside_only.trajectory.positions - contact.trajectory.positions,
        np.tile([-0.015, 0.0, 0.0], (len(contact.trajectory), 1)),
        atol=1e-12,
    )
