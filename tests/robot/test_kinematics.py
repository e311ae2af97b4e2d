"""The arm chain read from the robot model: its compiled pose and Jacobian are Drake's."""

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable

from drake_tooluse.robot.baxter_model import Q_LOWER, Q_UPPER
from drake_tooluse.robot.kinematics import ArmChain
from drake_tooluse.robot.model import TIP_FRAME, make_robot_model


@pytest.mark.parametrize("length, grasp", [(None, (0, 0)), (0.175, (0, 0)), (0.45, (0.004, -0.01))])
def test_chain_pose_and_jacobian_are_drakes(length, grasp):
    plant = make_robot_model(length, grasp_offset=grasp)
    context = plant.CreateDefaultContext()
    tip = plant.GetFrameByName(TIP_FRAME)
    chain = ArmChain.from_plant(plant, tip)
    world = plant.world_frame()
    for q in np.random.default_rng(3).uniform(Q_LOWER, Q_UPPER, size=(50, 7)):
        plant.SetPositions(context, q)
        X = tip.CalcPoseInWorld(context)
        R, p = chain.pose(q)
        np.testing.assert_allclose(R, X.rotation().matrix(), atol=1e-12)
        np.testing.assert_allclose(p, X.translation(), atol=1e-12)
        J = plant.CalcJacobianSpatialVelocity(
            context, JacobianWrtVariable.kQDot, tip, np.zeros(3), world, world
        )  # rows [ω; v]
        np.testing.assert_allclose(chain.jacobian(q), np.vstack([J[3:], J[:3]]), atol=1e-12)


def test_a_plant_with_other_positions_is_refused():
    from pydrake.multibody.plant import MultibodyPlant

    from drake_tooluse.robot.model import add_baxter, add_tip_at_gripper

    plant = MultibodyPlant(0.0)
    baxter = add_baxter(plant, np.zeros(7))
    add_tip_at_gripper(plant, baxter)
    plant.AddRigidBody("free_body", plant.AddModelInstance("extra"))  # a floating body: 7 more q
    plant.Finalize()
    with pytest.raises(ValueError, match="seven right-arm joints"):
        ArmChain.from_plant(plant, plant.GetFrameByName(TIP_FRAME))
