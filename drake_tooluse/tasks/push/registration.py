"""Gymnasium registration of the push envs; imports nothing heavy (no pydrake)."""

import gymnasium as gym

MAX_EPISODE_STEPS = 100
ENV_IDS = {
    "drake_tooluse/ToolPush-v0": {"reward_type": "tool_and_box", "goal_extra": 0.0},
    "drake_tooluse/ToolPushBoxReward-v0": {"reward_type": "box", "goal_extra": 0.0},
    "drake_tooluse/ToolPushFar-v0": {"reward_type": "tool_and_box", "goal_extra": 0.10},
}


def register_envs() -> None:
    """Registers the three ids (idempotent); `gym.make` builds them lazily."""
    for env_id, kwargs in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                env_id,
                entry_point="drake_tooluse.tasks.push.env:ToolPushEnv",
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs=dict(kwargs),
            )
