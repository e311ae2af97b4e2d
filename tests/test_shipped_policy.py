"""The shipped policy (models/policies/ppo_toolpush) loads, acts, and reproduces its metrics."""

import json
from pathlib import Path

import numpy as np
import pytest

from drake_tooluse.train import evaluate, load_policy

SHIPPED = Path(__file__).resolve().parent.parent / "models" / "policies" / "ppo_toolpush"
METRICS = json.loads((SHIPPED / "metrics.json").read_text())["evaluation"]


def test_shipped_policy_loads_and_meets_the_goals_it_claims():
    policy = load_policy(SHIPPED)
    assert policy.meta.env_id == "drake_tooluse/ToolPush-v0"
    assert policy.meta.env_kwargs["ik_mode"] == "full"  # InverseKinematics in the loop
    action = policy.act(np.zeros(30, np.float32))
    assert action.shape == (3,) and np.all(np.abs(action) <= 1.0)
    assert METRICS["episodes"] == 100
    assert METRICS["final_box_to_goal_mean_m"] <= 0.04 and METRICS["success_rate"] >= 0.8


def test_evaluate_reproduces_the_first_shipped_episodes():
    result = evaluate(SHIPPED, episodes=3, seed=METRICS["seed"])
    for ours, shipped in zip(result.per_episode, METRICS["per_episode"][:3]):
        assert ours["seed"] == shipped["seed"] and ours["success"] == shipped["success"]
        assert ours["final_box_to_goal_m"] == pytest.approx(shipped["final_box_to_goal_m"],
                                                            abs=1e-6)


@pytest.mark.slow
def test_evaluate_reproduces_all_shipped_metrics():
    result = evaluate(SHIPPED, episodes=METRICS["episodes"], seed=METRICS["seed"])
    assert result.final_box_to_goal_mean_m == pytest.approx(METRICS["final_box_to_goal_mean_m"],
                                                            abs=1e-6)
    assert result.success_rate == METRICS["success_rate"]
