"""The project's Baxter model against Rethink's upstream URDF, and the world it builds."""

import json
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.paths import MODELS_DIR
from drake_tooluse.robot.baxter_model import ARM_LIMITS, RIGHT_ARM_JOINTS, baxter_urdf
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import make_robot_model
from drake_tooluse.world.scenario import Scenario, with_tool_length
from drake_tooluse.world.scene import add_world, goal_position, initial_box_pose

DATA = Path(__file__).parent / "data"


def test_gripper_fk_matches_upstream_urdf():
    reference = json.loads((DATA / "upstream_fk.json").read_text())
    ik = ToolTipIK(None, library_size=1)
    assert len(reference["q"]) == 50
    for q, X_34 in zip(reference["q"], reference["X_34_rowmajor"]):
        ours = ik.fk_gripper(q).GetAsMatrix34().reshape(-1)
        np.testing.assert_allclose(ours, X_34, atol=1e-8)


def test_committed_urdf_is_current():
    assert (MODELS_DIR / "baxter" / "baxter.urdf").read_text() == baxter_urdf()


def test_joint_limits_velocity_and_effort_are_baxters():
    plant = make_robot_model(None)
    for name in RIGHT_ARM_JOINTS:
        joint = plant.GetJointByName(name)
        lo, hi, vel, effort = ARM_LIMITS[name.split("_")[1]]
        assert joint.position_lower_limits()[0] == pytest.approx(lo)
        assert joint.position_upper_limits()[0] == pytest.approx(hi)
        assert joint.velocity_upper_limits()[0] == pytest.approx(vel)
        assert plant.GetJointActuatorByName(f"{name}_motor").effort_limit() == pytest.approx(effort)


@pytest.mark.parametrize("length", [0.05, 0.125, 0.175, 0.6])
def test_tool_tip_frame_is_length_along_gripper_z(length):
    plant = make_robot_model(length)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, np.random.default_rng(0).uniform(-1, 1, 7))
    X_GT = plant.GetFrameByName("tool_tip").CalcPose(context, plant.GetFrameByName("right_gripper"))
    np.testing.assert_allclose(
        X_GT.GetAsMatrix4(),
        np.block(
            [[np.eye(3), np.array([[0], [0], [length]])], [np.zeros((1, 3)), np.ones((1, 1))]]
        ),
        atol=1e-12,
    )


def test_world_has_seven_actuated_arm_joints_and_a_free_box():
    builder = DiagramBuilder()
    world = add_world(builder, Scenario())
    plant = world.plant
    assert plant.num_actuated_dofs() == 7
    assert plant.num_positions() == 7 + 7  # arm + box (quaternion + position)
    assert plant.GetBodyByName("box").is_floating_base_body()
    context = plant.CreateDefaultContext()
    X_WB = plant.GetBodyByName("box").EvalPoseInWorld(context)
    np.testing.assert_allclose(X_WB.translation(), initial_box_pose(world.scenario).translation())
    assert goal_position(world.scenario)[1] > X_WB.translation()[1]


def test_grasp_offset_moves_the_true_tip():
    scenario = with_tool_length(Scenario(), 0.175)
    scenario.tool.grasp_offset_along = 0.01
    scenario.tool.grasp_offset_across = -0.005
    world = add_world(DiagramBuilder(), scenario)
    context = world.plant.CreateDefaultContext()
    p_GT = world.tip_frame.CalcPose(context, world.gripper_frame).translation()
    np.testing.assert_allclose(p_GT, [-0.005, 0.0, 0.185], atol=1e-12)
