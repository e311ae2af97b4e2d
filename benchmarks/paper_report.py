"""Tables and figures of the paper's experiments, from `benchmarks/paper_experiments.py`'s
results and its run directories.

    python benchmarks/paper_report.py [--runs-dir runs/paper] [--results FILE] [--out DIR]

Prints the Markdown tables quoted in docs/TRAINING.md and writes docs/figures/training_*.png
(or DIR/training_*.png).
"""

import argparse
import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "docs" / "figures"
PAPER_CM = {"ppo": 7.74, "trpo": 11.9, "ddpg": 35.1, "a2c": 40.9}


def eval_curve(run: Path):
    """(timesteps, mean eval episode reward) of the periodic evaluations."""
    path = run / "eval" / "evaluations.npz"
    if not path.is_file():
        return None
    data = np.load(path)
    return data["timesteps"], data["results"].mean(axis=1)


def rollout_curve(run: Path):
    """(timesteps, mean training episode reward) from progress.csv."""
    path = run / "logs" / "progress.csv"
    if not path.is_file():
        return None
    rows = [r for r in csv.DictReader(path.open()) if r.get("rollout/ep_rew_mean")]
    return (
        np.array([float(r["time/total_timesteps"]) for r in rows]),
        np.array([float(r["rollout/ep_rew_mean"]) for r in rows]),
    )


def _save(fig, name: str, figures: Path = FIGURES) -> None:
    figures.mkdir(parents=True, exist_ok=True)
    tmp = figures / f".{name}.tmp.png"
    fig.savefig(tmp, dpi=120)
    tmp.replace(figures / f"{name}.png")
    plt.close(fig)


def plot_curves(
    runs_dir: Path, names: dict, title: str, filename: str, figures: Path = FIGURES
) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for name, label in names.items():
        run = runs_dir / name
        for ax, curve in zip(axes, (rollout_curve(run), eval_curve(run))):
            if curve is not None and len(curve[0]):
                ax.plot(curve[0] / 1e3, curve[1], label=label)
    axes[0].set_title("training episodes (mean reward)", fontsize=9)
    axes[1].set_title("deterministic evaluation (mean reward)", fontsize=9)
    for ax in axes:
        ax.set_xlabel("env steps (thousands)")
        ax.set_ylabel("episode reward")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    _save(fig, filename, figures)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs-dir", type=Path, default=ROOT / "runs" / "paper")
    ap.add_argument(
        "--results",
        type=Path,
        default=ROOT / "docs" / "results" / "paper_experiments.json",
        help="benchmarks/paper_experiments.py's results",
    )
    ap.add_argument("--out", type=Path, default=FIGURES, help="directory for the figures")
    args = ap.parse_args()
    results = json.loads(args.results.read_text())

    print(
        "| run | env | algo, action | steps | wall (min) | final box–goal mean / median / std "
        "(cm) | success | box travel (cm) | tool / gripper touched | paper |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, r in results.items():
        e, t = r["evaluate_best"], r["train"]
        algo = name.split("_")[0]
        action = "paper 7-d" if name.endswith("_paper") else "position"
        paper = f"{PAPER_CM[algo]} cm" if name.endswith("env1") and algo in PAPER_CM else ""
        print(
            f"| {name} | {r['command'].split('--env ')[1].split()[0].split('/')[1]} | {algo}, "
            f"{action} | {t['timesteps']} | {t['wall_time_s'] / 60:.1f} | "
            f"{e['final_box_to_goal_mean_m'] * 100:.2f} / "
            f"{e['final_box_to_goal_median_m'] * 100:.2f} / "
            f"{e['final_box_to_goal_std_m'] * 100:.2f} | {e['success_rate'] * 100:.0f} % | "
            f"{e['box_travel_mean_m'] * 100:.1f} | {e['tool_touched_rate'] * 100:.0f} % / "
            f"{e['gripper_touched_rate'] * 100:.0f} % | {paper} |"
        )
    if "ppo_env1" in results and "evaluate_best_full_ik" in results["ppo_env1"]:
        e = results["ppo_env1"]["evaluate_best_full_ik"]
        print(
            f"\nppo_env1 best policy with ik_mode=full (InverseKinematics in the loop): final "
            f"box–goal mean {e['final_box_to_goal_mean_m'] * 100:.2f} cm, median "
            f"{e['final_box_to_goal_median_m'] * 100:.2f} cm, success "
            f"{e['success_rate'] * 100:.0f} %, tool touched {e['tool_touched_rate'] * 100:.0f}"
            f" %, gripper touched {e['gripper_touched_rate'] * 100:.0f} %"
        )

    algos = {
        n: n.split("_")[0].upper()
        for n in ("ppo_env1", "trpo_env1", "a2c_env1", "ddpg_env1", "ppo_env1_paper")
        if n in results
    }
    algos = {
        n: (label + " (paper 7-d action)" if n.endswith("paper") else label)
        for n, label in algos.items()
    }
    plot_curves(
        args.runs_dir,
        algos,
        "Env1 (ToolPush-v0): four algorithms, position action, and PPO with the paper's 7-d action",
        "training_env1_algorithms",
        args.out,
    )
    env3 = {
        n: label
        for n, label in (
            ("ppo_env3_scratch", "PPO from scratch"),
            ("ppo_env3_finetune", "PPO fine-tuned from Env1"),
        )
        if n in results
    }
    plot_curves(
        args.runs_dir,
        env3,
        "Env3 (ToolPushFar-v0): fine-tuned from Env1 vs from scratch",
        "training_env3_finetune",
        args.out,
    )
    print(f"\nwrote {args.out / 'training_env1_algorithms.png'}, training_env3_finetune.png")


if __name__ == "__main__":
    main()
