"""Tool-tip control: the differential IK's log lines."""

import logging

import gymnasium as gym
import numpy as np

import drake_tooluse  # noqa: F401  (registers the envs)


def test_differential_ik_status_lines_are_dropped_and_other_drake_logs_pass(caplog):
    """Driving the target out of reach makes the differential IK log its "no solution" switch;
    that line is filtered, anything else on the `drake` logger still arrives."""
    env = gym.make("drake_tooluse/ToolPush-v0", action_mode="position", ik_mode="differential")
    env.reset(seed=0)
    with caplog.at_level(logging.WARNING, logger="drake"):
        for _ in range(60):  # far forward, right and down: beyond the arm's reach
            *_, terminated, truncated, _ = env.step(np.array([1.0, -1.0, -1.0]))
            if terminated or truncated:
                break
        logging.getLogger("drake").warning("another drake warning")
    messages = [r.getMessage() for r in caplog.records if r.name == "drake"]
    assert messages == ["another drake warning"]
