"""The paper's experiments, with this project's tools: each run is a `drake-tooluse train`
command, evaluated with `drake-tooluse evaluate` over 100 seeded episodes.

    python benchmarks/paper_experiments.py [--runs-dir runs/paper] [--only NAME ...] [--out FILE]

Runs (budgets are this machine's, smaller than the paper's 1.25 M steps; see docs/TRAINING.md).
The results in docs/results/paper_experiments.json were measured before the first-order IK mode
was retired: the runs marked * trained with it (`ik_mode="differential"`); today every run
trains with the exact tool-tip IK, the env's only mode.
  ppo_env1 *          PPO on Env1, position action
  ppo_env1_fullik     the same at 300k steps (it trained with the exact IK when both existed)
  ppo_env1_tip        ppo_env1_fullik observing the task in tool-tip space only (the transfer policy)
  ppo_env1_paper *    PPO on Env1, the paper's 7-d action (tip position + quaternion change)
  trpo_env1, a2c_env1, ddpg_env1 *   the other three algorithms on Env1, position action
  ppo_env2 *          PPO on Env2 (reward -d(box, goal) only): tool or gripper?
  ppo_env3_scratch *  PPO on Env3 (goal 0.10 m further) from scratch
  ppo_env3_finetune * PPO on Env3 fine-tuned from ppo_env1's best policy

A run whose directory already has summary.json is not trained again (delete it to redo).
Writes docs/results/paper_experiments.json (or --out) and the figures in docs/figures/.
"""

import argparse
import json
import shlex
import subprocess
import sys
import time
from pathlib import Path

from drake_tooluse.files import atomic_write_json

ROOT = Path(__file__).resolve().parent.parent
ENV1, ENV2, ENV3 = (
    "drake_tooluse/ToolPush-v0",
    "drake_tooluse/ToolPushBoxReward-v0",
    "drake_tooluse/ToolPushFar-v0",
)
PAPER_ACTION = '{"env_kwargs": {"action_mode": "paper", "ik_mode": "full", "randomize": true}}'
FULL_IK = '{"env_kwargs": {"action_mode": "position", "ik_mode": "full", "randomize": true}}'
TIP_OBSERVATION = (
    '{"env_kwargs": {"action_mode": "position", "ik_mode": "full", '
    '"randomize": true, "observation_mode": "tip"}}'
)
RUNS = {
    "ppo_env1": dict(env=ENV1, algo="ppo", timesteps=500_000),
    "ppo_env1_fullik": dict(env=ENV1, algo="ppo", timesteps=300_000, hyperparams=FULL_IK),
    "ppo_env1_tip": dict(env=ENV1, algo="ppo", timesteps=300_000, hyperparams=TIP_OBSERVATION),
    "ppo_env2": dict(env=ENV2, algo="ppo", timesteps=200_000),
    "ppo_env3_scratch": dict(env=ENV3, algo="ppo", timesteps=200_000),
    "ppo_env3_finetune": dict(env=ENV3, algo="ppo", timesteps=100_000, init_from="ppo_env1"),
    "trpo_env1": dict(env=ENV1, algo="trpo", timesteps=200_000),
    "a2c_env1": dict(env=ENV1, algo="a2c", timesteps=200_000),
    "ppo_env1_paper": dict(env=ENV1, algo="ppo", timesteps=300_000, hyperparams=PAPER_ACTION),
    "ddpg_env1": dict(env=ENV1, algo="ddpg", timesteps=50_000),
}


def train_command(name: str, runs_dir: Path, seed: int) -> list[str]:
    r = RUNS[name]
    cmd = [
        "drake-tooluse",
        "train",
        "--env",
        r["env"],
        "--algo",
        r["algo"],
        "--timesteps",
        str(r["timesteps"]),
        "--seed",
        str(seed),
        "--out",
        str(runs_dir / name),
        "--no-progress",
    ]
    if "hyperparams" in r:
        cmd += ["--hyperparams", r["hyperparams"]]
    if "init_from" in r:
        cmd += ["--init-from", str(runs_dir / r["init_from"] / "best")]
    return cmd


def evaluate_command(policy: Path, env_id: str, episodes: int, extra=()) -> list[str]:
    return [
        "drake-tooluse",
        "evaluate",
        "--policy",
        str(policy),
        "--env",
        env_id,
        "--episodes",
        str(episodes),
        "--seed",
        "1000",
        "--json",
        *extra,
    ]


def run_json(cmd: list[str]) -> dict:
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--runs-dir", type=Path, default=ROOT / "runs" / "paper")
    ap.add_argument("--only", nargs="+", choices=list(RUNS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument(
        "--out",
        type=Path,
        default=ROOT / "docs" / "results" / "paper_experiments.json",
        help="results JSON, updated run by run",
    )
    args = ap.parse_args()
    names = args.only or list(RUNS)
    results_path = args.out
    results = json.loads(results_path.read_text()) if results_path.is_file() else {}
    for name in names:
        out = args.runs_dir / name
        cmd = train_command(name, args.runs_dir, args.seed)
        if not (out / "summary.json").is_file():
            print(f"[{time.strftime('%H:%M:%S')}] training {name}: {' '.join(cmd)}", flush=True)
            subprocess.run(cmd, check=True)
        summary = json.loads((out / "summary.json").read_text())
        env_id = RUNS[name]["env"]
        evaluation = run_json(evaluate_command(out / "best", env_id, args.episodes))
        entry = {
            "command": shlex.join(cmd),
            "train": summary,
            "evaluate_best": evaluation,
            "evaluate_command": shlex.join(evaluate_command(out / "best", env_id, args.episodes)),
        }
        results[name] = entry
        atomic_write_json(results_path, results)
        e = evaluation
        print(
            f"[{time.strftime('%H:%M:%S')}] {name}: final box-goal mean "
            f"{e['final_box_to_goal_mean_m'] * 100:.2f} cm, success "
            f"{e['success_rate'] * 100:.0f} %, {summary['timesteps']} steps in "
            f"{summary['wall_time_s'] / 60:.1f} min",
            flush=True,
        )


if __name__ == "__main__":
    sys.exit(main())
