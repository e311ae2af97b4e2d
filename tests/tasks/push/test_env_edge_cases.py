"""The env's edge cases are errors naming the argument, and a closed env
lets its diagram go."""

import gc

import gymnasium as gym
import numpy as np
import pytest

import drake_tooluse  # noqa: F401  (registers the ids)
from drake_tooluse.tasks.push.env import ToolPushEnv


@pytest.fixture(scope="module")
def env():
    env = ToolPushEnv(action_mode="position")
    yield env
    env.close()


def test_a_step_before_reset_is_refused():
    env = ToolPushEnv(action_mode="position")
    with pytest.raises(gym.error.ResetNeeded, match=r"call reset\(\) before step\(\)"):
        env.step(np.zeros(3))
    env.close()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"include_tool_length": "no"}, r"include_tool_length='no' must be True or False"),
        ({"randomize": "yes"}, r"randomize='yes' must be True or False"),
        ({"randomize": 1}, r"randomize=1 must be True or False"),
        ({"tool_length": float("nan")}, r"tool_length=nan must be a finite number in the allowed"),
        ({"scenario": 5}, r"scenario=5 must be a Scenario, a YAML file name or None"),
        ({"meshcat": 3}, r"meshcat=3 must be a pydrake.geometry.Meshcat .* or None"),
        ({"meshcat": "localhost:7000"}, r"meshcat='localhost:7000' must be a pydrake"),
        ({"colour": "red"}, r"unknown argument\(s\) \['colour'\]"),
    ],
)
def test_bad_kwargs_name_the_argument(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make("drake_tooluse/ToolPush-v1", **kwargs)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"bound_joint_speed": False},
            r"^bound_joint_speed=False is not an option of the push envs \(joint targets always",
        ),
        ({"end_at_success": True}, r"^end_at_success=True is not .* runs to its step limit\)"),
        ({"continuous_quaternion": 1}, r"^continuous_quaternion=1 is not an option"),
        ({"target_from_observed_state": "yes"}, r"^target_from_observed_state='yes' is not"),
        ({"ik_mode": "full"}, r"^ik_mode='full' is not .*the exact tool-tip IK always runs"),
        ({"action_mode": "paper"}, r"^action_mode='paper' is the earlier version's name of"),
        ({"observation_mode": "paper"}, r"^observation_mode='paper' is .* of 'gripper_joints'"),
    ],
)
def test_the_earlier_versions_names_are_refused_naming_the_tag_that_runs_them(kwargs, message):
    with pytest.raises(ValueError, match=message) as error:
        gym.make("drake_tooluse/ToolPush-v1", **kwargs)
    assert str(error.value).endswith("git tag figures-v0") and "\n" not in str(error.value)


@pytest.mark.parametrize(
    "action, message",
    [
        (np.array([0.1, 0.0, 0.0]) * 1j, r"is complex; actions are real numbers"),
        (np.array(["a", "b", "c"]), r"<U1 \(not numbers\)"),
        ([0.0, float("nan"), 0.0], r"NaN or infinite"),
        ([0.0, 0.0], r"action has 2 values; action_mode='position' needs 3"),
    ],
)
def test_bad_actions_are_refused(env, action, message):
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)


@pytest.mark.parametrize("seed", [2**64, -1, 2**32, 1.5, True])
def test_seeds_outside_32_bits_are_refused(env, seed):
    with pytest.raises(ValueError, match=r"seed=.*(outside the allowed range|must be an integer)"):
        env.reset(seed=seed)
    obs, _ = env.reset(seed=2**32 - 1)  # the largest one works
    assert np.all(np.isfinite(obs))


def _rss_mb() -> float:
    import os

    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_rebuilding_envs_does_not_grow_memory():
    """pydrake keeps a diagram with Python systems alive forever unless close() releases it:
    2-3 MB per rebuild before (50+ MB over these 20)."""

    def cycle():
        env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position")
        env.reset(seed=0)
        env.step(np.zeros(3))
        env.close()

    for _ in range(3):
        cycle()
    gc.collect()
    start = _rss_mb()
    for _ in range(20):
        cycle()
    gc.collect()
    assert _rss_mb() - start < 10.0


def test_a_closed_env_says_so():
    env = ToolPushEnv(action_mode="position")
    env.reset(seed=0)
    env.close()
    env.close()  # twice is fine
    with pytest.raises(gym.error.Error, match="this env is closed"):
        env.reset(seed=0)
