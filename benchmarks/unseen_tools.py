"""Tools the robot has never seen: push policies zero-shot on the generator's held-out tools.

    python benchmarks/unseen_tools.py --policies DIR [DIR ...] [--tools 200] [--tool-seed 0]
        [--seed 1000] [--reality] [--out FILE]

The held-out tools (`robot.tool_generator.held_out_tools`: the rake family, which training
never draws, and the corner of every other family's two shape parameters) are drawn once
from TOOL_SEED; tool i is run for one episode from env seed SEED + i by every policy, in
simulation (the policy's own env and settings, the robot told the tool's geometry), run to
the step limit and judged where the box ends. Each policy's success and mean final box–goal
distance are printed over all tools and per family, side by side: the policy trained over the
generator's training split (`models/policies/ppo_toolpush_shapes`: `generated_tools="training"`,
acting on each tool's push point) and today's tip policy (`models/policies/ppo_toolpush_tip`,
trained on straight rods), which acts on any tool through its tip frame. Goal for the policy
trained over shapes: ≥ 85 % in simulation.

With --reality, each tool is instead held in its policy's task's perturbed reality (its randomized
draw from SEED + i), measured by the head camera (`measure_shape_belief`: the robot is not told
its family, shape or grasp), and every policy is deployed on that measured belief
(`tasks.deploy`), run to the step limit and judged where the box ends. Goal: ≥ 75 %.

Prints a Markdown table; with --out, writes it as JSON (atomically).
"""

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.task_worlds import TOOL_TASKS, holding, measure, task_scenarios
from drake_tooluse.files import atomic_write_json, check_output_file
from drake_tooluse.learning.evaluate import make_policy_env, run_episode
from drake_tooluse.learning.policy_dir import check_policy_env, load_policy
from drake_tooluse.limits import MAX_EPISODES
from drake_tooluse.paths import POLICIES_DIR
from drake_tooluse.robot.tool_generator import FAMILIES, HELD_OUT_FAMILY, held_out_tools
from drake_tooluse.tasks.deploy import deploy
from drake_tooluse.tasks.push.registration import ENV_IDS as PUSH_ENV_IDS
from drake_tooluse.validation import check_int, check_seed
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import Scenario, with_tool

SIM_SUCCESS_GOAL = 0.85
REALITY_SUCCESS_GOAL = 0.75
DEFAULT_POLICIES = (POLICIES_DIR / "ppo_toolpush_shapes", POLICIES_DIR / "ppo_toolpush_tip")
# One tool per episode, given as the scenario's: the env draws none itself.
ONE_TOOL = {"generated_tools": None, "tool_length_range": None, "tool_length": None}


def check_args(args) -> list:
    """Every argument checked before the first episode: a ValueError (or FileNotFoundError,
    for a policy directory) naming the bad one. Returns the loaded policies."""
    check_int(args.tools, 1, MAX_EPISODES, "--tools")
    check_seed(args.tool_seed, "--tool-seed")
    check_seed(args.seed, "--seed", args.tools)
    if args.out is not None:
        check_output_file(args.out, "--out", ".json")
    policies = []
    for path in args.policies:
        policy = load_policy(path)
        if policy.meta.env_id not in PUSH_ENV_IDS:
            raise ValueError(
                f"{path} is a policy for {policy.meta.env_id}; this benchmark runs push "
                f"policies ({', '.join(PUSH_ENV_IDS)})"
            )
        if args.reality and task_of(policy.meta.env_id) is None:
            raise ValueError(
                f"{path} is a policy for {policy.meta.env_id}, which no tool task deploys in "
                "reality; --reality runs the policies of "
                f"{', '.join(t.env_id for t in TOOL_TASKS.values())}"
            )
        check_policy_env(policy, env_kwargs=ONE_TOOL)
        policies.append(policy)
    return policies


def run_policy(policy, tools, seed: int) -> list[dict]:
    """One episode per tool (env seed seed + i), each row its tool, success and distance."""
    rows = []
    for i, generated in enumerate(tools):
        scenario = with_tool(Scenario(), generated)
        _, env = make_policy_env(policy, env_kwargs={**ONE_TOOL, "scenario": scenario})
        try:
            info, _ = run_episode(env, policy, seed + i)
        finally:
            env.close()
        rows.append(
            {
                **generated.as_dict(),
                "success": bool(info["is_success"]) and not info["sim_error"],
                "object_to_goal_m": float(info["object_to_goal"]),
                "sim_error": bool(info["sim_error"]),
            }
        )
    return rows


def task_of(env_id: str) -> str | None:
    """The tool task (`experiments.task_worlds.TASKS`) whose policy acts in `env_id`, or None."""
    return next((name for name, task in TOOL_TASKS.items() if task.env_id == env_id), None)


