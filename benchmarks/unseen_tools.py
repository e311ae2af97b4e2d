"""Tools the robot has never seen: each task's policies zero-shot on the generator's held-out
tools.

    python benchmarks/unseen_tools.py --policies DIR [DIR ...] [--tools 200] [--tool-seed 0]
        [--seed 1000] [--reality [--told]] [--max-steps 100] [--out FILE]

The held-out tools (`robot.tool_generator.split_draw`'s "held_out" split: the rake family,
which training never draws, and the corner of every other family's two shape parameters) are
drawn in turn from TOOL_SEED, keeping the first `--tools` of the families the policy's task
serves (`ToolTask.shape_families`: every family for a push; for the pull the hooks and the
arcs, held as their equivalent hook; the draws of other families are counted and printed).
Tool i is held in the task's nominal world with its randomized draw from SEED + i, the robot
told its geometry and grasp, and every policy is deployed there (`tasks.deploy.deploy`), run
to the step limit and judged where the object ends. Each policy's success and mean final
distance are printed over all tools and per family, side by side: by default the push policy
trained over the generator's training split (`models/policies/ppo_toolpush_shapes`, acting on
each tool's push point) and today's tip policy (`models/policies/ppo_toolpush_tip`, trained on
straight rods), which acts on any tool through its tip frame. Goal for a policy trained over
shapes: ≥ 85 % in simulation.

With --reality, each tool is instead held in its policy's task's perturbed reality (its
randomized draw from SEED + i), measured by the head camera (`measure_shape_belief`: the robot
is not told its family, shape or grasp), and every policy is deployed on that measured belief.
Goal: ≥ 75 %. A tool the camera fits to no family (or to one without what the task's policy
holds) is a failed run, with its error. With --reality --told, the robot is told each tool's
geometry and grasp there instead (what reality's delay and joint limits cost apart from the
camera's).

Every run is judged at the envs' step limit (MAX_STEPS, the protocol the goals hold at) unless
--max-steps sets another: a diagnosis of how far a policy is from the goal in time (each row
records the first step its task succeeded at, and the median per family is printed).

Prints a Markdown table; with --out, writes it as JSON (atomically).
"""

import argparse
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.task_worlds import TOOL_TASKS, holding, task_scenarios
from drake_tooluse.experiments.tool_choice import believed_tool, measured_belief
from drake_tooluse.experiments.transfer import attempt
from drake_tooluse.files import atomic_write_json, check_output_file
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.limits import MAX_BENCHMARK_PERIODS, MAX_EPISODES
from drake_tooluse.paths import POLICIES_DIR
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool_generator import FAMILIES, HELD_OUT_FAMILY, held_out_draws
from drake_tooluse.tasks.deploy import MAX_STEPS, deploy
from drake_tooluse.validation import check_int, check_seed
from drake_tooluse.world.randomization import apply_draw, draw_randomization

SIM_SUCCESS_GOAL = 0.85
REALITY_SUCCESS_GOAL = 0.75
DEFAULT_POLICIES = (POLICIES_DIR / "ppo_toolpush_shapes", POLICIES_DIR / "ppo_toolpush_tip")


def task_of(env_id: str) -> str | None:
    """The tool task (`experiments.task_worlds.TASKS`) whose policy acts in `env_id`, or None."""
    return next((name for name, task in TOOL_TASKS.items() if task.env_id == env_id), None)


def check_args(args) -> list:
    """Every argument checked before the first episode: a ValueError (or FileNotFoundError,
    for a policy directory) naming the bad one. Returns the loaded policies."""
    check_int(args.tools, 1, MAX_EPISODES, "--tools")
    check_seed(args.tool_seed, "--tool-seed")
    check_seed(args.seed, "--seed", args.tools)
    check_int(args.max_steps, 1, MAX_BENCHMARK_PERIODS, "--max-steps")
    if args.out is not None:
        check_output_file(args.out, "--out", ".json")
    policies = []
    for path in args.policies:
        policy = load_policy(path)
        if task_of(policy.meta.env_id) is None:
            raise ValueError(
                f"{path} is a policy for {policy.meta.env_id}, which no tool task deploys; "
                f"this benchmark runs the policies of "
                f"{', '.join(t.env_id for t in TOOL_TASKS.values())}"
            )
        policies.append(policy)
    return policies


def served_tools(task: str, count: int, seed: int) -> tuple[list, Counter]:
    """(the first `count` held-out tools drawn from `seed` of the families `task` serves; how
    many of each other family were drawn and passed over)."""
    families = TOOL_TASKS[task].shape_families
    tools, passed = [], Counter()
    for tool in held_out_draws(seed):
        if families is None or tool.family in families:
            tools.append(tool)
            if len(tools) == count:
                return tools, passed
        else:
            passed[tool.family] += 1


