"""Do the push policies push the box to the goal and hold it there? Each policy in simulation
and closed loop in the perturbed reality, judged against the goals for shipped push policies.

    python benchmarks/push_policies_hold.py [--policies DIR ...] [--episodes 100]
        [--seed 1000] [--tools 0.125 0.175 0.15 0.25] [--runs 20] [--reality-seed 300]

1. **Simulation**: `learning.evaluate.evaluate` over EPISODES seeded episodes (SEED …) of the
   paper's task (Env1, the 0.175 m tool, no actuation delay: a policy trained over drawn tools
   and delays is judged without them), each run to its 100-step limit and judged where the
   box ends (the env's default). Goals: the mean final box–goal distance ≤ 3 cm and ≥ 80 % of
   episodes with the box at the goal.
2. **Reality**: `experiments.transfer.run_transfer` closed loop, RUNS runs per tool (seeds
   REALITY_SEED …; the default 300 is apart from the seeds the policies were tuned on): the
   reality of diagrams/reality.yaml (40 ms actuation delay, conservative joint limits, a noisy
   camera, the grasp, box mass and friction drawn per run), the robot's model from the
   camera's measurement. Goal: ≥ 90 % of runs with the box at the goal at the
   end, for every tool (the paper's two, 0.125 and 0.175 m, and others).

Each policy's physical-sanity flags (simulation) are shown beside it. Prints a Markdown table
and whether each goal is met.
"""

import argparse
import sys
import time
from pathlib import Path

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.transfer import check_transfer_args, run_transfer
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.policy_dir import check_policy_env, load_policy
from drake_tooluse.limits import MAX_EPISODES
from drake_tooluse.paths import POLICIES_DIR
from drake_tooluse.tasks.push.registration import ENV_IDS as PUSH_ENV_IDS
from drake_tooluse.validation import check_int, check_seed

ROOT = Path(__file__).resolve().parent.parent
POLICIES = ("ppo_toolpush_tip", "ppo_toolpush", "ppo_toolpush_paper_action")
# The paper's task whatever the policy trained over (its other env kwargs stand: the action
# and observation modes).
PAPER_TASK = {"tool_length_range": None, "actuation_delay_range": None}
SIM_DISTANCE_GOAL = 0.03  # m
SIM_SUCCESS_GOAL = 0.80
REALITY_SUCCESS_GOAL = 0.90


def shown(policy: Path) -> str:
    """The policy as the table names it: relative to the checkout where it lies in it."""
    full = policy.resolve()
    return str(full.relative_to(ROOT)) if full.is_relative_to(ROOT) else str(policy)


def quiet(_line: str) -> None:
    """Drops the transfer's line per run."""


def check_args(args) -> None:
    """Every argument checked before the first policy runs: a ValueError (or
    FileNotFoundError, for a policy directory) naming the bad one."""
    check_int(args.episodes, 1, MAX_EPISODES, "--episodes")
    check_seed(args.seed, "--seed", args.episodes)
    check_transfer_args(args.tools, args.runs, "closed-loop", args.reality_seed)
    for path in args.policies:
        policy = load_policy(path)
        if policy.meta.env_id not in PUSH_ENV_IDS:
            raise ValueError(
                f"{path} is a policy for {policy.meta.env_id}; this benchmark runs push "
                f"policies ({', '.join(PUSH_ENV_IDS)})"
            )
        check_policy_env(policy, env_kwargs=PAPER_TASK)


def measure(policy: Path, args) -> dict:
    sim = evaluate(policy, episodes=args.episodes, seed=args.seed, env_kwargs=PAPER_TASK)
    real = run_transfer(policy, tools=args.tools, runs=args.runs, seed=args.reality_seed, log=quiet)
    reality = [t["reality"]["success_rate"] for t in real["tools"]]  # in the order of --tools
    distance = sim.metrics["final_object_to_goal_mean_m"]
    return {
        "distance": distance,
        "success": sim.success_rate,
        "flags": {k: v for k, v in sim.flagged_episodes.items() if v},
        "reality": reality,
        "sim_met": distance <= SIM_DISTANCE_GOAL and sim.success_rate >= SIM_SUCCESS_GOAL,
        "reality_met": all(s >= REALITY_SUCCESS_GOAL for s in reality),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument(
        "--policies",
        nargs="+",
        type=Path,
        default=[POLICIES_DIR / name for name in POLICIES],
        help="policy directories (default: the shipped push policies of the 0.20 m task)",
    )
    ap.add_argument("--episodes", type=int, default=100, help="simulation episodes per policy")
    ap.add_argument("--seed", type=int, default=1000, help="seed of the first episode")
    ap.add_argument("--tools", nargs="+", type=float, default=[0.125, 0.175, 0.15, 0.25], help="m")
    ap.add_argument("--runs", type=int, default=20, help="reality runs per tool")
    ap.add_argument("--reality-seed", type=int, default=300, help="seed of the first run")
    args = ap.parse_args()
    try:
        check_args(args)
    except (ValueError, FileNotFoundError) as e:
        ap.error(str(e))
    tools = " | ".join(f"reality {t * 100:g} cm" for t in args.tools)
    print(f"| policy | sim distance (cm) | sim success | sim flags | {tools} | goals | wall (s) |")
    print("|---" * (6 + len(args.tools)) + "|")
    failed = 0
    for policy in args.policies:
        start = time.perf_counter()
        m = measure(policy, args)
        reality = " | ".join(f"{s * 100:.0f} %" for s in m["reality"])
        flags = ", ".join(f"{k} {v}" for k, v in m["flags"].items()) or "none"
        goals = (
            f"sim {'met' if m['sim_met'] else 'NOT met'}, "
            f"reality {'met' if m['reality_met'] else 'NOT met'}"
        )
        failed += not (m["sim_met"] and m["reality_met"])
        print(
            f"| {shown(policy)} | {m['distance'] * 100:.2f} | {m['success'] * 100:.0f} % | {flags} "
            f"| {reality} | {goals} | {time.perf_counter() - start:.0f} |",
            flush=True,
        )
    print(
        f"goals: sim ≤ {SIM_DISTANCE_GOAL * 100:g} cm and ≥ {SIM_SUCCESS_GOAL * 100:g} % over "
        f"{args.episodes} episodes from seed {args.seed}; reality ≥ "
        f"{REALITY_SUCCESS_GOAL * 100:g} % for every tool over {args.runs} runs from seed "
        f"{args.reality_seed}. {len(args.policies) - failed} of {len(args.policies)} policies "
        "meet both"
    )
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
