"""The transfer experiment for each policy and mode, and the table quoted in docs/TRANSFER.md.

    python benchmarks/transfer_experiments.py [--runs 10] [--episodes 100] [--seed 0]
        [--only NAME ...] [--modes MODE ...] [--out DIR] [--update-docs]
    python benchmarks/transfer_experiments.py --report [DIR]

Runs `drake-tooluse transfer` (tools 0.125 and 0.175 m, the perturbed reality of
diagrams/reality.yaml against the nominal simulation) for

- `tip`: models/policies/ppo_toolpush_tip (observes the task in tool-tip space only);
- `paper`: models/policies/ppo_toolpush (the paper's observation: gripper pose, joint angles);
- `tip-length-only`: `tip` with the robot's model taking only the measured length, not the
  camera's estimate of the grasp along the tool (the paper's measurement);

each closed-loop, open-loop (the policy's episodes averaged into a trajectory and replayed: the
command's default, the line-contact trajectory) and open-loop-paper (the paper's own averaged
trajectory, `--extraction mean-achieved`: the baseline), writing DIR/<name>_<mode>/
(transfer.json, transfer_boxplot.png, and open loop the trajectories and trajectory.png) into
a new directory (default runs/transfer_experiments-<time>/), then prints the Markdown table.
`--update-docs` then copies each into docs/results/transfer/<name>_<mode>/, the results the
docs quote, with every path in transfer.json relative (to the run's directory, or else to the
repository) instead of this machine's. `--report` prints the table of results already written
(default: docs/results/transfer/).
"""

import argparse
import json
import os
import shutil
import sys
from pathlib import Path

from drake_tooluse.cli.common import run_script
from drake_tooluse.paths import MODELS_DIR, POLICIES_DIR, SCENARIOS_DIR

ROOT = Path(__file__).resolve().parent.parent
DOCS_RESULTS = ROOT / "docs" / "results" / "transfer"
TIP = POLICIES_DIR / "ppo_toolpush_tip"
PAPER = POLICIES_DIR / "ppo_toolpush"
# name -> (policy, extra `transfer` arguments)
POLICIES = {"tip": (TIP, []), "paper": (PAPER, []), "tip-length-only": (TIP, ["--length-only"])}
# mode -> (`transfer --mode`, extra `transfer` arguments)
MODES = {
    "closed-loop": ("closed-loop", []),
    "open-loop": ("open-loop", []),
    "open-loop-paper": ("open-loop", ["--extraction", "mean-achieved"]),
}


def run(name: str, mode: str, runs: int, episodes: int, seed: int, out_dir: Path) -> dict:
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


def relative_paths(value, run_dir: Path):
    """`value` (a transfer.json's contents) with every absolute path made relative to the run's
    directory `run_dir` where it lies inside it; the package's models and scenarios as the
    repository names them (models/…, diagrams/…), wherever the package is installed; else
    relative to the repository where it lies there."""
    if isinstance(value, dict):
        return {k: relative_paths(v, run_dir) for k, v in value.items()}
    if isinstance(value, list):
        return [relative_paths(v, run_dir) for v in value]
    if isinstance(value, str) and os.path.isabs(value):
        path = Path(value).resolve()
        bases = ((run_dir, ""), (MODELS_DIR, "models"), (SCENARIOS_DIR, "diagrams"), (ROOT, ""))
        for base, name in bases:
            if path.is_relative_to(base.resolve()):
                return str(Path(name, path.relative_to(base.resolve())))
    return value


def update_docs(out_dir: Path, names) -> None:
    """Copies each run of `out_dir` into docs/results/transfer/, replacing the one there whole."""
    from drake_tooluse.files import atomic_dir, atomic_write_json

    for name in names:
        run_dir = out_dir / name
        with atomic_dir(DOCS_RESULTS / name, replace=True) as work:
            for file in run_dir.iterdir():
                if file.name == "transfer.json":
                    result = json.loads(file.read_text())
                    atomic_write_json(work / file.name, relative_paths(result, run_dir))
                elif file.is_file():
                    shutil.copy2(file, work / file.name)
        print(f"updated {DOCS_RESULTS.relative_to(ROOT) / name}", file=sys.stderr)


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
                f" | {n['object_travel_mean_m'] * 100:.1f} ± {n['object_travel_std_m'] * 100:.1f} | "
                f"{re_['object_travel_mean_m'] * 100:.1f} ± {re_['object_travel_std_m'] * 100:.1f} | "
                f"{ratio} | {re_['final_object_to_goal_mean_m'] * 100:.1f} | "
                f"{n['success_rate'] * 100:.0f} % / {re_['success_rate'] * 100:.0f} % | "
                f"{'–' if diff is None else f'{diff * 100:.2f}'} |"
            )
    return "\n".join(lines)


def main() -> None:
    from drake_tooluse.experiments.runs import new_run_dir
    from drake_tooluse.files import check_output_dir

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", nargs="+", choices=list(POLICIES), default=list(POLICIES))
    parser.add_argument("--modes", nargs="+", choices=list(MODES), default=list(MODES))
    parser.add_argument(
        "--report",
        nargs="?",
        type=Path,
        const=DOCS_RESULTS,
        metavar="DIR",
        help="only print the table of the results already in DIR (default: %(const)s)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        help="a new results directory (default: runs/transfer_experiments-<time>)",
    )
    parser.add_argument(
        "--update-docs",
        action="store_true",
        help=f"copy the results into {DOCS_RESULTS.relative_to(ROOT)}/, which the docs quote",
    )
    args = parser.parse_args()
    names = [(name, mode) for name in args.only for mode in args.modes]
    if args.report is not None:
        results = {
            (name, mode): json.loads((args.report / f"{name}_{mode}" / "transfer.json").read_text())
            for name, mode in names
        }
        print(table(results))
        return
    out = check_output_dir(args.out or new_run_dir("transfer_experiments"), "--out")
    results = {
        (name, mode): run(name, mode, args.runs, args.episodes, args.seed, out)
        for name, mode in names
    }
    print(table(results))
    if args.update_docs:
        update_docs(out, [f"{name}_{mode}" for name, mode in names])


if __name__ == "__main__":
    sys.exit(run_script(main))
