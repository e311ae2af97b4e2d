"""The envs learning trains and evaluates, found through Gymnasium's registry.

Any id registered in the project's namespace whose class follows the task contract
(`tasks.contract.TaskEnv`) can be trained, evaluated and swept; its class checks its keyword
arguments and gives its spaces without being built. learning/ imports no task: adding a task
is a package of its own that registers its ids.
"""

from __future__ import annotations

from drake_tooluse.tasks.contract import check_env_id, env_class, task_env_ids

__all__ = ["check_env_id", "env_class", "task_env_ids"]


def check_env_kwargs(env_id: str, kwargs, name: str = "env kwargs") -> dict:
    """`kwargs` for `env_id`'s class, checked without building the env (see `TaskEnv`)."""
    return env_class(env_id).check_kwargs(kwargs, name)


def env_spaces(env_id: str, kwargs) -> tuple[list, list]:
    """(observation shape, action shape) of the env `env_id` makes with `kwargs`."""
    return env_class(env_id).spaces(kwargs)


def episode_metrics(env_id: str):
    """The metrics an evaluation reports of each of `env_id`'s episodes (`EpisodeMetric`)."""
    return env_class(env_id).EPISODE_METRICS
