"""Tool-tip IK: round trips, the paper's offset method, unreachable targets, bad input."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from drake_tooluse.robot.baxter_model import Q_LOWER, Q_UPPER
from drake_tooluse.robot.ik import (
    ToolTipIK,
    gripper_target_from_tip_target,
    pose_from_vector,
    rotation_angle_between,
)

LENGTHS = [None, 0.05, 0.125, 0.175, 0.30, 0.60]


@pytest.fixture(scope="module", params=LENGTHS, ids=lambda L: f"tool={L}")
def ik(request):
    return ToolTipIK(request.param)


def test_fk_ik_round_trip_from_mid_limits(ik):
    rng = np.random.default_rng(7)
    for _ in range(15):
        X = ik.fk(rng.uniform(Q_LOWER, Q_UPPER))
        result = ik.solve(X)
        assert result.success, result
        assert result.position_error < 1e-5 and result.orientation_error < 1e-4
        assert np.all(result.q >= Q_LOWER) and np.all(result.q <= Q_UPPER)
        # Independent check by FK on the solution.
        X_solved = ik.fk(result.q)
        assert np.linalg.norm(X_solved.translation() - X.translation()) < 1e-5
        assert rotation_angle_between(X_solved.rotation(), X.rotation()) < 1e-4


def test_same_call_gives_same_answer():
    ik = ToolTipIK(0.175)
    X = ik.fk([0.3, -0.5, 0.2, 1.2, 0.1, 0.8, -0.3])
    a, b = ik.solve(X), ToolTipIK(0.175).solve(X)
    np.testing.assert_array_equal(a.q, b.q)


@pytest.mark.parametrize("length", [0.125, 0.175, 0.30])
def test_offset_method_agrees_with_tip_frame_ik(length):
    tip_ik, gripper_ik = ToolTipIK(length), ToolTipIK(None)
    rng = np.random.default_rng(3)
    for _ in range(10):
        X_WT = tip_ik.fk(rng.uniform(Q_LOWER, Q_UPPER))
        X_WG = gripper_target_from_tip_target(X_WT, length)
        via_offset = gripper_ik.solve(X_WG)
        assert via_offset.success
        # The gripper solution puts the tool tip on the target too, and vice versa.
        X_tip = tip_ik.fk(via_offset.q)
        assert np.linalg.norm(X_tip.translation() - X_WT.translation()) < 1e-5
        assert rotation_angle_between(X_tip.rotation(), X_WT.rotation()) < 1e-4
        via_tip = tip_ik.solve(X_WT)
        X_g = gripper_ik.fk(via_tip.q)
        assert np.linalg.norm(X_g.translation() - X_WG.translation()) < 1e-5


def test_offset_is_the_rotated_tool_vector():
    X_WT = RigidTransform(RollPitchYaw(np.pi, 0, 0), [0.7, -0.2, 0.0])  # tool pointing down
    X_WG = gripper_target_from_tip_target(X_WT, 0.175)
    np.testing.assert_allclose(X_WG.translation(), [0.7, -0.2, 0.175], atol=1e-12)


def test_unreachable_target_is_a_result_not_an_exception():
    ik = ToolTipIK(0.175, max_attempts=3)
    result = ik.solve(RigidTransform(RollPitchYaw(np.pi, 0, 0), [3.0, 0.0, 0.0]))
    assert not result.success
    assert result.position_error > 1.0  # the residual: ~1.7 m beyond reach
    assert np.all(np.isfinite(result.q))


@pytest.mark.parametrize("length", [0.0, -0.1, float("nan"), 0.61, float("inf")])
def test_bad_tool_length_names_value_and_range(length):
    with pytest.raises(ValueError, match=r"tool length.*(range \(0, 0\.6\]|finite)"):
        ToolTipIK(length)


def test_non_finite_target_is_an_error():
    ik = ToolTipIK(0.175, library_size=1)
    with pytest.raises(ValueError, match="finite"):
        ik.solve([0.7, np.nan, 0.0, 1, 0, 0, 0])


def test_zero_quaternion_is_an_error():
    with pytest.raises(ValueError, match="zero norm"):
        pose_from_vector([0.7, 0.0, 0.0, 0, 0, 0, 0])


def test_q_of_wrong_size_or_outside_limits():
    ik = ToolTipIK(0.175, library_size=1)
    with pytest.raises(ValueError, match="exactly 7"):
        ik.check_q([0.0] * 6)
    with pytest.raises(ValueError, match=r"right_s1=2 rad outside \[-2.147, 1.047\]"):
        ik.check_q([0.0, 2.0, 0.0, 0.5, 0.0, 0.0, 0.0])


def test_robot_model_with_a_believed_grasp_offset():
    """The tip frame sits `length` past the grasp point, which sits (across, along) from the
    gripper frame's origin."""
    import numpy as np

    from drake_tooluse.robot.ik import ToolTipIK

    ik = ToolTipIK(0.2, grasp_offset=(0.004, -0.01), library_size=1)
    q = np.array([0.3, -0.5, 0.1, 1.2, 0.2, 0.8, -0.4])
    X_WG, X_WT = ik.fk_gripper(q), ik.fk(q)
    np.testing.assert_allclose(X_WG.inverse() @ X_WT.translation(), [0.004, 0.0, 0.19], atol=1e-12)


