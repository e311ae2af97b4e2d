"""docs/TRAINING.md and its figures (`drake-tooluse study-report`), made from the paper study's
results (`experiments.paper_study`: docs/results/paper_study.json) and its runs' archived files
(docs/results/paper_study/: the training curves and best policies).

Statistics are rliable's (Agarwal et al. 2021) over the seeds of a cell, each seed's score its
mean over the 100 evaluation episodes (the same seeded starts for every run): the mean and the
interquartile mean (IQM) of the final box–goal distance and the mean success rate, each with a
95 % bootstrap confidence interval (2,000 resamples of the seeds, seeded: the page is the same
every time it is made; with three seeds the interval is wide, as it should be).
Figures: Env1's reward curves of the four algorithms with seed bands (the paper's four-panel
figure), PPO with the paper's action beside the position action, Env3 fine-tuned against from
scratch, and N generated tool-tip trajectories per algorithm with their mean (the paper's 3-D
figure; a cell with no finished seed is left out). A figure draws the seeds whose files it has;
its legend counts them. The paper's figures stand beside the cells judged in its protocol only.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix

from drake_tooluse.experiments.paper_study import order, read_results, run_dir, run_state
from drake_tooluse.experiments.paper_study_cells import StudyFiles
from drake_tooluse.experiments.trajectory_extraction import record_episodes
from drake_tooluse.files import atomic_write_figure, atomic_write_text
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tip_target import Workspace, apply_action
from drake_tooluse.tasks.push.registration import MAX_EPISODE_STEPS
from drake_tooluse.validation import EnvironmentProblem

# The paper's figures, set beside the cells judged in its protocol (to the step limit) only.
# Its PPO acted with the 7-d action (position and quaternion change), so its figure stands
# beside both PPO cells: the one with that action and the one with the position action.
PAPER_CM = {
    "hold_ppo_env1_paper": 7.74,
    "hold_ppo_env1": 7.74,
    "hold_trpo_env1": 11.9,
    "hold_a2c_env1": 40.9,
}
PAPER_STEPS = 1_250_000  # the paper's budget per algorithm
ALGORITHMS = {"ppo_env1": "PPO", "trpo_env1": "TRPO", "a2c_env1": "A2C", "ddpg_env1": "DDPG"}
BOOTSTRAP_REPS = 2000


def finished(results: dict, cell: str) -> dict:
    """seed → entry of the cell's evaluated runs."""
    seeds = results.get(cell, {}).get("seeds", {})
    return {int(s): e for s, e in seeds.items() if "evaluate_best" in e}


def interval_estimates(entries: dict, evaluation: str = "evaluate_best") -> dict:
    """Over the seeds: the mean and IQM of each run's mean final distance (cm), and the mean of
    each run's success rate (%), with 95 % stratified-bootstrap CIs (rliable: the runs of the
    one task resampled; None with fewer than two seeds), of one of the runs' evaluations
    (`paper_study.EVALUATIONS`)."""
    try:
        from rliable import library as rly
        from rliable import metrics
    except ImportError:
        raise EnvironmentProblem(
            "the study's statistics need rliable: install the bench extra (pip install '.[bench]')"
        ) from None
    runs = [e[evaluation]["per_episode"] for e in entries.values()]
    distance = np.array([[np.mean(r["final_object_to_goal_m"]) * 100] for r in runs])  # (seeds, 1)
    success = np.array([[np.mean(r["success"]) * 100] for r in runs])

    def estimates(scores, aggregates):
        np.random.seed(0)  # rliable's StratifiedBootstrap draws from NumPy's global generator
        points, intervals = rly.get_interval_estimates(
            {"cell": scores}, lambda x: np.array([f(x) for f in aggregates]), reps=BOOTSTRAP_REPS
        )
        return points["cell"], intervals["cell"]

    out = {}
    for name, scores, aggregates in (
        ("distance_cm", distance, (metrics.aggregate_mean, metrics.aggregate_iqm)),
        ("success_pct", success, (metrics.aggregate_mean,)),
    ):
        points, intervals = estimates(scores, aggregates)
        several = len(runs) >= 2
        out[name] = {"n": len(runs)}
        for i, key in enumerate(("mean", "iqm")[: len(aggregates)]):
            out[name][key] = float(points[i])
            out[name][key + "_ci"] = [float(v) for v in intervals[:, i]] if several else None
    return out


