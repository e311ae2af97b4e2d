"""Is the fast env still the same task? The plant time step behind the env's speed: the
scripted push (randomized starts) at 5, 10 and 20 ms, each episode run to its step limit and
judged where it ends, with the step of its first success.

(A first check compared the retired first-order IK mode with the exact IK; with one IK in the
loop it has nothing left to compare.)

    python benchmarks/env_fidelity.py [--episodes 20] [--out FILE | --update-docs]

Prints Markdown tables and writes them as JSON to a new runs/env_fidelity-<time>/env_fidelity.json
(or --out; `--update-docs`: docs/results/env_fidelity.json, which docs/BENCHMARKS.md quotes).
"""

import argparse
import copy
import dataclasses as dc
import platform
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import drake_tooluse  # noqa: F401
from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.files import atomic_write_json
from drake_tooluse.tasks.push.scripted import ScriptedPush
from drake_tooluse.world.scenario import Scenario

OUTPUT = BenchmarkOutput(Path(__file__))


def time_steps(episodes: int) -> list:
    out = []
    for dt in (0.005, 0.01, 0.02):
        base = Scenario()
        plant = copy.copy(base.plant)  # Drake's MultibodyPlantConfig: not a dataclass
        plant.time_step = dt
        scenario = dc.replace(base, plant=plant)
        env = gym.make(
            "drake_tooluse/ToolPush-v1", action_mode="position", scenario=scenario, randomize=True
        )
        policy = ScriptedPush(scenario.table.top_z)
        rows = []
        for ep in range(episodes):
            obs, _ = env.reset(seed=ep)
            policy.reset()
            first = np.nan
            for step in range(1, 101):
                obs, _, terminated, truncated, info = env.step(policy(obs))
                if info["is_success"] and np.isnan(first):
                    first = step
                if terminated or truncated:
                    break
            ok = info["is_success"] and not info["sim_error"]
            rows.append((ok, first, info["object_to_goal"], info["object_travel"]))
        env.close()
        r = np.array(rows, float)
        reached = r[~np.isnan(r[:, 1]), 1]
        out.append(
            {
                "time_step_s": dt,
                "success_rate": float(r[:, 0].mean()),
                "reached_rate": len(reached) / len(r),
                "first_success_step_mean": float(reached.mean()) if len(reached) else None,
                "final_object_to_goal_mean_m": float(r[:, 2].mean()),
                "object_travel_mean_m": float(r[:, 3].mean()),
            }
        )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=20)
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    out = OUTPUT.path(args)
    steps = time_steps(args.episodes)
    print(
        f"Scripted push, randomized starts, {args.episodes} episodes per plant step, each to "
        "its step limit\n"
    )
    print(
        "| plant step (ms) | success at the end | success at some step | first success "
        "(step, mean) | final box–goal (cm) | box travel (cm) |"
    )
    print("| --- | --- | --- | --- | --- | --- |")
    for r in steps:
        first = r["first_success_step_mean"]
        print(
            f"| {r['time_step_s'] * 1e3:g} | {r['success_rate'] * 100:.0f} % | "
            f"{r['reached_rate'] * 100:.0f} % | "
            f"{'—' if first is None else f'{first:.1f}'} | "
            f"{r['final_object_to_goal_mean_m'] * 100:.2f} | "
            f"{r['object_travel_mean_m'] * 100:.2f} |"
        )
    atomic_write_json(
        out,
        {
            "command": f"python benchmarks/env_fidelity.py --episodes {args.episodes}",
            "machine": platform.platform(),
            "time_steps": steps,
        },
    )
    print(f"\nwrote {out}")


if __name__ == "__main__":
    sys.exit(run_script(main))