def test_fast_path_is_held_to_the_solver_of_record():
    """The Levenberg–Marquardt answer satisfies Drake InverseKinematics' own constraints (the
    program the SNOPT path solves), and SNOPT started at it stays there."""
    ik = ToolTipIK(0.175)
    rng = np.random.default_rng(11)
    for q_true in rng.uniform(Q_LOWER, Q_UPPER, size=(20, 7)):
        X = ik.fk(q_true)
        fast = ik.solve(X)
        assert fast.success and fast.solver == "newton"
        program = ik._new_ik(X)
        program.AddOrientationConstraint(
            ik.plant.world_frame(), X.rotation(), ik.tip_frame, RotationMatrix(), 1e-6
        )
        constraints = program.prog().GetAllConstraints()
        assert program.prog().CheckSatisfied(constraints, fast.q, tol=1e-8)
        polished = ik.solve_with_snopt(X, fast.q)
        assert polished.success and np.max(np.abs(polished.q - fast.q)) < 1e-6


def test_snopt_remains_the_fallback(monkeypatch):
    """Where the fast path finds nothing, the answer comes from InverseKinematics."""
    ik = ToolTipIK(0.175)
    X = ik.fk([0.3, -0.5, 0.2, 1.2, 0.1, 0.8, -0.3])
    monkeypatch.setattr(ik, "_fast_starts", lambda p, R, q_seed: iter(()))
    result = ik.solve(X)
    assert result.success and result.solver == "snopt"


def test_warm_solves_along_a_smooth_path_stay_on_their_branch():
    """A tip path made by a smooth joint path (steps up to 0.05 rad) away from the wrist and
    elbow singularities (w1, e1 > 0.2 rad), each solve seeded by the last answer: no joint
    jumps (the answer follows the path's own branch)."""
    ik = ToolTipIK(0.30)
    t = np.linspace(0.0, 2 * np.pi, 800)[:, None]
    centre = np.array([0.0, -0.5, 0.0, 1.3, 0.0, 1.0, 0.0])
    amplitude = np.array([0.8, 0.6, 1.2, 0.8, 1.2, 0.7, 1.5])
    path = centre + amplitude * np.sin(t * np.arange(1, 8) * 0.5 + np.arange(7))
    assert np.max(np.abs(np.diff(path, axis=0))) <= 0.05
    assert path[:, 3].min() > 0.2 and path[:, 5].min() > 0.2
    q = path[0]
    for q_path in path[1:]:
        result = ik.solve(ik.fk(q_path), q)
        assert result.success
        assert np.max(np.abs(result.q - q)) < 0.5
        q = result.q


@pytest.mark.parametrize("bad", [[np.nan] * 7, [0.0] * 6, [0.0] * 8])
def test_fk_with_bad_joint_angles_is_a_value_error(bad):
    ik = ToolTipIK(0.175, library_size=1)
    for call in (ik.fk, ik.fk_gripper, lambda q: ik.errors(q, ik.fk(np.zeros(7)))):
        with pytest.raises(ValueError, match="q"):
            call(bad)


def test_a_target_rotation_that_is_not_orthonormal_is_refused():
    ik = ToolTipIK(0.175, library_size=1)
    R = RollPitchYaw(np.pi, 0, np.pi / 2).ToRotationMatrix().matrix()
    X = RigidTransform(RotationMatrix(np.diag([2.0, 1.0, 1.0]) @ R), [0.65, -0.25, -0.1])
    with pytest.raises(ValueError, match="not orthonormal"):
        ik.solve(X)
