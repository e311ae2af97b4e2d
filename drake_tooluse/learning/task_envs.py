"""The envs learning trains and evaluates, found through Gymnasium's registry.

Any id registered in the project's namespace whose class follows the task contract
(`tasks.contract.TaskEnv`) can be trained, evaluated and swept; its class checks its keyword
arguments and gives its spaces without being built. learning/ imports no task: adding a task
is a package of its own that registers its ids.
"""

from __future__ import annotations

import gymnasium as gym
from gymnasium.envs.registration import load_env_creator

from drake_tooluse.tasks.contract import ENV_NAMESPACE, TaskEnv


def task_env_ids() -> list[str]:
    """The registered ids of the project's namespace (registered on `import drake_tooluse`)."""
    return [i for i in gym.registry if i.startswith(ENV_NAMESPACE + "/")]


def check_env_id(env_id) -> str:
    if not isinstance(env_id, str) or env_id not in task_env_ids():
        raise ValueError(f"unknown env {env_id!r}; choose one of {task_env_ids()}")
    return env_id


def env_class(env_id: str) -> type[TaskEnv]:
    """The class a registered id makes (its module imported on first use)."""
    entry_point = gym.spec(check_env_id(env_id)).entry_point
    cls = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
    if not (isinstance(cls, type) and issubclass(cls, TaskEnv)):
        raise ValueError(f"env {env_id!r} ({entry_point!r}) does not follow the task contract")
    return cls


def check_env_kwargs(env_id: str, kwargs, name: str = "env kwargs") -> dict:
    """`kwargs` for `env_id`'s class, checked without building the env (see `TaskEnv`)."""
    return env_class(env_id).check_kwargs(kwargs, name)


def env_spaces(env_id: str, kwargs) -> tuple[list, list]:
    """(observation shape, action shape) of the env `env_id` makes with `kwargs`."""
    return env_class(env_id).spaces(kwargs)


def episode_metrics(env_id: str):
    """The metrics an evaluation reports of each of `env_id`'s episodes (`EpisodeMetric`)."""
    return env_class(env_id).EPISODE_METRICS
