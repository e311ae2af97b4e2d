"""drake-tooluse: a Baxter robot using a straight tool of any length, in Drake.

Importing the package registers the Gymnasium env ids (`drake_tooluse/ToolPush-v0`, …); it
imports no Drake. The layers, in the order they import each other, are described in
docs/ARCHITECTURE.md.
"""

from drake_tooluse.envs.registration import ENV_IDS, register_envs

__version__ = "0.1.0"

register_envs()

__all__ = ["ENV_IDS", "register_envs", "__version__"]
