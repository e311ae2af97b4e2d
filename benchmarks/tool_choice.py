"""The robot's choice of tool against the oracle's, over N seeded task instances.

Instance i (seed seed + i) is task TASKS[i mod len(TASKS)] of `--tasks`; the rack is the
default (`experiments.tool_choice.DEFAULT_RACK`) or `--tools`. For each instance the robot
measures every tool, predicts its success from `--rollouts` rollouts in its nominal
simulation of the measured tool, chooses, and does the task in reality; the oracle runs every
tool in reality on the same instance. Prints, per task and over all: the choice's end-to-end
success, the oracle's (some tool succeeds), their ratio (goals: ratio >= 0.90, end-to-end
>= 0.75), and the time per choice.

With `--generated-racks R`, the racks are of tools never trained with: R racks of five
generated tools of five families (`experiments.tool_choice.generated_rack`, rack seeds
seed … seed + R - 1), instance i holding rack i mod R. Each rack is measured once per task by
the head camera (`measure_rack`, its time printed apart: the robot knows its rack before it
chooses); each choice predicts from those shapes, and the chosen tool is measured again in
the hand for its grasp. Goals: ratio >= 0.95 and <= 5 s per choice. Instances where no tool
succeeds (the oracle fails) count for neither.

    python benchmarks/tool_choice.py [--instances 20] [--tasks push-far pull] [--rollouts 6]
        [--delay-margin 0.06] [--generated-racks R] [--workers N] [--out FILE.json [--resume]]
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from drake_tooluse.cli.common import count_arg, run_script, seed_arg
from drake_tooluse.experiments.choices import DEFAULT_ROLLOUTS
from drake_tooluse.experiments.parallel import available_cores
from drake_tooluse.experiments.tool_choice import (
    DEFAULT_RACK,
    DELAY_MARGIN,
    MAX_DELAY_MARGIN,
    TASKS,
    Policies,
    TaskInstance,
    check_rack,
    choose_tool,
    generated_rack,
    measure_rack,
)
from drake_tooluse.files import atomic_write_json, check_output_file
from drake_tooluse.validation import check_in_range, check_int

RATIO_GOAL, END_TO_END_GOAL = 0.90, 0.75
GENERATED_RATIO_GOAL, CHOICE_TIME_GOAL = 0.95, 5.0  # s per choice, on 2 cores


def recorded_args(args) -> dict:
    """The arguments that make the results (not where they go, nor how many processes)."""
    return {k: v for k, v in vars(args).items() if k not in ("out", "resume", "workers")}


def done_results(args) -> list:
    """The results an earlier run of the same arguments wrote to --out; ValueError where
    there is no such file or its arguments differ."""
    if not args.out:
        raise ValueError("--resume needs --out, the file of the run to resume")
    try:
        done = json.loads(Path(args.out).read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"--resume: cannot read {args.out!r}: {e}") from None
    recorded = done.get("args") if isinstance(done, dict) else None
    if recorded != recorded_args(args) or not isinstance(done.get("results"), list):
        raise ValueError(f"--resume: {args.out!r} holds a run of other arguments: {recorded}")
    return done["results"][: args.instances]


def row(name: str, results: list) -> str:
    chosen = np.array([r["success"] for r in results])
    oracle = np.array([r["oracle_success"] for r in results])
    ratio = f"{chosen.sum() / oracle.sum():.2f}" if oracle.sum() else "n/a"
    times = [r["choice_time_s"] for r in results]
    return (
        f"| {name} | {len(results)} | {chosen.mean():.2f} | {oracle.mean():.2f} | {ratio} | "
        f"{np.mean(times):.1f} | {np.mean([r['wall_time_s'] for r in results]):.1f} |"
    )


def generated_report(args, results: list, shapes: dict, seconds: float) -> None:
    """The table and goals of `--generated-racks`."""
    tools = sum(len(m) for m, _ in shapes.values())
    measuring = sum(t for _, t in shapes.values())
    print(
        f"\ntool choice on {args.generated_racks} racks of five generated tools never trained "
        f"with, {args.rollouts} rollouts per tool, seeds {args.seed}…"
        f"{args.seed + args.instances - 1}; the racks measured once per task: {tools} tools, "
        f"{measuring / max(tools, 1):.1f} s per tool\n"
    )
    print(
        "| tasks | instances | choice success | oracle success | ratio | choice time (s) "
        "| with the oracle's runs (s) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    met = True
    for task in args.tasks:
        mine = [r for r in results if r["task"] == task]
        print(row(task, mine))
        oracle = sum(r["oracle_success"] for r in mine)
        met &= bool(oracle) and sum(r["success"] for r in mine) / oracle >= GENERATED_RATIO_GOAL
    print(row("all", results))
    times = np.array([r["choice_time_s"] for r in results])
    none = sum(not r["oracle_success"] for r in results)
    print(
        f"\nno tool of the rack succeeds (counted for neither): {none} of {len(results)}; "
        f"choice time mean {times.mean():.1f} s, max {times.max():.1f} s"
    )
    fast = times.mean() <= CHOICE_TIME_GOAL
    print(
        f"goals: ratio >= {GENERATED_RATIO_GOAL:.2f} for each task: {'met' if met else 'not met'}; "
        f"<= {CHOICE_TIME_GOAL:.0f} s per choice (mean): {'met' if fast else 'not met'}  "
        f"({seconds:.0f} s)"
    )


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--instances", type=int, default=20, help="seeded task instances")
    ap.add_argument("--seed", type=int, default=0, help="the first instance's seed")
    ap.add_argument("--tasks", nargs="+", default=["push-far", "pull"], help=f"of {TASKS}")
    ap.add_argument("--tools", nargs="+", help="the rack (default: the default rack)")
    ap.add_argument(
        "--rollouts", type=int, default=DEFAULT_ROLLOUTS, help="predicted rollouts per tool"
    )
    ap.add_argument(
        "--delay-margin",
        type=float,
        default=DELAY_MARGIN,
        help="see tool_choice.rollout_delays (s)",
    )
    ap.add_argument(
        "--generated-racks",
        type=int,
        metavar="R",
        help="R racks of five generated tools the policies never trained with (not with --tools)",
    )
    ap.add_argument(
        "--workers",
        type=int,
        default=available_cores(),
        help="processes running a choice's rollouts (default: this machine's cores)",
    )
    ap.add_argument("--out", help="write every instance's result there (JSON), after each instance")
    ap.add_argument(
        "--resume",
        action="store_true",
        help="keep --out's results (of the same arguments) and run the instances after them",
    )
    return ap


def main() -> None:
    ap = parser()
    args = ap.parse_args()
    for task in args.tasks:
        if task not in TASKS:
            ap.error(f"--tasks: unknown task {task!r}; choose from {list(TASKS)}")
    try:  # the checks `drake-tooluse choose-tool` makes, before any work
        check_int(args.instances, 1, 10_000, "--instances")
        seed_arg(args.seed, "--seed", args.instances)
        count_arg(args.rollouts, "--rollouts")
        count_arg(args.workers, "--workers")
        check_in_range(args.delay_margin, 0.0, MAX_DELAY_MARGIN, "--delay-margin", unit="s")
        rack = check_rack(args.tools or DEFAULT_RACK)
        if args.generated_racks is not None:
            if args.tools:
                raise ValueError("--generated-racks draws the racks: give no --tools with it")
            check_int(args.generated_racks, 1, args.instances, "--generated-racks")
            seed_arg(args.seed, "--seed", args.generated_racks)
        results = []
        if args.resume:
            results = done_results(args)
        elif args.out:
            check_output_file(args.out, "--out", ".json")
    except ValueError as e:
        ap.error(str(e))
    policies = Policies()
    start = time.perf_counter()
    shapes = {}  # (task, rack index) -> the rack's shapes, measured once
    for i in range(len(results), args.instances):
        instance = TaskInstance(args.tasks[i % len(args.tasks)], args.seed + i)
        rack_shapes = None
        if args.generated_racks:
            r = i % args.generated_racks
            rack = generated_rack(args.seed + r)
            if (instance.task, r) not in shapes:
                measuring = time.perf_counter()
                measured = measure_rack(instance.task, rack, args.seed + r)
                shapes[instance.task, r] = (measured, time.perf_counter() - measuring)
            rack_shapes = shapes[instance.task, r][0]
        out = choose_tool(
            instance,
            rack,
            args.rollouts,
            oracle=True,
            policies=policies,
            delay_margin=args.delay_margin,
            rack_shapes=rack_shapes,
            progress=False,
            workers=args.workers,
        )
        results.append(out)
        if args.out:  # a kill loses at most the instance in progress (--resume)
            atomic_write_json(args.out, {"args": recorded_args(args), "results": results})
        if not out["success"]:
            print(
                f"seed {instance.seed} {instance.task}: chose {out['chosen']}, failed; the "
                f"oracle: {', '.join(out['oracle_tools']) or 'no tool succeeds'}",
                flush=True,
            )
    seconds = time.perf_counter() - start
    if args.generated_racks:
        generated_report(args, results, shapes, seconds)
        return
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