def measured_realities(task: str, tools, seed: int) -> list:
    """(scenario, belief, measurement figures) per tool: tool i held in `task`'s reality with
    its randomized draw from seed + i, and what the head camera measured of it."""
    reality = task_scenarios(task)[1]
    worlds = []
    for i, generated in enumerate(tools):
        base = holding(reality, generated)
        scenario = apply_draw(base, draw_randomization(base, np.random.default_rng(seed + i)))
        belief, measurement = measure(scenario, generated, seed + i)
        figures = {"measured_family": measurement.family}
        worlds.append((scenario, belief, figures))
    return worlds


def run_policy_in_reality(policy, tools, worlds) -> list[dict]:
    """One deployed run (`tasks.deploy.deploy`) of the loaded `policy` per tool in its
    measured reality (`measured_realities`)."""
    rows = []
    for generated, (scenario, belief, figures) in zip(tools, worlds):
        run = deploy(scenario, policy, belief)
        rows.append(
            {
                **generated.as_dict(),
                **figures,
                "success": run.success,
                "object_to_goal_m": run.final_object_to_goal,
                "sim_error": run.sim_error,
            }
        )
    return rows


def summary(rows: list[dict]) -> dict:
    """Success and mean final distance over `rows`, and per family."""
    by_family = defaultdict(list)
    for row in rows:
        by_family[row["family"]].append(row)

    def figures(rs):
        return {
            "tools": len(rs),
            "success_rate": float(np.mean([r["success"] for r in rs])),
            "object_to_goal_mean_m": float(np.mean([r["object_to_goal_m"] for r in rs])),
        }

    return {
        **figures(rows),
        "families": {f: figures(by_family[f]) for f in FAMILIES if f in by_family},
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument(
        "--policies",
        nargs="+",
        type=Path,
        default=list(DEFAULT_POLICIES),
        help="push policy directories (default: the shipped shapes and tip policies)",
    )
    ap.add_argument("--tools", type=int, default=200, help="held-out tools (one episode each)")
    ap.add_argument("--tool-seed", type=int, default=0, help="seed of the held-out tools' draw")
    ap.add_argument("--seed", type=int, default=1000, help="env seed of the first episode")
    ap.add_argument(
        "--reality",
        action="store_true",
        help="in the perturbed reality, each tool measured by the head camera",
    )
    ap.add_argument("--out", type=Path, help="write the figures as JSON here")
    args = ap.parse_args()
    try:
        policies = check_args(args)
    except (ValueError, FileNotFoundError) as e:
        ap.error(str(e))
    tools = held_out_tools(args.tools, args.tool_seed)
    families = [f for f in FAMILIES if any(t.family == f for t in tools)]
    heads = " | ".join(
        f"{f}{' (held-out family)' if f == HELD_OUT_FAMILY else ' (corner)'}" for f in families
    )
    print(f"| policy | success | distance (cm) | {heads} | wall (s) |")
    print("|---" * (4 + len(families)) + "|")
    results = {}
    worlds, measure_s = {}, 0.0  # task -> its measured realities (the tools measured once)
    for path, policy in zip(args.policies, policies):
        start = time.perf_counter()
        if args.reality:
            task = task_of(policy.meta.env_id)
            if task not in worlds:
                worlds[task] = measured_realities(task, tools, args.seed)
                measure_s += time.perf_counter() - start
                start = time.perf_counter()
            rows = run_policy_in_reality(policy, tools, worlds[task])
        else:
            rows = run_policy(policy, tools, args.seed)
        s = summary(rows)
        results[str(path)] = {**s, "episodes": rows}
        per_family = " | ".join(
            f"{s['families'][f]['success_rate'] * 100:.0f} % of {s['families'][f]['tools']}"
            for f in families
        )
        print(
            f"| {path} | {s['success_rate'] * 100:.1f} % | {s['object_to_goal_mean_m'] * 100:.2f} "
            f"| {per_family} | {time.perf_counter() - start:.0f} |",
            flush=True,
        )
    where, goal = "in simulation", SIM_SUCCESS_GOAL
    if args.reality:
        measured = next(iter(worlds.values()))
        right = np.mean([f["measured_family"] == t.family for t, (_, _, f) in zip(tools, measured)])
        where = (
            f"in the perturbed reality, each tool measured by the head camera (family named "
            f"right for {right * 100:.0f} %, {measure_s:.0f} s)"
        )
        goal = REALITY_SUCCESS_GOAL
    print(
        f"{args.tools} held-out tools drawn from tool seed {args.tool_seed}, one episode each "
        f"from env seed {args.seed}, {where}, to the step limit. Goal for a policy "
        f"trained over the generator's training split: ≥ {goal * 100:g} %."
    )
    if args.out is not None:
        atomic_write_json(
            args.out,
            {
                "tools": args.tools,
                "tool_seed": args.tool_seed,
                "seed": args.seed,
                "reality": args.reality,
                "success_goal": goal,
                "policies": results,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
