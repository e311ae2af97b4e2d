"""An action moves the tip target from the arm state the policy observed: the IK solves in the
plant's own update batch, so it reads the state at the start of the plant's step, not the
state one plant step (20 ms) later, which a discrete update at the same time would read."""

import numpy as np
import pytest

from drake_tooluse.tasks.push.env import ToolPushEnv


def test_a_zero_action_holds_the_target_at_the_observed_tip():
    """The target a zero action commands is the tip at the observed state, on the robot
    model, with the arm moving."""
    env = ToolPushEnv(action_mode="position", observation_mode="tip")
    try:
        env.reset(seed=0)
        for _ in range(3):  # the arm under way
            env.step(np.array([1.0, 0.0, 0.0]))
        world = env.world
        q = world.plant.GetPositions(env._plant_context, world.baxter)
        observed_tip = env.control.ik.fk(q).translation()
        env.step(np.zeros(3))
        gap = np.linalg.norm(env.commanded_tip_pose().translation() - observed_tip)
        assert gap < 1e-4  # the IK's tolerance; a plant step later the tip is mm further
    finally:
        env.close()


def first_motion(delay: float) -> float:
    """When (s) the arm first moves after an action fixed at reset, plant step by plant step."""
    kwargs = {} if delay == 0 else {"actuation_delay_range": [delay, delay + 1e-3]}
    env = ToolPushEnv(action_mode="position", **kwargs)
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
def test_the_actuation_delay_is_exact(delay):
    """The IK solving in the plant's batch changes what it reads, not when the arm answers:
    the delay system samples its command one tick sooner, so it holds it one update more."""
    assert first_motion(delay) == pytest.approx(first_motion(0.0) + delay)
