"""Gymnasium registration of the pull env; imports nothing heavy (no pydrake)."""

import gymnasium as gym

MAX_EPISODE_STEPS = 100
ENV_IDS = {"drake_tooluse/ToolPull-v0": {}}


def register_envs() -> None:
    """Registers the id (idempotent); `gym.make` builds it lazily."""
    for env_id, kwargs in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                env_id,
                entry_point="drake_tooluse.tasks.pull.env:ToolPullEnv",
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs=dict(kwargs),
            )
