"""docs/ARCHITECTURE.md's "Add a task" as a test: a toy task defined in the tests
(`tests/tasks/toy_touch.py`, touch a point with the tool tip) plugs in with no edit outside its
own file — it registers, passes Gymnasium's and SB3's env checkers, and learning/ trains and
evaluates it, reporting the metric the task declares."""

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from drake_tooluse.learning.config import resolve_config
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.task_envs import check_env_kwargs, env_spaces, task_env_ids
from drake_tooluse.learning.train import train
from tests.tasks import toy_touch


@pytest.fixture(scope="module", autouse=True)
def registered():
    toy_touch.register()


def test_the_toy_task_registers_and_passes_the_env_checkers():
    assert toy_touch.ENV_ID in task_env_ids()
    assert env_spaces(toy_touch.ENV_ID, {}) == ([6], [3])
    with pytest.raises(ValueError, match="target_offset"):
        check_env_kwargs(toy_touch.ENV_ID, {"target_offset": [1, 0, 0]})
    env = gym.make(toy_touch.ENV_ID)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped)
    env.close()


def test_a_scripted_reach_ends_the_episode_through_the_simulator_monitor():
    env = gym.make(toy_touch.ENV_ID)
    obs, info = env.reset(seed=0)
    start = info["distance"]
    for _ in range(20):
        target, tip = obs[:3], obs[3:]
        obs, reward, terminated, truncated, info = env.step((target - tip) / 0.02)
        assert reward == pytest.approx(-info["distance"])
        if terminated or truncated:
            break
    assert terminated and info["is_success"] and info["distance"] < start
    env.close()


def test_learning_trains_and_evaluates_the_toy_task(tmp_path):
    overrides = {"env_kwargs": {}, **toy_touch.TINY_PPO}
    config = resolve_config(toy_touch.ENV_ID, "ppo", 256, 1, 0, overrides=overrides)
    train(config, tmp_path / "run", progress_bar=False)
    result = evaluate(tmp_path / "run" / "final", episodes=2, seed=0)
    assert set(result.metrics) == {
        "final_distance_mean_m",
        "final_distance_median_m",
        "final_distance_std_m",
    }
    assert 0 <= result.metrics["final_distance_mean_m"] < 1.0
    assert result.episodes == 2 and 1 <= result.episode_length_mean <= 20


def test_a_refused_reset_leaves_the_env_usable():
    """A refused seed, then a valid reset: the env steps (Gymnasium 1.4's passive checker
    broke every later step: docs/UPSTREAM.md, whose reproduction runs here too)."""
    import re
    from pathlib import Path

    import gymnasium as gym
    import numpy as np

    env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position")
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=-1)
    env.reset(seed=0)
    assert env.step(np.zeros(3, np.float32))[4]["sim_error"] is False
    env.close()
    page = Path(__file__).resolve().parents[2] / "docs" / "UPSTREAM.md"
    (reproduction,) = re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
    exec(compile(reproduction, str(page), "exec"), {"__name__": "upstream_md"})
