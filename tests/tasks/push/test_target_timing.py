"""`target_from_observed_state`: an action moves the tip target from the arm state the policy
observed. Without it the IK reads the plant's state one plant step later (the plant's step, an
unrestricted update, runs before the IK's discrete update at the same time), so a target
"from where the tip is" is from where it is 20 ms after the observation."""

import numpy as np
import pytest

from drake_tooluse.tasks.push.legacy import ToolPushEnvV0


def commanded_vs_observed(observed_state: bool) -> float:
    """How far (m) the target a zero action commands lies from the tip at the observed
    state, on the robot model, with the arm moving."""
    env = ToolPushEnvV0(
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


def first_motion(observed_state: bool, delay: float) -> float:
    """When (s) the arm first moves after an action fixed at reset, plant step by plant step."""
    kwargs = {} if delay == 0 else {"actuation_delay_range": [delay, delay + 1e-3]}
    env = ToolPushEnvV0(action_mode="position", target_from_observed_state=observed_state, **kwargs)
    try:
        env.reset(seed=0)
        context = env.simulator.get_mutable_context()
        env.action_port.FixValue(context, np.array([0.0, 1.0, 0.0]))
        h = env.world.plant.time_step()
        for k in range(1, 20):
            env.simulator.AdvanceTo(k * h)
            v = env.world.plant.GetVelocities(env._plant_context, env.world.baxter)
            if np.abs(v).max() > 1e-6:
                return k * h
        raise AssertionError("the arm never moved")
    finally:
        env.close()


@pytest.mark.parametrize("delay", [0.02, 0.04])
def test_the_actuation_delay_is_the_same_either_way(delay):
    """The IK solving in the plant's batch changes what it reads, not when the arm answers:
    the delay system samples its command one tick sooner, so it holds it one update more."""
    prompt = first_motion(True, 0.0)
    assert first_motion(False, 0.0) == prompt
    assert first_motion(True, delay) == pytest.approx(prompt + delay)
    assert first_motion(False, delay) == pytest.approx(prompt + delay)
