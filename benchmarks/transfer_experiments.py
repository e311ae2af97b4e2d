"""The transfer experiment for each policy and mode, and the table quoted in docs/TRANSFER.md.

    python benchmarks/transfer_experiments.py [--runs 10] [--episodes 100] [--seed 0]
        [--only NAME ...] [--modes MODE ...] [--out DIR]

Runs `drake-tooluse transfer` (tools 0.125 and 0.175 m, the perturbed reality of
diagrams/reality.yaml against the nominal simulation) for

- `tip`: models/policies/ppo_toolpush_tip (observes the task in tool-tip space only);
- `paper`: models/policies/ppo_toolpush (the paper's observation: gripper pose, joint angles);
- `tip-length-only`: `tip` with the robot's model taking only the measured length, not the
  camera's estimate of the grasp along the tool (the paper's measurement);

each closed-loop, open-loop (the policy's episodes averaged into a trajectory and replayed: the
command's default, the line-contact trajectory) and open-loop-paper (the paper's own averaged
trajectory, `--extraction paper`: the baseline), writing docs/results/transfer/<name>_<mode>/
(or --out DIR/<name>_<mode>/: transfer.json, transfer_boxplot.png, and open loop the
trajectories and trajectory.png), then prints the Markdown table.
"""

import argparse
import json
import os
import sys
from pathlib import Path

from drake_tooluse.cli.common import run_script

ROOT = Path(__file__).resolve().parent.parent
# Relative to ROOT (the script runs there), so the JSON files hold repo paths.
OUT = Path("docs") / "results" / "transfer"
TIP = Path("models") / "policies" / "ppo_toolpush_tip"
PAPER = Path("models") / "policies" / "ppo_toolpush"
# name -> (policy, extra `transfer` arguments)
POLICIES = {"tip": (TIP, []), "paper": (PAPER, []), "tip-length-only": (TIP, ["--length-only"])}
# mode -> (`transfer --mode`, extra `transfer` arguments)
MODES = {
    "closed-loop": ("closed-loop", []),
    "open-loop": ("open-loop", []),
    "open-loop-paper": ("open-loop", ["--extraction", "mean-achieved"]),
}


def run(name: str, mode: str, runs: int, episodes: int, seed: int, out_dir: Path = OUT) -> dict:
    from drake_tooluse.cli import main

    out = out_dir / f"{name}_{mode}"
    policy, extra = POLICIES[name]
    transfer_mode, mode_extra = MODES[mode]
    argv = [
        "transfer",
        "--policy",
        str(policy),
        "--mode",
        transfer_mode,
        "--runs",
        str(runs),
        "--episodes",
        str(episodes),
        "--seed",
        str(seed),
        "--out",
        str(out),
        *extra,
        *mode_extra,
    ]
    print("drake-tooluse " + " ".join(argv), file=sys.stderr, flush=True)
    if main(argv) != 0:
        raise SystemExit(f"transfer {name} {mode} failed")
    return json.loads((out / "transfer.json").read_text())


def table(results: dict) -> str:
    lines = [
        "| policy | mode | tool (m) | measured (mm) | box travel nominal (cm) | box travel "
        "reality (cm) | reality / nominal | final box–goal reality (cm) | success nominal / "
        "reality | tools' travel differ (cm) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (name, mode), r in results.items():
        diff = r["goals"]["tool_travel_difference_m"]
        for t in r["tools"]:
            n, re_ = t["nominal"], t["reality"]
            ratio = "–" if t["travel_ratio"] is None else f"{t['travel_ratio'] * 100:.0f} %"
            lines.append(
                f"| {name} | {mode} | {t['tool_length_m']:.3f} | "
                f"{t['measured_length_mean_m'] * 1000:.2f} ± {t['measured_length_std_m'] * 1000:.2f}"
                f" | {n['box_travel_mean_m'] * 100:.1f} ± {n['box_travel_std_m'] * 100:.1f} | "
                f"{re_['box_travel_mean_m'] * 100:.1f} ± {re_['box_travel_std_m'] * 100:.1f} | "
                f"{ratio} | {re_['final_box_to_goal_mean_m'] * 100:.1f} | "
                f"{n['success_rate'] * 100:.0f} % / {re_['success_rate'] * 100:.0f} % | "
                f"{'–' if diff is None else f'{diff * 100:.2f}'} |"
            )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", nargs="+", choices=list(POLICIES), default=list(POLICIES))
    parser.add_argument("--modes", nargs="+", choices=list(MODES), default=list(MODES))
    parser.add_argument(
        "--report", action="store_true", help="only print the table of the results already written"
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=OUT,
        help=f"results directory (default {OUT}; relative: to the repository)",
    )
    args = parser.parse_args()
    os.chdir(ROOT)
    results = {}
    for name in args.only:
        for mode in args.modes:
            if args.report:
                results[name, mode] = json.loads(
                    (args.out / f"{name}_{mode}" / "transfer.json").read_text()
                )
            else:
                results[name, mode] = run(name, mode, args.runs, args.episodes, args.seed, args.out)
    print(table(results))


if __name__ == "__main__":
    sys.exit(run_script(main))
