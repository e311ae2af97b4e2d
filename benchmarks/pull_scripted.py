"""The scripted pull (`tasks.pull.scripted.ScriptedPull`) on drake_tooluse/ToolPull-v1: its
success rate and final cube–goal distance over N seeded episodes (seeds 0 … N−1), each with
a hook drawn from HookTool's ranges and a randomized start, judged at the step limit, and the
episodes a physical-sanity flag was raised in (`tasks.sanity`).

    python benchmarks/pull_scripted.py [--episodes 20] [--seed 0]
        [--scenario diagrams/pull_limits.yaml] [--delay-range LO HI]

`--scenario` replaces the pull world (reality's joint limits: diagrams/pull_limits.yaml) and
`--delay-range` draws each episode's actuation delay (s), as the env's options of those names.
Prints a Markdown table, and each failed episode's hook.
"""

import argparse
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.cli.common import run_script
from drake_tooluse.learning import evaluate
from drake_tooluse.learning.task_envs import check_env_kwargs
from drake_tooluse.tasks.pull.scripted import ScriptedPull
from drake_tooluse.tasks.sanity import PHYSICAL_LIMITS
from drake_tooluse.validation import check_seed
from drake_tooluse.world.scenario import load_scenario

ENV_ID = "drake_tooluse/ToolPull-v1"


def run_episode(env, seed: int) -> tuple[dict, bool]:
    """One scripted episode from `reset(seed=seed)` to the step limit (the evaluations' own
    loop, `learning.evaluate.run_episode`): its last `info`, and whether a physical-sanity flag
    was raised at any step."""
    script = ScriptedPull(env.unwrapped.scenario.table.top_z)
    sanity = evaluate.PhysicalSanity(PHYSICAL_LIMITS)
    info, _ = evaluate.run_episode(env, SimpleNamespace(act=script), seed, sanity.add)
    row = sanity.row()
    return info, any(row[limit.flag] for limit in PHYSICAL_LIMITS)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=20, help="seeded episodes")
    ap.add_argument("--seed", type=int, default=0, help="the first episode's seed")
    ap.add_argument("--scenario", help="the pull world's YAML (default diagrams/pull.yaml)")
    ap.add_argument(
        "--delay-range", type=float, nargs=2, metavar=("LO", "HI"), help="actuation delay (s)"
    )
    args = ap.parse_args(argv)
    if args.episodes < 1:
        ap.error(f"--episodes={args.episodes} must be at least 1")
    kwargs, shown = {}, {}
    try:
        check_seed(args.seed, "--seed", args.episodes)
        if args.scenario is not None:  # read once, here, where a missing file is an error
            kwargs["scenario"] = load_scenario(Path(args.scenario))
            shown["scenario"] = args.scenario
        if args.delay_range is not None:
            kwargs["actuation_delay_range"] = shown["actuation_delay_range"] = list(
                args.delay_range
            )
        check_env_kwargs(ENV_ID, kwargs)
    except (ValueError, FileNotFoundError) as error:
        ap.error(str(error))
    env = gym.make(ENV_ID, **kwargs)
    start = time.perf_counter()
    runs = [run_episode(env, args.seed + i) for i in range(args.episodes)]
    seconds = time.perf_counter() - start
    env.close()
    infos = [info for info, _ in runs]
    flagged = sum(flags for _, flags in runs)
    success = np.array([i["is_success"] for i in infos])
    final = np.array([i["object_to_goal"] for i in infos])
    travel = np.array([i["object_travel"] for i in infos])
    world = ", ".join(f"{k}={v}" for k, v in shown.items()) or "the pull world"
    print(
        f"ScriptedPull on ToolPull-v1 ({world}), seeds {args.seed}…"
        f"{args.seed + args.episodes - 1}\n"
    )
    print(
        "| episodes | success rate | final cube–goal mean (m) | median (m) | travel mean (m) "
        "| flagged episodes |"
    )
    print("| --- | --- | --- | --- | --- | --- |")
    print(
        f"| {args.episodes} | {success.mean():.2f} | {final.mean():.3f} | "
        f"{np.median(final):.3f} | {travel.mean():.3f} | {flagged} |"
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
