"""The robot's choice of tool against the oracle's, over N seeded task instances.

Instance i (seed seed + i) is task TASKS[i mod len(TASKS)] of `--tasks`; the rack is the
default (`experiments.tool_choice.DEFAULT_RACK`) or `--tools`. For each instance the robot
measures every tool, predicts its success from `--rollouts` rollouts in its nominal
simulation of the measured tool, chooses, and does the task in reality; the oracle runs every
tool in reality on the same instance. Prints, per task and over all: the choice's end-to-end
success, the oracle's (some tool succeeds), their ratio (goals: ratio >= 0.90, end-to-end
>= 0.75), and the time per choice.

    python benchmarks/tool_choice.py [--instances 20] [--tasks push-far pull] [--rollouts 3]
        [--delay-margin 0.06]
"""

import argparse
import sys
import time

import numpy as np

from drake_tooluse.cli.common import count_arg, run_script, seed_arg
from drake_tooluse.experiments.tool_choice import (
    DEFAULT_RACK,
    DELAY_MARGIN,
    MAX_DELAY_MARGIN,
    TASKS,
    Policies,
    TaskInstance,
    check_rack,
    choose_tool,
)
from drake_tooluse.validation import check_in_range, check_int

RATIO_GOAL, END_TO_END_GOAL = 0.90, 0.75


def row(name: str, results: list) -> str:
    chosen = np.array([r["success"] for r in results])
    oracle = np.array([r["oracle_success"] for r in results])
    ratio = f"{chosen.sum() / oracle.sum():.2f}" if oracle.sum() else "n/a"
    times = [r["choice_time_s"] for r in results]
    return (
        f"| {name} | {len(results)} | {chosen.mean():.2f} | {oracle.mean():.2f} | {ratio} | "
        f"{np.mean(times):.1f} | {np.mean([r['wall_time_s'] for r in results]):.1f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--instances", type=int, default=20, help="seeded task instances")
    ap.add_argument("--seed", type=int, default=0, help="the first instance's seed")
    ap.add_argument("--tasks", nargs="+", default=["push-far", "pull"], help=f"of {TASKS}")
    ap.add_argument("--tools", nargs="+", help="the rack (default: the default rack)")
    ap.add_argument("--rollouts", type=int, default=3, help="predicted rollouts per tool")
    ap.add_argument(
        "--delay-margin", type=float, default=DELAY_MARGIN, help="see tool_choice.predict (s)"
    )
    args = ap.parse_args()
    for task in args.tasks:
        if task not in TASKS:
            ap.error(f"--tasks: unknown task {task!r}; choose from {list(TASKS)}")
    try:  # the checks `drake-tooluse choose-tool` makes, before any work
        check_int(args.instances, 1, 10_000, "--instances")
        seed_arg(args.seed, "--seed", args.instances)
        count_arg(args.rollouts, "--rollouts")
        check_in_range(args.delay_margin, 0.0, MAX_DELAY_MARGIN, "--delay-margin", unit="s")
        rack = check_rack(args.tools or DEFAULT_RACK)
    except ValueError as e:
        ap.error(str(e))
    policies = Policies()
    start = time.perf_counter()
    results = []
    for i in range(args.instances):
        instance = TaskInstance(args.tasks[i % len(args.tasks)], args.seed + i)
        out = choose_tool(
            instance,
            rack,
            args.rollouts,
            oracle=True,
            policies=policies,
            delay_margin=args.delay_margin,
        )
        results.append(out)
        if not out["success"]:
            print(
                f"seed {instance.seed} {instance.task}: chose {out['chosen']}, failed; the "
                f"oracle: {', '.join(out['oracle_tools']) or 'no tool succeeds'}",
                flush=True,
            )
    seconds = time.perf_counter() - start
    rack_text = " ".join(c["tool"] for c in results[0]["candidates"])
    print(
        f"\ntool choice, rack [{rack_text}], {args.rollouts} rollouts per tool (actuation delays up to "
        f"{args.delay_margin * 1000:.0f} ms), seeds "
        f"{args.seed}…{args.seed + args.instances - 1}\n"
    )
    print(
        "| tasks | instances | choice success | oracle success | ratio | choice time (s) "
        "| with the oracle's runs (s) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for task in args.tasks:
        print(row(task, [r for r in results if r["task"] == task]))
    print(row("all", results))
    chosen = np.mean([r["success"] for r in results])
    oracle = sum(r["oracle_success"] for r in results)
    ratio = sum(r["success"] for r in results) / oracle if oracle else float("nan")
    print(
        f"\ngoals: ratio >= {RATIO_GOAL:.2f}: {'met' if ratio >= RATIO_GOAL else 'not met'}; "
        f"end-to-end >= {END_TO_END_GOAL:.2f}: "
        f"{'met' if chosen >= END_TO_END_GOAL else 'not met'}  ({seconds:.0f} s)"
    )


if __name__ == "__main__":
    sys.exit(run_script(main))
