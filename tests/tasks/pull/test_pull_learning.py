"""learning/ trains and evaluates the pull env through the registry (no import of the task),
reporting the metrics the task declares. A few hundred steps: the plumbing, not a policy."""

import pytest

from drake_tooluse.learning.config import resolve_config
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.train import train
from tests.tasks.toy_touch import TINY_PPO

ENV_ID = "drake_tooluse/ToolPull-v1"


def test_the_pull_entry_of_the_hyperparameters_resolves():
    config = resolve_config(ENV_ID, "ppo", 1000, 1, 0)
    assert config.hyperparams["gamma"] == 0.99
    assert config.hyperparams["env_kwargs"] == {"randomize": True}


@pytest.mark.slow
def test_learning_trains_and_evaluates_the_pull_task(tmp_path):
    config = resolve_config(ENV_ID, "ppo", 256, 1, 0, overrides={**TINY_PPO})
    train(config, tmp_path / "run", progress_bar=False)
    result = evaluate(tmp_path / "run" / "final", episodes=2, seed=0)
    assert set(result.metrics) >= {
        "final_object_to_goal_mean_m",
        "object_travel_mean_m",
        "tool_touched_rate",
        "gripper_touched_rate",
    }
    assert result.episodes == 2 and result.episode_length_mean == 100
