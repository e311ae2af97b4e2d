"""The hook policy in the perturbed reality, beside the scripted pull; and each task's policy
with the other task's tool.

    python benchmarks/pull_policy.py [--policy models/policies/ppo_toolpull]
        [--instances 100] [--seed 1000] [--cross-instances 20]

1. **Reality** (the goal: ≥ 70 % success): N seeded instances (seeds SEED … SEED+N−1, apart from
   the training's and the shipped evaluation's). Each draws a hook from HookTool's ranges,
   and the pull world as reality meets it (`task_worlds.task_scenarios("pull")`: actuation
   delay, conservative joint limits, camera noise) with the seed's draw of the cube's start,
   mass, friction and the grasp. The head camera measures the hook (`measure_hook_belief`);
   the policy pulls with what it measured, to the step limit, judged where the cube ends.
   The scripted pull (`ScriptedPull`) runs on the same instances with the same belief.
2. **The other task's tool** (nominal worlds, the same draws):
   - the push policy (`paths.TRANSFER_POLICY`) pushing with a hook, taking its straight
     handle for a straight tool (the hook hangs from its end);
   - the hook policy holding a straight tool as long as the hook's handle, told it holds
     that hook. The pull needs the hook: it should fail.

Prints Markdown tables.
"""

import argparse
import sys
import time

import numpy as np

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.task_worlds import measure, task_scenarios
from drake_tooluse.experiments.tool_choice import (
    LearnedPolicy,
    Outcome,
    ScriptedPolicy,
    run_outcome,
)
from drake_tooluse.experiments.transfer import attempt, run_worlds
from drake_tooluse.paths import PULL_POLICY, TRANSFER_POLICY
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import HookTool, StraightTool, tool_label
from drake_tooluse.tasks.pull.hook import draw_hook


def instance_hook(seed: int) -> HookTool:
    """The instance's hook, drawn from HookTool's ranges (its own stream of the seed)."""
    return HookTool(*draw_hook(np.random.default_rng([seed, 1])))


def reality(policies: dict, instances: range) -> dict:
    """Each policy's outcomes on the instances, in reality, with the camera's belief."""
    nominal, real = task_scenarios("pull")
    outcomes = {name: [] for name in policies}
    for seed in instances:
        hook = instance_hook(seed)
        world = run_worlds(nominal, real, hook, seed)[1]
        measured, error = attempt(measure, world, hook, seed)
        belief = None if measured is None else measured[0]
        for name, policy in policies.items():
            if belief is None:
                outcomes[name].append(Outcome(False, float("nan"), f"measurement: {error}"))
                continue
            outcome = run_outcome(policy, world, belief)
            outcomes[name].append(outcome)
            if not outcome.success:
                print(
                    f"  reality seed {seed} {tool_label(hook)}: {name} failed "
                    f"({outcome.final_distance * 100:.1f} cm from the goal"
                    f"{'; ' + outcome.error if outcome.error else ''})",
                    flush=True,
                )
    return outcomes


def with_other_tool(task: str, policy, tools, instances: range) -> list[Outcome]:
    """`policy` doing `task` in its nominal world, each instance's hook made into (the tool in
    the hand, the tool the robot believes it holds) by `tools`."""
    nominal, _ = task_scenarios(task)
    outcomes = []
    for seed in instances:
        held, believed = tools(instance_hook(seed))
        world = run_worlds(nominal, nominal, held, seed)[1]
        outcomes.append(run_outcome(policy, world, RobotBelief(believed)))
    return outcomes


def handle(hook: HookTool) -> StraightTool:
    """A straight tool as long as the hook's handle."""
    return StraightTool(hook.handle_length)


def row(name: str, outcomes: list[Outcome]) -> str:
    success = np.mean([o.success for o in outcomes])
    final = np.array([o.final_distance for o in outcomes], float)
    done = final[np.isfinite(final)]
    errors = sum(o.error is not None for o in outcomes)
    mean = f"{done.mean() * 100:.2f}" if len(done) else "–"
    median = f"{np.median(done) * 100:.2f}" if len(done) else "–"
    return f"| {name} | {len(outcomes)} | {success * 100:.0f} % | {mean} | {median} | {errors} |"


HEADER = (
    "| policy | runs | success | final distance mean (cm) | median (cm) | failed runs |\n"
    "| --- | --- | --- | --- | --- | --- |"
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--policy", default=str(PULL_POLICY), help="the hook policy's directory")
    ap.add_argument("--instances", type=int, default=100, help="reality instances")
    ap.add_argument("--seed", type=int, default=1000, help="the first instance's seed")
    ap.add_argument(
        "--cross-instances", type=int, default=20, help="instances with the other task's tool"
    )
    args = ap.parse_args()
    if args.instances < 1:
        ap.error(f"--instances={args.instances} must be at least 1")
    if args.cross_instances < 0:
        ap.error(f"--cross-instances={args.cross_instances} must be at least 0")
    if args.seed < 0:
        ap.error(f"--seed={args.seed} must be at least 0")
    learned = LearnedPolicy(args.policy)
    instances = range(args.seed, args.seed + args.instances)
    start = time.perf_counter()
    outcomes = reality(
        {"hook policy": learned, "scripted pull": ScriptedPolicy(learned.env_id)}, instances
    )
    seconds = time.perf_counter() - start
    print(
        f"\nToolPull in the perturbed reality (a hook drawn per instance and measured by the head "
        f"camera; delay, joint limits, camera noise, mass, friction, grasp), seeds "
        f"{instances.start}…{instances.stop - 1}, policy {args.policy}\n"
    )
    print(HEADER)
    for name, runs in outcomes.items():
        print(row(name, runs))
    rate = np.mean([o.success for o in outcomes["hook policy"]])
    print(
        f"\ngoal: reality success >= 70 %: {'met' if rate >= 0.70 else 'not met'} ({seconds:.0f} s)"
    )
    if args.cross_instances:
        cross = range(args.seed, args.seed + args.cross_instances)
        print(
            "\nEach task's policy with the other task's tool (nominal worlds), seeds "
            f"{cross.start}…{cross.stop - 1}\n"
        )
        print(HEADER)
        push = LearnedPolicy(TRANSFER_POLICY)
        hook_as_straight = with_other_tool("push", push, lambda h: (h, handle(h)), cross)
        print(row("push policy, a hook's straight handle (push)", hook_as_straight))
        straight_as_hook = with_other_tool("pull", learned, lambda h: (handle(h), h), cross)
        print(row("hook policy, a straight tool (pull)", straight_as_hook))


if __name__ == "__main__":
    sys.exit(run_script(main))