def _drawn(world, tool, seed: int):
    base = holding(world, tool)
    return apply_draw(base, draw_randomization(base, np.random.default_rng(seed)))


def told_worlds(task: str, tools, seed: int, reality: bool = False) -> list:
    """(scenario, belief, figures) per tool: tool i held in `task`'s nominal world (or, with
    `reality`, its perturbed reality) with its randomized draw from seed + i, the robot told
    its geometry and grasp."""
    world = task_scenarios(task)[1 if reality else 0]
    worlds = []
    for i, generated in enumerate(tools):
        scenario = _drawn(world, generated, seed + i)
        grasp = (scenario.tool.grasp_offset_across, scenario.tool.grasp_offset_along)
        worlds.append((scenario, RobotBelief(believed_tool(task, generated), grasp), {}))
    return worlds


def measured_realities(task: str, tools, seed: int) -> list:
    """(scenario, belief or None, figures) per tool: tool i held in `task`'s reality with its
    randomized draw from seed + i, and what the head camera measured of it (None, with the
    error in the figures, where the measurement gives the task's policy no tool)."""
    reality = task_scenarios(task)[1]
    worlds = []
    for i, generated in enumerate(tools):
        scenario = _drawn(reality, generated, seed + i)
        measured, error = attempt(measured_belief, task, scenario, seed + i)
        if measured is None:
            worlds.append((scenario, None, {"measured_family": None, "error": error}))
        else:
            worlds.append((scenario, measured[0], {"measured_family": measured[1].family}))
    return worlds


# The outcome of a tool the camera gave no belief of: a failed run that did not run.
NOT_RUN = {
    "success": False,
    "object_to_goal_m": None,
    "sim_error": False,
    "first_success_step": None,
}


def run_deployed(policy, tools, worlds, max_steps: int = MAX_STEPS) -> list[dict]:
    """One deployed run (`tasks.deploy.deploy`) of the loaded `policy` per tool in its world
    (`told_worlds`, `measured_realities`), to `max_steps`; a tool with no belief is a failed
    run."""
    rows = []
    for generated, (scenario, belief, figures) in zip(tools, worlds):
        row = {**generated.as_dict(), **figures}
        if belief is None:
            rows.append({**row, **NOT_RUN})
            continue
        run = deploy(scenario, policy, belief, max_steps)
        rows.append(
            {
                **row,
                "success": run.success,
                "object_to_goal_m": run.final_object_to_goal,
                "sim_error": run.sim_error,
                "first_success_step": run.first_success_step,
            }
        )
    return rows


def by_family(rows: list[dict]) -> dict:
    """`rows` by their tool's family, the families in FAMILIES' order."""
    grouped = defaultdict(list)
    for row in rows:
        grouped[row["family"]].append(row)
    return {f: grouped[f] for f in FAMILIES if f in grouped}


def first_success_medians(rows: list[dict]) -> str:
    """Per family, the median step the task first succeeded at over its runs that did, and how
    many did: `hook 60 (14 of 15), arc 86 (15 of 25)`."""
    parts = []
    for family, family_rows in by_family(rows).items():
        steps = [row["first_success_step"] for row in family_rows]
        reached = [s for s in steps if s is not None]
        median = f"{np.median(reached):.0f}" if reached else "–"
        parts.append(f"{family} {median} ({len(reached)} of {len(steps)})")
    return ", ".join(parts)


