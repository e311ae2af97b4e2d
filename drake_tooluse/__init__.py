"""drake-tooluse: a Baxter robot using a straight tool of any length, in Drake."""

from drake_tooluse.registration import ENV_IDS, register_envs

__version__ = "0.1.0"

register_envs()

__all__ = ["ENV_IDS", "register_envs", "__version__"]
