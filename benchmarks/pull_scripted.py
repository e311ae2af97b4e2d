"""The scripted pull (`tasks.pull.scripted.ScriptedPull`) on drake_tooluse/ToolPull-v1: its
success rate and final cube–goal distance over N seeded episodes (seeds 0 … N−1), each with
a hook drawn from HookTool's ranges and a randomized start, judged at the step limit.

    python benchmarks/pull_scripted.py [--episodes 20] [--seed 0]

Prints a Markdown table, and each failed episode's hook.
"""

import argparse
import sys
import time

import gymnasium as gym
import numpy as np

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.cli.common import run_script
from drake_tooluse.tasks.pull.scripted import ScriptedPull


def run_episode(env, seed: int) -> dict:
    """One scripted episode from `reset(seed=seed)` to the step limit; its last `info`."""
    observation, info = env.reset(seed=seed)
    policy = ScriptedPull(env.unwrapped.scenario.table.top_z)
    terminated = truncated = False
    while not (terminated or truncated):
        observation, _, terminated, truncated, info = env.step(policy(observation))
    return info


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=20, help="seeded episodes")
    ap.add_argument("--seed", type=int, default=0, help="the first episode's seed")
    args = ap.parse_args()
    if args.episodes < 1:
        ap.error(f"--episodes={args.episodes} must be at least 1")
    env = gym.make("drake_tooluse/ToolPull-v1")
    start = time.perf_counter()
    infos = [run_episode(env, args.seed + i) for i in range(args.episodes)]
    seconds = time.perf_counter() - start
    env.close()
    success = np.array([i["is_success"] for i in infos])
    final = np.array([i["object_to_goal"] for i in infos])
    travel = np.array([i["object_travel"] for i in infos])
    print(f"ScriptedPull on ToolPull-v1, seeds {args.seed}…{args.seed + args.episodes - 1}\n")
    print("| episodes | success rate | final cube–goal mean (m) | median (m) | travel mean (m) |")
    print("| --- | --- | --- | --- | --- |")
    print(
        f"| {args.episodes} | {success.mean():.2f} | {final.mean():.3f} | "
        f"{np.median(final):.3f} | {travel.mean():.3f} |"
    )
    for seed, info in enumerate(infos, args.seed):
        if not info["is_success"]:
            handle, hook, angle = info["hook"]
            print(
                f"failed: seed {seed}, hook handle {handle:.3f} m, hook {hook:.3f} m, "
                f"angle {angle:.1f}°: cube {info['object_to_goal']:.3f} m from the goal"
            )
    print(f"\n({seconds:.0f} s)")


if __name__ == "__main__":
    sys.exit(run_script(main))