_STATS: dict = {}


def cell_stats(results: dict, cell: str, evaluation: str = "evaluate_best") -> dict | None:
    """`interval_estimates` of a cell's finished seeds, computed once (the page quotes them in
    more than one place, and a bootstrap's resamples are drawn again on every call); None if
    none is finished or one lacks that evaluation."""
    done = finished(results, cell)
    if not done or not all(evaluation in e for e in done.values()):
        return None
    # The evaluations themselves are the key: two results files never share statistics.
    key = (cell, evaluation, json.dumps([done[s][evaluation]["per_episode"] for s in sorted(done)]))
    if key not in _STATS:
        _STATS[key] = interval_estimates(done, evaluation)
    return _STATS[key]


def _ci(d: dict, key: str, digits: int) -> str:
    if d[key + "_ci"] is None:
        return f"{d[key]:.{digits}f} [one seed: no CI]"
    lo, hi = d[key + "_ci"]
    return f"{d[key]:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def study_table(results: dict, cells: dict) -> str:
    lines = [
        "| cell | protocol (trained and judged) | env | algo, action | seeds done | steps per run | wall per run (min) | "
        "final box–goal mean (cm) [95 % CI] | IQM (cm) [95 % CI] | success (%) [95 % CI] | "
        "per seed: mean cm / success | box travel (cm) | tool / gripper touched | "
        "run on to the 100-step limit: final box–goal mean (cm) [95 % CI], success (%) | paper |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for cell, c in cells.items():
        done = finished(results, cell)
        action = (
            "paper 7-d"
            if c.get("hyperparams", {}).get("env_kwargs", {}).get("action_mode")
            in ("paper", "position_quaternion")
            else "position"
        )
        protocol = "to the limit" if c.get("protocol") == "to-limit" else "early end"
        head = (
            f"| {cell} | {protocol} | {c['env'].split('/')[1]} | {c['algo']}, {action} | "
            f"{len(done)} of {len(c['seeds'])} |"
        )
        paper = f"{PAPER_CM[cell]} cm (1 run)" if cell in PAPER_CM else ""
        if not done:
            lines.append(head + f" {c['timesteps']} | | | | | | | | | {paper} |")
            continue
        stats = cell_stats(results, cell)
        evals = [e["evaluate_best"] for e in done.values()]
        per_seed = ", ".join(
            f"s{s}: {e['evaluate_best']['final_object_to_goal_mean_m'] * 100:.2f} / "
            f"{e['evaluate_best']['success_rate'] * 100:.0f} %"
            for s, e in sorted(done.items())
        )
        wall = np.mean([e["train"]["wall_time_s"] for e in done.values()]) / 60
        steps = int(np.mean([e["train"]["timesteps"] for e in done.values()]))
        lines.append(
            head + f" {steps} | {wall:.0f} | {_ci(stats['distance_cm'], 'mean', 2)} | "
            f"{_ci(stats['distance_cm'], 'iqm', 2)} | {_ci(stats['success_pct'], 'mean', 0)} | "
            f"{per_seed} | {np.mean([e['object_travel_mean_m'] for e in evals]) * 100:.1f} | "
            f"{np.mean([e['tool_touched_rate'] for e in evals]) * 100:.0f} % / "
            f"{np.mean([e['gripper_touched_rate'] for e in evals]) * 100:.0f} % | "
            f"{_at_limit(results, cell)} | {paper} |"
        )
    return "\n".join(lines) + "\n"


def _at_limit(results: dict, cell: str) -> str:
    stats = cell_stats(results, cell, "evaluate_best_time_limit")
    if stats is None:
        done = finished(results, cell)
        have = sum("evaluate_best_time_limit" in e for e in done.values())
        return f"{have} of {len(done)} seeds evaluated so"
    return f"{_ci(stats['distance_cm'], 'mean', 2)}, {_ci(stats['success_pct'], 'mean', 0)}"


def missing_runs(results: dict, cells: dict, runs_dir: Path) -> str:
    """What is still to run, in the order the job runs it (the runner's `order`), and about
    how long each run takes here (its cell's finished runs), so that the rest can be planned."""
    queue = [(cell, seed) for cell, c in cells.items() for seed in c["seeds"]]
    lines = []
    for cell, seed in order(cells, queue, runs_dir, results):
        state = run_state(cells, runs_dir, runs_dir, results, cell, seed)
        if state.startswith("done"):
            continue
        rates = [
            e["train"]["steps_per_s"] for e in finished(results, cell).values() if "train" in e
        ]
        minutes = cells[cell]["timesteps"] / np.mean(rates) / 60 if rates else None
        took = f"; ~{minutes:.0f} min here" if minutes else ""
        lines.append(f"- `{cell}` seed {seed}: {state}{took}")
    return "\n".join(lines) + "\n" if lines else "Every cell has all its seeds.\n"


def earlier_runs(path: Path) -> str:
    """The single-seed runs of an earlier session (docs/results/paper_experiments.json): most
    trained with the first-order IK since retired; one is where the demo's policy comes from."""
    if not path.is_file():
        return ""
    lines = [
        "## Earlier single-seed runs (before the fast IK)\n",
        "One seed each, at budgets below the paper's, from `docs/results/paper_experiments.json`"
        " (an earlier version of the runner). Every run but `ppo_env1_fullik` and `ppo_env1_tip`"
        " trained with the first-order differential IK, since retired; the evaluations are of "
        "the current code. The study above supersedes them; they stay for `ppo_env1_tip`, the run "
        "the demo's shipped policy (`models/policies/ppo_toolpush_tip`) comes from.\n",
        "| run | steps | final box–goal mean / median (cm) | success | box travel (cm) | "
        "tool / gripper touched |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, r in json.loads(path.read_text()).items():
        e, t = r["evaluate_best"], r["train"]
        lines.append(
            f"| {name} | {t['timesteps']} | {e['final_object_to_goal_mean_m'] * 100:.2f} / "
            f"{e['final_object_to_goal_median_m'] * 100:.2f} | {e['success_rate'] * 100:.0f} % | "
            f"{e['object_travel_mean_m'] * 100:.1f} | {e['tool_touched_rate'] * 100:.0f} % / "
            f"{e['gripper_touched_rate'] * 100:.0f} % |"
        )
    return "\n".join(lines) + "\n"


def _curve(run: Path):
    """(timesteps, training episode reward) from progress.csv."""
    path = run / "logs" / "progress.csv"
    if not path.is_file():
        return None
    with path.open() as f:
        rows = [r for r in csv.DictReader(f) if r.get("rollout/ep_rew_mean")]
    if not rows:
        return None
    return (
        np.array([float(r["time/total_timesteps"]) for r in rows]),
        np.array([float(r["rollout/ep_rew_mean"]) for r in rows]),
    )


def plot_band(ax, runs_dir: Path, cell: str, seeds, label: str, color: str, offset: float = 0.0):
    """The finished seeds' mean training reward and their range (the band), on a common
    grid; whether there was a curve to draw."""
    curves = [_curve(run_dir(runs_dir, cell, s)) for s in seeds]
    curves = [c for c in curves if c is not None and len(c[0]) > 1]
    if not curves:
        return False
    end = min(c[0][-1] for c in curves)
    grid = np.linspace(max(c[0][0] for c in curves), end, 200)
    ys = np.array([np.interp(grid, t, r) for t, r in curves])
    x = (grid + offset) / 1e6
    seeds = f"{len(curves)} seed{'s' if len(curves) > 1 else ''}"
    ax.plot(x, ys.mean(axis=0), color=color, label=f"{label} ({seeds})")
    ax.fill_between(x, ys.min(axis=0), ys.max(axis=0), color=color, alpha=0.2)
    return True


def _no_curve(results: dict, cell: str) -> str:
    """Why a panel is empty: the cell has not run, or its runs' curves were lost."""
    if not finished(results, cell):
        return "not run yet"
    return "evaluated (see the table), but the\ncurves were lost; they train again"


def figure_algorithms(results: dict, runs_dir: Path, figures: Path) -> Path | None:
    path = figures / "training_env1_algorithms.png"
    if not any(finished(results, cell) for cell in ALGORITHMS):
        path.unlink(missing_ok=True)  # no stale figure beside the page
        return None
    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 2, sharey=True)
    for ax, (cell, name), color in zip(
        axes.flat, ALGORITHMS.items(), ("tab:blue", "tab:orange", "tab:green", "tab:red")
    ):
        plot_band(ax, runs_dir, cell, finished(results, cell), name, color)
        ax.set_title(f"{name}, Env1, position action", fontsize=9)
        ax.set_xlabel("env steps (millions)")
        ax.set_ylabel("training episode reward")
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8, loc="lower right")
        else:
            ax.text(0.5, 0.5, _no_curve(results, cell), ha="center", transform=ax.transAxes)
    fig.suptitle("Env1 (ToolPush-v0): mean over seeds, band = the seeds' range", fontsize=10)
    fig.tight_layout()
    return atomic_write_figure(path, fig)


