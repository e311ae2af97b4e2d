"""Physical sanity under extreme actions: the largest penetration of the tool and the gripper into
the table, box speed and arm joint speed over N steps of the push env, as its `info` reports them
(`drake_tooluse.tasks.sanity`), and how many steps were past each limit.

    python benchmarks/env_sanity.py [--steps 2000] [--actions extreme|uniform] [--seed 0]
        [--env-id drake_tooluse/ToolPush-v1] [--env-kwargs '{"action_mode": "pose"}'] [--json]

`extreme` actions are ±1 in every component, drawn at random each step (bang-bang: the largest
commands a policy can give); `uniform` are uniform in [-1, 1]. Episodes run to their step limit
and reset. Prints a Markdown table (or JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import drake_tooluse  # noqa: E402,F401
from drake_tooluse.cli.common import run_script


def measure(env_id: str, env_kwargs: dict, steps: int, actions: str, seed: int) -> dict:
    env = gym.make(env_id, **env_kwargs)
    limits = type(env.unwrapped).PHYSICAL_LIMITS
    rng = np.random.default_rng(seed)
    n = env.action_space.shape[0]
    peak = {lim.info_key: 0.0 for lim in limits}
    flagged = {lim.flag: 0 for lim in limits}
    sim_errors = episodes = 0
    env.reset(seed=seed)
    start = time.perf_counter()
    for _ in range(steps):
        if actions == "extreme":
            a = rng.choice([-1.0, 1.0], size=n)
        else:
            a = rng.uniform(-1.0, 1.0, size=n)
        _, _, terminated, truncated, info = env.step(a.astype(np.float32))
        for lim in limits:
            peak[lim.info_key] = max(peak[lim.info_key], float(info[lim.info_key]))
            flagged[lim.flag] += bool(info[lim.flag])
        sim_errors += bool(info["sim_error"])
        if terminated or truncated:
            episodes += 1
            env.reset(seed=seed + episodes)
    wall = time.perf_counter() - start
    env.close()
    return {
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "steps": steps,
        "actions": actions,
        "seed": seed,
        "max": peak,
        "steps_past_limit": flagged,
        "limits": {lim.flag: [lim.info_key, lim.limit, lim.unit] for lim in limits},
        "sim_errors": sim_errors,
        "wall_s": round(wall, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--actions", choices=("extreme", "uniform"), default="extreme")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--env-id", default="drake_tooluse/ToolPush-v1")
    parser.add_argument("--env-kwargs", type=json.loads, default={})
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    r = measure(args.env_id, args.env_kwargs, args.steps, args.actions, args.seed)
    if args.json:
        print(json.dumps(r, indent=1))
        return
    print(
        f"{r['env_id']} {json.dumps(r['env_kwargs'])}: {r['steps']} steps of {r['actions']} "
        f"actions, seed {r['seed']}, {r['sim_errors']} sim errors, {r['wall_s']} s\n"
    )
    print("| figure | max | limit | steps past it |")
    print("| --- | --- | --- | --- |")
    for flag, (key, limit, unit) in r["limits"].items():
        print(
            f"| {key} | {r['max'][key]:.4g} {unit} | {limit:g} {unit} | "
            f"{r['steps_past_limit'][flag]} |"
        )


if __name__ == "__main__":
    sys.exit(run_script(main))
