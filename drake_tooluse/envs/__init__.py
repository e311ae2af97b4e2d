"""Gymnasium envs of the push task on `pydrake.gym.DrakeGymEnv` (registered on
`import drake_tooluse`), and a scripted reference push.

`ToolPushEnv` lives in `envs.push_env`; importing this package imports no Drake, so that the
registration stays cheap.
"""

from drake_tooluse.envs.registration import ENV_IDS, MAX_EPISODE_STEPS, register_envs

__all__ = ["ENV_IDS", "MAX_EPISODE_STEPS", "register_envs"]
