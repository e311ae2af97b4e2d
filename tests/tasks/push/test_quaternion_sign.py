"""The paper action's quaternion change is added to the tip quaternion in the initial one's
hemisphere, so the same action turns the tip the same way at every step. Drake's sign, by which
the target would otherwise be taken, jumps at this scene's home orientation (w ≈ 0)."""

import numpy as np
from pydrake.math import RotationMatrix

from drake_tooluse.robot.kinematics import fk_jacobian
from drake_tooluse.systems.tip_target import MAX_QUATERNION_STEP
from drake_tooluse.tasks.push.env import ToolPushEnv

STEPS = 25


def tip_quaternion(env, observation) -> np.ndarray:
    """The tip's orientation at the observation's joint angles (the robot model's forward
    kinematics), with Drake's sign."""
    chain = env.target_system._chain
    R, p, J = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
    fk_jacobian(chain.fixed, chain.axes, observation[16:23].astype(float), R, p, J)
    return RotationMatrix.MakeUnchecked(R).ToQuaternion().wxyz()


def target_quaternions(hold: bool) -> tuple[np.ndarray, list, list, list]:
    """The initial target's quaternion, the tip's quaternions with Drake's sign, the targets'
    quaternions and the tip's orientation error (rad) over STEPS steps of a push. The position
    moves towards the box; the quaternion part is zero, or (`hold`) the change back to the
    initial orientation."""
    env = ToolPushEnv(action_mode="position_quaternion")
    try:
        observation, _ = env.reset(seed=3)
        held = env.target_system.initial_quaternion
        context = env.target_system.GetMyContextFromRoot(env.simulator.get_context())
        drakes, targets, errors = [], [], []
        for _ in range(STEPS):
            quaternion = tip_quaternion(env, observation)
            drakes.append(quaternion)
            if hold:
                signed = quaternion if quaternion.dot(held) >= 0 else -quaternion
                change = np.clip((held - signed) / MAX_QUATERNION_STEP, -1, 1)
            else:
                change = np.zeros(4)
            observation, *_ = env.step(np.concatenate([[0.5, 0.3, -0.2], change]))
            targets.append(env.target_system.GetOutputPort("tip_pose_desired").Eval(context)[3:])
            errors.append(2 * np.arccos(min(1.0, abs(tip_quaternion(env, observation).dot(held)))))
        return held, drakes, targets, errors
    finally:
        env.close()


def test_drakes_sign_jumps_where_the_targets_stay_in_the_initial_hemisphere():
    held, drakes, targets, _ = target_quaternions(hold=False)
    assert abs(held[0]) < 1e-6  # w ≈ 0
    assert min(q.dot(held) for q in drakes) < -0.9  # Drake's opposite sign at some step
    assert min(t.dot(held) for t in targets) > 0.9


def test_the_change_back_to_the_initial_orientation_holds_it():
    _, _, _, errors = target_quaternions(hold=True)
    assert max(errors) < np.radians(2.0)
