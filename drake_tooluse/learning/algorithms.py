"""The algorithms' names, without torch: the command line checks `--algo` before it imports
`learning.config`, which maps them to their classes."""

ALGOS = ("ppo", "a2c", "ddpg", "trpo")
