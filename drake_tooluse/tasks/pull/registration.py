"""Gymnasium registration of the pull env; imports nothing heavy (no pydrake)."""

from drake_tooluse.tasks.contract import register_task_envs

MAX_EPISODE_STEPS = 100
ENV_IDS = {"drake_tooluse/ToolPull-v0": {}}


def register_envs() -> None:
    """Registers the id (idempotent); `gym.make` builds it lazily."""
    register_task_envs(ENV_IDS, "drake_tooluse.tasks.pull.env:ToolPullEnv", MAX_EPISODE_STEPS)
