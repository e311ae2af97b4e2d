"""`target_from_observed_state`: an action moves the tip target from the arm state the policy
observed. Without it the IK reads the plant's state one plant step later (the plant's step, an
unrestricted update, runs before the IK's discrete update at the same time), so a target
"from where the tip is" is from where it is 20 ms after the observation."""

import numpy as np
import pytest

from drake_tooluse.tasks.push.env import ToolPushEnv


def commanded_vs_observed(observed_state: bool) -> float:
    """How far (m) the target a zero action commands lies from the tip at the observed
    state, on the robot model, with the arm moving."""
    env = ToolPushEnv(
        action_mode="position", observation_mode="tip", target_from_observed_state=observed_state
    )
    try:
        env.reset(seed=0)
        for _ in range(3):  # the arm under way
            env.step(np.array([1.0, 0.0, 0.0]))
        world = env.world
        q = world.plant.GetPositions(env._plant_context, world.baxter)
        observed_tip = env.control.ik.fk(q).translation()
        env.step(np.zeros(3))
        return float(np.linalg.norm(env.commanded_tip_pose().translation() - observed_tip))
    finally:
        env.close()


@pytest.mark.parametrize("observed_state", [True, False])
def test_a_zero_action_holds_the_target_at_the_observed_tip_only_with_the_option(observed_state):
    gap = commanded_vs_observed(observed_state)
    if observed_state:
        assert gap < 1e-4  # the IK's tolerance
    else:
        assert gap > 1e-3  # the tip moved on for a plant step
