"""Gymnasium registration of the push envs; imports nothing heavy (no pydrake)."""

from drake_tooluse.tasks.contract import register_task_envs

MAX_EPISODE_STEPS = 100
ENV_IDS = {
    "drake_tooluse/ToolPush-v0": {"reward_type": "tool_and_box", "goal_extra": 0.0},
    "drake_tooluse/ToolPushBoxReward-v0": {"reward_type": "box", "goal_extra": 0.0},
    "drake_tooluse/ToolPushFar-v0": {"reward_type": "tool_and_box", "goal_extra": 0.10},
}


def register_envs() -> None:
    """Registers the three ids (idempotent); `gym.make` builds them lazily."""
    register_task_envs(ENV_IDS, "drake_tooluse.tasks.push.env:ToolPushEnv", MAX_EPISODE_STEPS)
