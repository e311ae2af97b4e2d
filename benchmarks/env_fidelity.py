"""Is the fast env still the same task? The plant time step behind the env's speed: the
scripted push (randomized starts) at 5, 10 and 20 ms.

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
            "drake_tooluse/ToolPush-v0", action_mode="position", scenario=scenario, randomize=True
        )
        policy = ScriptedPush(scenario.table.top_z)
        rows = []
        for ep in range(episodes):
            obs, _ = env.reset(seed=ep)
            policy.reset()
            for steps in range(1, 101):  # noqa: B007  (read after the loop)
                obs, _, terminated, truncated, info = env.step(policy(obs))
                if terminated or truncated:
                    break
            rows.append((terminated, steps, info["object_to_goal"], info["object_travel"]))
        r = np.array(rows, float)
        out.append(
            {
                "time_step_s": dt,
                "success_rate": float(r[:, 0].mean()),
                "steps_mean": float(r[:, 1].mean()),
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
    print(f"Scripted push, randomized starts, {args.episodes} episodes per plant step\n")
    print("| plant step (ms) | success | steps (mean) | final box–goal (cm) | box travel (cm) |")
    print("| --- | --- | --- | --- | --- |")
    for r in steps:
        print(
            f"| {r['time_step_s'] * 1e3:g} | {r['success_rate'] * 100:.0f} % | "
            f"{r['steps_mean']:.1f} | {r['final_object_to_goal_mean_m'] * 100:.2f} | "
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
