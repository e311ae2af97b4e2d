"""The line-contact variant of benchmarks/open_loop_variants.py: the tool is turned about the push
direction, about the point of its axis at the box's mid-height, the tip leaning away from the
robot, ramped in from the recorded start."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix

from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tip_trajectory import TipTrajectory

_spec = importlib.util.spec_from_file_location(
    "open_loop_variants",
    Path(__file__).resolve().parents[2] / "benchmarks" / "open_loop_variants.py",
)
variants = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(variants)


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
