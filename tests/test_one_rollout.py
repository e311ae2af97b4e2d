"""One rollout per task: the Gym env and the deployed run (the push task's policy diagram, policy
`LeafSystem` → IK → plant, `tasks.deploy`) are built by the task's one builder (its env
class's `add_task`),
step on the same clock and are judged the same, so the same policy, seed and world give the
same trajectory in both, bit for bit, and the same physical-sanity flags."""

import dataclasses as dc

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.seeding import np_random

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.paths import PULL_POLICY, PULL_SCENARIO, TRANSFER_POLICY
from drake_tooluse.tasks.deploy import build_policy_diagram, run_policy
from drake_tooluse.tasks.pull.env import with_hook
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import Scenario, load_scenario

STEPS = 60
HOOK = (0.25, 0.05, 90.0)


def _v1(policy, env_id: str, **kwargs):
    """`policy` as a policy of `env_id` (a -v1 id) with `kwargs` over its env kwargs."""
    env_kwargs = {**policy.meta.env_kwargs, **kwargs}
    policy.meta = dc.replace(policy.meta, env_id=env_id, env_kwargs=env_kwargs)
    return policy


def _env_path(env_id: str, kwargs: dict, policy, seed: int, tip) -> tuple[np.ndarray, list]:
    """The tool point's path (W, m) over STEPS steps of the policy in the env, and each step's
    physical-sanity flags."""
    env = gym.make(env_id, **kwargs)
    inner = env.unwrapped
    try:
        observation, _ = env.reset(seed=seed)
        path, flags = [tip(inner)], []
        for _ in range(STEPS):
            observation, *_, info = env.step(policy.act(observation))
            path.append(tip(inner))
            flags.append({lim.flag: info[lim.flag] for lim in inner.PHYSICAL_LIMITS})
        return np.array(path), flags
    finally:
        env.close()


def _tool_tip(env) -> np.ndarray:
    """The true tool's tip frame in W (m): what a deployed run records as its tool path."""
    return env.world.tip_frame.CalcPoseInWorld(env._plant_context).translation()


@pytest.mark.parametrize("randomize", [False, True], ids=["nominal", "randomized"])
def test_the_push_env_and_the_policy_diagram_give_the_same_trajectory(randomize):
    policy = _v1(load_policy(TRANSFER_POLICY), "drake_tooluse/ToolPush-v1", randomize=randomize)
    seed = 3
    scenario = Scenario()
    if randomize:  # the world the env's reset(seed) draws
        scenario = apply_draw(scenario, draw_randomization(scenario, np_random(seed)[0]))
    built = build_policy_diagram(scenario, policy)
    run = run_policy(built, max_steps=STEPS)
    env_path, env_flags = _env_path(
        policy.meta.env_id, policy.meta.env_kwargs, policy, seed, _tool_tip
    )
    assert run.steps == STEPS and not run.sim_error
    np.testing.assert_array_equal(run.tool_path, env_path)
    assert run.flagged == {flag for step in env_flags for flag, on in step.items() if on}


def test_the_pull_env_and_the_policy_diagram_give_the_same_trajectory():
    policy = _v1(load_policy(PULL_POLICY), "drake_tooluse/ToolPull-v1", randomize=False)
    kwargs = {**policy.meta.env_kwargs, "hook": HOOK}
    scenario = with_hook(load_scenario(PULL_SCENARIO), HOOK)
    run = run_policy(build_policy_diagram(scenario, policy), max_steps=STEPS)
    env_path, env_flags = _env_path(policy.meta.env_id, kwargs, policy, 0, _tool_tip)
    assert run.steps == STEPS and not run.sim_error
    np.testing.assert_array_equal(run.tool_path, env_path)
    assert run.flagged == {flag for step in env_flags for flag, on in step.items() if on}