def figure_pair(results: dict, runs_dir: Path, figures: Path, pairs, title: str, name: str):
    path = figures / f"{name}.png"
    if not any(finished(results, cell) for cell, *_ in pairs):
        path.unlink(missing_ok=True)  # no stale figure beside the page
        return None
    fig = Figure(figsize=(6.5, 4))
    ax = fig.subplots()
    missing = []
    for cell, label, color, offset in pairs:
        if not plot_band(ax, runs_dir, cell, finished(results, cell), label, color, offset):
            missing.append(f"{label}: {_no_curve(results, cell)}".replace("\n", " "))
    ax.set_xlabel("env steps (millions)")
    ax.set_ylabel("training episode reward")
    ax.grid(alpha=0.3)
    if missing:
        ax.text(0.5, 0.5, "\n".join(missing), ha="center", fontsize=8, transform=ax.transAxes)
    if ax.lines:
        ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return atomic_write_figure(path, fig)


def figure_trajectories(results: dict, runs_dir: Path, figures: Path, n: int) -> Path | None:
    """N tool-tip paths per algorithm (its first finished seed's best policy) and their mean."""
    seeds = {  # each algorithm's first finished seed whose best policy is here
        cell: min(have)
        for cell in ALGORITHMS
        if (
            have := [
                s
                for s in finished(results, cell)
                if (run_dir(runs_dir, cell, s) / "best" / "policy.json").is_file()
            ]
        )
    }
    cells = list(seeds)
    if not cells:
        (figures / "training_env1_trajectories.png").unlink(missing_ok=True)
        return None
    fig = Figure(figsize=(5 * len(cells), 4.5))
    for i, cell in enumerate(cells):
        seed = seeds[cell]
        tips = record_episodes(run_dir(runs_dir, cell, seed) / "best", n, seed=1000)[0]
        ax = fig.add_subplot(1, len(cells), i + 1, projection="3d")
        for p in tips:
            ax.plot(p[:, 0], p[:, 1], p[:, 2], color="tab:blue", alpha=0.35, lw=0.8)
        m = tips.mean(axis=0)
        ax.plot(m[:, 0], m[:, 1], m[:, 2], color="tab:red", lw=2.5, label="mean")
        ax.set_title(f"{ALGORITHMS[cell]} (seed {seed}): {n} episodes", fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        ax.legend(fontsize=7)
    fig.suptitle("Generated tool-tip trajectories, Env1, evaluation seeds 1000+", fontsize=10)
    fig.tight_layout()
    return atomic_write_figure(figures / "training_env1_trajectories.png", fig)


def orientation_drift(std: float, steps: int, episodes: int = 2000) -> float:
    """Mean tilt (rad) of the tool after `steps` steps of the paper's action with Gaussian
    exploration noise of `std` on it (the mean action zero, clipped to [-1, 1] as actions are),
    each step applied by the env's own `systems.tip_target.apply_action`: the quaternion change
    is added to the current quaternion and normalized, so the orientation random-walks with
    nothing pulling it back."""
    rng = np.random.default_rng(0)
    workspace = Workspace(np.full(3, -np.inf), np.full(3, np.inf))  # position: irrelevant here
    start = np.concatenate([np.zeros(3), RollPitchYaw(TOOL_DOWN_RPY).ToQuaternion().wxyz()])
    targets = np.tile(start, (episodes, 1))
    for _ in range(steps):
        noise = np.clip(rng.normal(0.0, std, (episodes, 4)), -1.0, 1.0)
        for target, quaternion_change in zip(targets, noise):
            action = np.concatenate([np.zeros(3), quaternion_change])
            target[:] = apply_action(target, action, "position_quaternion", workspace)

    def axis(quaternion):  # the tool's axis (z of the tip frame), as a copy
        return np.array(RotationMatrix(Quaternion(quaternion)).matrix())[:, 2]

    z0 = axis(start[3:])
    return float(np.mean([np.arccos(np.clip(axis(t[3:]) @ z0, -1.0, 1.0)) for t in targets]))


def _brief(results: dict, cell: str) -> str | None:
    done = finished(results, cell)
    if not done:
        return None
    st = cell_stats(results, cell)
    d, s = st["distance_cm"], st["success_pct"]
    return (
        f"{_ci(d, 'mean', 2)} cm and {_ci(s, 'mean', 0)} % success over "
        f"{len(done)} seed{'s' if len(done) > 1 else ''}"
    )


def _at_limit_brief(results: dict, cell: str) -> str | None:
    st = cell_stats(results, cell, "evaluate_best_time_limit")
    if st is None:
        return None
    d, s = st["distance_cm"], st["success_pct"]
    return f"{_ci(d, 'mean', 2)} cm, {_ci(s, 'mean', 0)} % at the goal at the limit"


def budget_note(results: dict, cells: dict, cell: str, name: str) -> str | None:
    """For a cell trained below the paper's 1.25 M steps: how far, and why, in this machine's
    own measured speed (its finished runs)."""
    if cell not in cells:
        return None
    steps = cells[cell]["timesteps"]
    if steps >= PAPER_STEPS:
        return None
    rates = [e["train"]["steps_per_s"] for e in finished(results, cell).values() if "train" in e]
    speed = (
        f"it trained at {np.mean(rates):.0f} steps/s here ({steps / np.mean(rates) / 60:.0f} min "
        f"per run; the paper's 1.25 M would take ~{PAPER_STEPS / np.mean(rates) / 3600:.1f} h "
        "per seed)"
        if rates
        else "its speed here is not measured yet (no run has finished)"
    )
    return (
        f"{name}'s runs are {steps:,} steps, not the paper's {PAPER_STEPS / 1e6:.2f} M, as far "
        f"as this 2-core machine allows: one gradient step per env step makes it the slowest "
        f"per step; {speed}."
    )


def discussion(results: dict, cells: dict) -> str:
    """What the table shows, each figure computed here from the results."""
    steps = 50
    wide, narrow = orientation_drift(1.0, steps), orientation_drift(float(np.exp(-1)), steps)
    paper = _brief(results, "ppo_env1_paper") or "— (not run yet)"
    control = _brief(results, "ppo_env1_paper_std1") or "— (not run yet)"
    algorithms = "; ".join(
        f"{name} {_brief(results, cell)}" if finished(results, cell) else f"{name}: not run yet"
        for cell, name in ALGORITHMS.items()
    )
    short = [budget_note(results, cells, cell, name) for cell, name in ALGORITHMS.items()]
    short = " ".join(note for note in short if note)
    cells = {**ALGORITHMS, "ppo_env1_paper": "PPO with the paper's action"}
    briefs = [f"{name} {_at_limit_brief(results, c)}" for c, name in cells.items()]
    briefs = [b for b, c in zip(briefs, cells) if _at_limit_brief(results, c)]
    at_limit = (
        f"the same policies give {'; '.join(briefs)} (the paper's PPO: 7.74 cm)"
        if briefs
        else "no cell has all its seeds evaluated so yet"
    )
    return f"""## What it shows

**The paper's 7-d action (tip position change + quaternion change) learns the task once the
exploration noise on it is smaller.** The action moves the target from where the tip is now,
so Gaussian exploration noise on the quaternion change random-walks the tool's orientation with
nothing pulling it back: with SB3's default initial noise (std 1) the tool tilts
{np.degrees(wide):.0f}° on average after {steps} steps (an episode is at most
{MAX_EPISODE_STEPS}), with std e⁻¹ ≈ 0.37 {np.degrees(narrow):.0f}° (`orientation_drift` in
`drake_tooluse/experiments/paper_study_report.py`: the action's own arithmetic, no
simulation). A tilted tool meets the box with its side or misses it, and PPO has to learn to
cancel the noise in four dimensions before it can learn the push. `log_std_init = -1` — the one change, chosen on seed 0
at 300k steps; the action's meaning, scale and normalisation are the paper's — gives {paper};
the same training with std 1: {control}. The goal: ≤ 4 cm and ≥ 80 % over ≥ 3 seeds within
1.25 M steps, on seeds it was not tuned on.

**The four algorithms on Env1** (position action; the paper's figures are one run each):
{algorithms}. {short}

**Where our figures and the paper's differ, and why.** Our episodes end at the success
(d(x, x*) + d(x, y) ≤ 5 cm, the paper's criterion), so a successful episode's final box–goal
distance is at most ~2.4 cm by construction (the tip touching the box is ~2.6 cm from its
centre). The paper does not say whether its episodes ended there (Gym's Fetch envs, which
its env followed, run to their step limit); its PPO moved the box 27.3 cm for a final distance
of 7.74 cm, which reads as pushing on. Judged as a protocol without an early end would — each
episode run on to the 100-step limit and measured where the box ends (the column "run on to
the 100-step limit") — {at_limit}. Trained on episodes that stop at the goal, the policies
were never taught to stop there, and push the box on past it.
Both columns are of the same 100 seeded episodes; the paper's figures are one run each at
1.25 M steps in another simulator (MuJoCo, a Fetch-style env with mocap control), so neither
column is a like-for-like comparison.
{env2_paragraph(results)}"""


def env2_paragraph(results: dict) -> str:
    """Env2 (reward −d(box, goal) only), per seed: does the policy push, and with what."""
    done = finished(results, "ppo_env2")
    if not done:
        return ""
    seeds = [
        f"s{s}: {e['evaluate_best']['final_object_to_goal_mean_m'] * 100:.2f} cm, tool "
        f"{e['evaluate_best']['tool_touched_rate'] * 100:.0f} % / gripper "
        f"{e['evaluate_best']['gripper_touched_rate'] * 100:.0f} % of episodes"
        for s, e in sorted(done.items())
    ]
    idle = sum(
        e["evaluate_best"]["tool_touched_rate"] == 0
        and e["evaluate_best"]["gripper_touched_rate"] == 0
        for e in done.values()
    )
    pushers = [e["evaluate_best"] for e in done.values() if e["evaluate_best"]["tool_touched_rate"]]
    with_what = (
        "No seed pushes the box with the tool"
        if not pushers
        else "The seeds that do find the box push it with the tool"
        + (", never the gripper" if all(e["gripper_touched_rate"] == 0 for e in pushers) else "")
    )
    return f"""
**Env2 (reward −d(box, goal) only) learns or not by the seed.** Of {len(done)} seeds
({"; ".join(seeds)}), {idle} never touch the box: its reward stays at −0.20 (the box where it
started) whatever the arm does until something reaches the box, so nothing draws the tool to it
(Env1's tip–box term does). {with_what} (the paper's Env2 policy pushed with the gripper).
"""


HEADER = """# Training: the paper's study at its scale, with statistics

Made by `drake-tooluse study-report --update-docs` from `docs/results/paper_study.json`, which
`drake-tooluse study --update-docs` writes run by run (a re-run picks up every run where it
stopped; it also makes this page again after each run it finishes, so the page is current when
a session ends; committing both is yours). Every run is a `drake-tooluse train` command
(its exact command is in the JSON), on the exact tool-tip IK, with randomized starts (box ±2 cm,
yaw ±0.2 rad, mass and friction ±30 %, the grasp ±1 cm along and ±0.5 cm across the tool), two
env processes, observation and reward normalisation and the hyperparameters of
`drake_tooluse/learning/hyperparams/`. Every figure is `drake-tooluse evaluate` of the run's
best policy (by periodic evaluation) over **100 episodes, seeds 1000–1099**. Statistics: rliable
(Agarwal et al. 2021) over the seeds of a cell, each seed's score its mean over the 100
episodes: mean and interquartile mean (IQM) with 95 % bootstrap confidence intervals over the
seeds ({reps} resamples; with 3 seeds wide, as they should be). The paper's figures are one run
each.

Two protocols, each row saying which it trained and was judged in. **To the limit** (the
paper's, and the envs' default): every episode runs to its 100-step limit and is judged where
the box ends, so a policy must push the box to the goal and hold it there; the `hold_*` cells.
**Early end** (this study's first table): an episode ends at its first success
(`end_at_success`), so a success's distance is at most ~2.4 cm and no policy learned to stop;
its last column judges the same policies to the limit. The paper's figures stand beside the
rows of its protocol only.

```bash
drake-tooluse study --update-docs --status        # what is done and what is missing
drake-tooluse study --update-docs                 # runs what is missing, resuming stopped runs
drake-tooluse study --update-docs --parallel 2    # the same, two runs at a time
drake-tooluse study-report --update-docs          # this page and its figures
drake-tooluse study-report --update-docs --check  # exit 2 if this page is not the results'
drake-tooluse study --out runs/mine               # the same study, all files under runs/mine
```

## The study

{table}
The paper: PPO 7.74 cm, TRPO 11.9 cm, DDPG 35.1 cm, A2C 40.9 cm (final box–goal distance, one
run each at 1.25 M steps, ~7 h on 32 cores).

**Still to run**, in the order the job runs it (each run resumes where it stopped):

{missing}
"""


def training_page(results: dict, cells: dict, files: StudyFiles) -> str:
    """docs/TRAINING.md's text: the table, what is still to run (of the runs' archive), the
    discussion, the figures that exist and the earlier runs."""
    table = study_table(results, cells)
    page = HEADER.format(
        reps=f"{BOOTSTRAP_REPS:,}", table=table, missing=missing_runs(results, cells, files.archive)
    )
    page += "\n" + discussion(results, cells)
    figures = files.figures
    where = Path(os.path.relpath(figures, files.page.parent))
    page += (
        "\n## Figures\n\n"
        + "\n\n".join(
            f"![{caption}]({(where / name).as_posix()})"
            for name, caption in (
                ("training_env1_algorithms.png", "Env1: the four algorithms, seed bands"),
                (
                    "training_env1_paper_action.png",
                    "PPO: the paper's action and the position action",
                ),
                ("training_env3_finetune.png", "Env3: fine-tuned against from scratch"),
                ("training_env1_trajectories.png", "Generated tool-tip trajectories"),
            )
            if (figures / name).is_file()
        )
        + "\n"
    )
    page += "\n" + earlier_runs(files.results.parent / "paper_experiments.json")
    return page


def without_queue(page: str) -> str:
    """The page without its list of runs still to run, which tells the state of the run
    directories of the machine that made it (a run training there is "training now"), not the
    results."""
    start, end = page.find("**Still to run**"), page.find("## What it shows")
    return page[:start] + page[end:] if 0 <= start < end else page


def page_is_current(cells: dict, files: StudyFiles) -> bool:
    """Whether the page is the one the results give (its list of runs still to run aside:
    that is of the machine's run directories); writes nothing."""
    page = training_page(read_results(files.results), cells, files)
    return files.page.is_file() and without_queue(files.page.read_text()) == without_queue(page)


def make_report(cells: dict, files: StudyFiles, trajectories: int = 10) -> dict:
    """Writes the page and its figures from the results and the runs' archive; the files
    written and the study's table."""
    results = read_results(files.results)
    runs_dir, figures = files.archive, files.figures
    written = [
        figure_algorithms(results, runs_dir, figures),
        figure_pair(
            results,
            runs_dir,
            figures,
            [
                ("ppo_env1", "position action", "tab:blue", 0.0),
                ("ppo_env1_paper", "the paper's 7-d action", "tab:purple", 0.0),
            ],
            "PPO on Env1: the paper's action against the position action",
            "training_env1_paper_action",
        ),
        figure_pair(
            results,
            runs_dir,
            figures,
            [
                ("ppo_env3_scratch", "from scratch", "tab:gray", 0.0),
                (
                    "ppo_env3_finetune",
                    "fine-tuned from Env1 (after its 1.25 M)",
                    "tab:green",
                    cells.get("ppo_env1", {}).get("timesteps", PAPER_STEPS),
                ),
            ],
            "Env3 (ToolPushFar-v0): fine-tuned from Env1 against from scratch",
            "training_env3_finetune",
        ),
        figure_trajectories(results, runs_dir, figures, trajectories),
    ]
    atomic_write_text(files.page, training_page(results, cells, files))
    return {
        "page": str(files.page),
        "figures": [str(f) for f in written if f is not None],
        "table": study_table(results, cells),
    }
