"""drake-tooluse: a Baxter robot using a tool, in Drake.

Importing the package registers every task's Gymnasium env ids (`drake_tooluse/ToolPush-v1`,
`drake_tooluse/ToolPull-v1`, …); it imports no Drake. The layers, in the order they import each
other, are described in docs/ARCHITECTURE.md.
"""

from drake_tooluse.tasks.pull.registration import ENV_IDS as PULL_ENV_IDS
from drake_tooluse.tasks.pull.registration import register_envs as register_pull_envs
from drake_tooluse.tasks.push.registration import ENV_IDS as PUSH_ENV_IDS
from drake_tooluse.tasks.push.registration import register_envs as register_push_envs

__version__ = "0.1.0"

# Every task's ids and its registration (a new task adds its own here).
ENV_IDS = {**PUSH_ENV_IDS, **PULL_ENV_IDS}


def register_envs() -> None:
    """Registers every task's env ids (idempotent); `gym.make` builds them lazily."""
    register_push_envs()
    register_pull_envs()


register_envs()

__all__ = ["ENV_IDS", "register_envs", "__version__"]