def summary(rows: list[dict]) -> dict:
    """Success and mean final distance over `rows`, and per family."""

    def figures(rs):
        return {
            "tools": len(rs),
            "success_rate": float(np.mean([r["success"] for r in rs])),
            # Over the runs that ran (a tool the camera gave no belief of did not).
            "object_to_goal_mean_m": float(
                np.mean([r["object_to_goal_m"] for r in rs if r["object_to_goal_m"] is not None])
            ),
        }

    return {
        **figures(rows),
        "families": {f: figures(rs) for f, rs in by_family(rows).items()},
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument(
        "--policies",
        nargs="+",
        type=Path,
        default=list(DEFAULT_POLICIES),
        help="policy directories of tool tasks (default: the shipped push policies over shapes "
        "and of the tip)",
    )
    ap.add_argument("--tools", type=int, default=200, help="held-out tools (one episode each)")
    ap.add_argument("--tool-seed", type=int, default=0, help="seed of the held-out tools' draw")
    ap.add_argument("--seed", type=int, default=1000, help="env seed of the first episode")
    ap.add_argument(
        "--reality",
        action="store_true",
        help="in the perturbed reality, each tool measured by the head camera",
    )
    ap.add_argument(
        "--told",
        action="store_true",
        help="with --reality: the robot told each tool's geometry and grasp, not measuring "
        "them (what the reality's perturbations cost apart from the camera's)",
    )
    ap.add_argument(
        "--max-steps",
        type=int,
        default=MAX_STEPS,
        help=f"control steps of each run, judged at its end (default: the envs' step limit, "
        f"{MAX_STEPS}, where the goals hold)",
    )
    ap.add_argument("--out", type=Path, help="write the figures as JSON here")
    args = ap.parse_args()
    if args.told and not args.reality:
        ap.error("--told goes with --reality (in simulation the robot is always told)")
    try:
        policies = check_args(args)
    except (ValueError, FileNotFoundError) as e:
        ap.error(str(e))
    tasks = list(dict.fromkeys(task_of(p.meta.env_id) for p in policies))
    tools, passed = {}, {}
    for task in tasks:
        tools[task], passed[task] = served_tools(task, args.tools, args.tool_seed)
    families = [f for f in FAMILIES if any(t.family == f for ts in tools.values() for t in ts)]
    heads = " | ".join(
        f"{f}{' (held-out family)' if f == HELD_OUT_FAMILY else ' (corner)'}" for f in families
    )
    print(f"| policy | task | success | distance (cm) | {heads} | wall (s) |")
    print("|---" * (5 + len(families)) + "|")
    results = {}
    worlds, measure_s = {}, 0.0  # task -> its worlds (each reality's tools measured once)
    for path, policy in zip(args.policies, policies):
        task = task_of(policy.meta.env_id)
        start = time.perf_counter()
        if task not in worlds:
            if args.reality and not args.told:
                worlds[task] = measured_realities(task, tools[task], args.seed)
            else:
                worlds[task] = told_worlds(task, tools[task], args.seed, args.reality)
            measure_s += time.perf_counter() - start
            start = time.perf_counter()
        rows = run_deployed(policy, tools[task], worlds[task], args.max_steps)
        s = summary(rows)
        results[str(path)] = {**s, "task": task, "episodes": rows}
        per_family = " | ".join(
            f"{s['families'][f]['success_rate'] * 100:.0f} % of {s['families'][f]['tools']}"
            if f in s["families"]
            else "–"
            for f in families
        )
        print(
            f"| {path} | {task} | {s['success_rate'] * 100:.1f} % | "
            f"{s['object_to_goal_mean_m'] * 100:.2f} | {per_family} | "
            f"{time.perf_counter() - start:.0f} |",
            flush=True,
        )
    where, goal = "in simulation, the robot told each tool's geometry and grasp", SIM_SUCCESS_GOAL
    if args.told and args.reality:
        where = "in the perturbed reality, the robot told each tool's geometry and grasp"
        goal = REALITY_SUCCESS_GOAL
    elif args.reality:
        rows = [row for r in results.values() for row in r["episodes"]]
        right = np.mean([row["measured_family"] == row["family"] for row in rows])
        where = (
            f"in the perturbed reality, each tool measured by the head camera (family named "
            f"right for {right * 100:.0f} %, {measure_s:.0f} s)"
        )
        goal = REALITY_SUCCESS_GOAL
    limit = "to the step limit" if args.max_steps == MAX_STEPS else f"to {args.max_steps} steps"
    print(
        f"{args.tools} held-out tools per task drawn from tool seed {args.tool_seed}, one "
        f"episode each from env seed {args.seed}, {where}, {limit}. Goal for a policy "
        f"trained over the generator's training split: ≥ {goal * 100:g} %"
        + ("." if args.max_steps == MAX_STEPS else f" at the step limit, {MAX_STEPS}.")
    )
    for path, result in results.items():
        print(f"{path}: median first success step {first_success_medians(result['episodes'])}")
    for task in tasks:
        if passed[task]:
            others = ", ".join(f"{n} {f}" for f, n in sorted(passed[task].items()))
            print(f"{task}: the draws of families its policy does not serve, passed over: {others}")
    if args.out is not None:
        atomic_write_json(
            args.out,
            {
                "tools": args.tools,
                "tool_seed": args.tool_seed,
                "seed": args.seed,
                "reality": args.reality,
                "told": args.told or not args.reality,
                "max_steps": args.max_steps,
                "success_goal": goal,
                "passed_over": {t: dict(passed[t]) for t in tasks},
                "policies": results,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
