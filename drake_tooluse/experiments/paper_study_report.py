"""docs/TRAINING.md and its figures (`drake-tooluse study-report`), made from the paper study's
results (`experiments.paper_study`: docs/results/paper_study.json) and its runs' archived files
(docs/results/paper_study/: the training curves and best policies).

Every figure judges a run's best policy in the paper's protocol: each of 100 seeded episodes
runs to its 100-step limit and is judged where the box ends (the evaluation
`evaluate_best_time_limit`). Statistics are rliable's (Agarwal et al. 2021) over the seeds of a
cell, each seed's score its mean over the episodes: the interquartile mean (IQM) and the mean
of the final box–goal distance and the mean success rate, each with a 95 % bootstrap
confidence interval (2,000 resamples of the seeds, seeded: the page is the same every time it
is made). Each cell stands beside the paper's figure for its algorithm. Figures: each cell's
training reward with its seeds' band, and N generated tool-tip trajectories per cell with their
mean (the paper's 3-D figure). The study's costs are its runs' wall times (their summary.json,
which the results hold).
"""

from __future__ import annotations

import csv
import json
import math
import os
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_tooluse.experiments.paper_study import (
    REPLAY_BUFFER,
    order,
    read_results,
    run_dir,
    run_state,
)
from drake_tooluse.experiments.paper_study_cells import StudyFiles
from drake_tooluse.experiments.trajectory_extraction import record_episodes
from drake_tooluse.files import atomic_write_figure, atomic_write_text
from drake_tooluse.tasks.push.registration import MAX_EPISODE_STEPS
from drake_tooluse.validation import EnvironmentProblem

# The paper's final box–goal distance (cm, mean of 100 episodes of one run) per algorithm. Its
# PPO acted with the 7-d action, so its figure stands beside every PPO cell.
PAPER_CM = {"ppo": 7.74, "trpo": 11.9, "ddpg": 35.1, "a2c": 40.9}
PAPER_STEPS = 1_250_000  # the paper's budget per algorithm
PAPER_CPU_HOURS = 7 * 32  # per algorithm: ~7 h on 32 cores
# The reference machine's cores: the runs record wall time, not CPU time, and each keeps both
# busy (two env processes and the learner).
MACHINE_CORES = 2
EVALUATION = "evaluate_best_time_limit"  # the paper's protocol (`paper_study.EVALUATIONS`)
BOOTSTRAP_REPS = 2000
# Cell -> the commit its runs were trained at, for runs trained before `train` recorded its
# commit (summary.json "code"): the -v1 study's first job ran from a clean checkout of it, made
# a second before its first run and not moved since (every cell it trained: its processes ran
# with PYTHONPATH on that checkout).
TRAINED_AT = dict.fromkeys(("v1_ppo", "v1_ppo_paper_action", "v1_trpo", "v1_a2c"), "7de66a6")
# Where the earlier study (the -v0 envs, both protocols, Env2, Env3) and its page stay.
EARLIER = "tag `figures-v0` (commit ef1f4b4)"
COLORS = ("tab:blue", "tab:purple", "tab:orange", "tab:green", "tab:red", "tab:brown")


def finished(results: dict, cell: str) -> dict:
    """seed → entry of the cell's runs evaluated in the paper's protocol."""
    seeds = results.get(cell, {}).get("seeds", {})
    return {int(s): e for s, e in seeds.items() if EVALUATION in e}


def interval_estimates(entries: dict, evaluation: str = EVALUATION) -> dict:
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


def cell_stats(results: dict, cell: str) -> dict | None:
    """`interval_estimates` of a cell's finished seeds, computed once (a bootstrap's resamples
    are drawn again on every call); None if none is finished."""
    done = finished(results, cell)
    if not done:
        return None
    # The evaluations themselves are the key: two results files never share statistics.
    key = (cell, json.dumps([done[s][EVALUATION]["per_episode"] for s in sorted(done)]))
    if key not in _STATS:
        _STATS[key] = interval_estimates(done)
    return _STATS[key]


def _ci(d: dict, key: str, digits: int) -> str:
    if d[key + "_ci"] is None:
        return f"{d[key]:.{digits}f} [one seed: no CI]"
    lo, hi = d[key + "_ci"]
    return f"{d[key]:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def label(spec: dict) -> str:
    """The cell's algorithm and action, as the page names them."""
    mode = spec.get("hyperparams", {}).get("env_kwargs", {}).get("action_mode")
    action = "the paper's 7-d action" if mode == "position_quaternion" else "position"
    return f"{spec['algo'].upper()}, {action}"


def paper_figure(spec: dict) -> float | None:
    """The paper's figure (cm) that the cell stands beside: its algorithm's."""
    return PAPER_CM.get(spec["algo"])


def against_paper(stats: dict, paper: float) -> str:
    """Where the paper's figure lies against the CI of the cell's mean distance."""
    ci = stats["distance_cm"]["mean_ci"]
    if ci is None:
        return "one seed: no CI"
    if paper > ci[1]:
        return "lower: the CI's upper end is below it"
    if paper < ci[0]:
        return "higher: the CI's lower end is above it"
    return "the CI holds it"


def study_table(results: dict, cells: dict) -> str:
    lines = [
        "| cell | algorithm, action | seeds done | final box–goal IQM (cm) [95 % CI] | "
        "mean (cm) [95 % CI] | success (%) [95 % CI] | per seed: mean cm / success | "
        "the paper (cm, 1 run) | ours against the paper's |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for cell, c in cells.items():
        done, paper = finished(results, cell), paper_figure(c)
        head = f"| {cell} | {label(c)} | {len(done)} of {len(c['seeds'])} |"
        shown = "" if paper is None else f"{paper}"
        if not done:
            lines.append(head + f" | | | | {shown} | |")
            continue
        stats = cell_stats(results, cell)
        per_seed = ", ".join(
            f"s{s}: {e[EVALUATION]['final_object_to_goal_mean_m'] * 100:.2f} / "
            f"{e[EVALUATION]['success_rate'] * 100:.0f} %"
            for s, e in sorted(done.items())
        )
        verdict = "" if paper is None else against_paper(stats, paper)
        lines.append(
            head
            + f" {_ci(stats['distance_cm'], 'iqm', 2)} | {_ci(stats['distance_cm'], 'mean', 2)}"
            f" | {_ci(stats['success_pct'], 'mean', 0)} | {per_seed} | {shown} | {verdict} |"
        )
    return "\n".join(lines) + "\n"


def _settings(cells: dict) -> str:
    """Each cell's settings over the hyperparameter files', and its budget where it is not the
    paper's."""
    notes = [
        f"`{cell}`: {json.dumps(c['hyperparams'])}"
        for cell, c in cells.items()
        if "hyperparams" in c
    ]
    notes += [
        f"`{cell}` trains {c['timesteps']:,} steps, not the paper's {PAPER_STEPS:,} (its "
        "comment in the study file says why)"
        for cell, c in cells.items()
        if c["timesteps"] != PAPER_STEPS
    ]
    return "".join(f"- {n}\n" for n in notes)


def _rate(results: dict, cells) -> float | None:
    """Mean training speed (steps/s) of the finished runs of `cells`; None without any."""
    rates = [e["train"]["steps_per_s"] for c in cells for e in finished(results, c).values()]
    return float(np.mean(rates)) if rates else None


def missing_runs(results: dict, cells: dict, runs_dir: Path) -> str:
    """What is still to run, in the order the job runs it (the runner's `order`), and about
    how long each run takes here (its cell's finished runs, else the study's: not for an
    algorithm with a replay buffer, a gradient step per env step makes it several times slower),
    so that the rest can be planned."""
    queue = [(cell, seed) for cell, c in cells.items() for seed in c["seeds"]]
    lines, minutes = [], []
    for cell, seed in order(cells, queue, runs_dir, results):
        state = run_state(cells, runs_dir, runs_dir, results, cell, seed)
        if state.startswith("done"):
            continue
        own = _rate(results, [cell])
        study = _rate(results, cells) if cells[cell]["algo"] not in REPLAY_BUFFER else None
        took = "; no estimate yet (none of its runs has finished)"
        if own or study:
            minutes.append(cells[cell]["timesteps"] / (own or study) / 60)
            took = f"; ~{minutes[-1]:.0f} min here" + ("" if own else " (at the study's rate)")
        lines.append(f"- `{cell}` seed {seed}: {state}{took}")
    if not lines:
        return "Every cell has all its seeds.\n"
    total = ""
    if minutes:
        unknown = len(lines) - len(minutes)
        total = f"\nAbout {sum(minutes) / 60:.1f} h in all, one run at a time" + (
            f", besides the {unknown} run{'s' if unknown > 1 else ''} with no estimate.\n"
            if unknown
            else ".\n"
        )
    return "\n".join(lines) + "\n" + total


def costs(results: dict, cells: dict) -> str:
    """Wall time per run and CPU hours, per cell and in all, from the runs' summaries."""
    lines = [
        "| cell | runs done | steps per run | wall per run (min) | steps/s | CPU hours |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    walls = []
    for cell in cells:
        done = finished(results, cell)
        if not done:
            continue
        train = {s: e["train"] for s, e in sorted(done.items())}
        wall = [t["wall_time_s"] for t in train.values()]
        walls += wall
        per_run = ", ".join(f"s{s}: {t['wall_time_s'] / 60:.0f}" for s, t in train.items())
        steps = int(np.mean([t["timesteps"] for t in train.values()]))
        lines.append(
            f"| {cell} | {len(done)} | {steps:,} | {per_run} | "
            f"{np.mean([t['steps_per_s'] for t in train.values()]):.0f} | "
            f"{sum(wall) * MACHINE_CORES / 3600:.1f} |"
        )
    if not walls:
        return "No run has finished yet.\n"
    total = (
        f"In all: {len(walls)} runs, {sum(walls) / 3600:.1f} h of wall time, "
        f"{sum(walls) * MACHINE_CORES / 3600:.1f} CPU hours on this {MACHINE_CORES}-core machine "
        f"(wall time × {MACHINE_CORES} cores: a run records its wall time, not its CPU time, "
        "and keeps both cores busy with its two env processes and its learner). The paper: ~7 h "
        f"on 32 cores per algorithm, ~{PAPER_CPU_HOURS} CPU hours."
    )
    return "\n".join(lines) + "\n\n" + textwrap.fill(total, 100) + "\n"


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


def plot_band(ax, runs_dir: Path, cell: str, seeds, label: str, color: str) -> bool:
    """The finished seeds' mean training reward and their range (the band), on a common
    grid; whether there was a curve to draw."""
    curves = [_curve(run_dir(runs_dir, cell, s)) for s in seeds]
    curves = [c for c in curves if c is not None and len(c[0]) > 1]
    if not curves:
        return False
    end = min(c[0][-1] for c in curves)
    grid = np.linspace(max(c[0][0] for c in curves), end, 200)
    ys = np.array([np.interp(grid, t, r) for t, r in curves])
    x = grid / 1e6
    seeds = f"{len(curves)} seed{'s' if len(curves) > 1 else ''}"
    ax.plot(x, ys.mean(axis=0), color=color, label=f"{label} ({seeds})")
    ax.fill_between(x, ys.min(axis=0), ys.max(axis=0), color=color, alpha=0.2)
    return True


def _no_curve(results: dict, cell: str) -> str:
    """Why a panel is empty: the cell has not run, or its runs' curves were lost."""
    if not finished(results, cell):
        return "not run yet"
    return "evaluated (see the table), but the\ncurves were lost; they train again"


def figure_curves(results: dict, cells: dict, runs_dir: Path, figures: Path) -> Path | None:
    """One panel per cell: its seeds' training reward, mean and band (the paper's four-panel
    figure)."""
    path = figures / "training_curves.png"
    if not any(finished(results, cell) for cell in cells):
        path.unlink(missing_ok=True)  # no stale figure beside the page
        return None
    columns = 2 if len(cells) <= 4 else 3
    rows = math.ceil(len(cells) / columns)
    fig = Figure(figsize=(5 * columns, 3.5 * rows))
    axes = list(fig.subplots(rows, columns, sharex=True, sharey=True, squeeze=False).flat)
    for ax, (cell, c), color in zip(axes, cells.items(), COLORS * len(cells)):
        plot_band(ax, runs_dir, cell, finished(results, cell), cell, color)
        ax.set_title(f"{cell}: {label(c)}", fontsize=9)
        ax.set_xlabel("env steps (millions)")
        ax.set_ylabel("training episode reward")
        ax.tick_params(labelbottom=True)  # a shared axis labels only the last row's
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8, loc="lower right")
        else:
            ax.text(0.5, 0.5, _no_curve(results, cell), ha="center", transform=ax.transAxes)
    for ax in axes[len(cells) :]:  # the grid's panels left over
        ax.set_visible(False)
    envs = ", ".join(sorted({c["env"].split("/")[-1] for c in cells.values()}))
    fig.suptitle(f"{envs}: mean over seeds, band = the seeds' range", fontsize=10)
    fig.tight_layout()
    return atomic_write_figure(path, fig)


def figure_trajectories(
    results: dict, cells: dict, runs_dir: Path, figures: Path, n: int
) -> Path | None:
    """N tool-tip paths per cell (its first finished seed's best policy) and their mean."""
    path = figures / "training_trajectories.png"
    seeds = {  # each cell's first finished seed whose best policy is here
        cell: min(have)
        for cell in cells
        if (
            have := [
                s
                for s in finished(results, cell)
                if (run_dir(runs_dir, cell, s) / "best" / "policy.json").is_file()
            ]
        )
    }
    if not seeds:
        path.unlink(missing_ok=True)
        return None
    fig = Figure(figsize=(5 * len(seeds), 4.5))
    for i, (cell, seed) in enumerate(seeds.items()):
        tips = record_episodes(run_dir(runs_dir, cell, seed) / "best", n, seed=1000)[0]
        ax = fig.add_subplot(1, len(seeds), i + 1, projection="3d")
        for p in tips:
            ax.plot(p[:, 0], p[:, 1], p[:, 2], color="tab:blue", alpha=0.35, lw=0.8)
        m = tips.mean(axis=0)
        ax.plot(m[:, 0], m[:, 1], m[:, 2], color="tab:red", lw=2.5, label="mean")
        ax.set_title(f"{cell} (seed {seed}): {n} episodes", fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        ax.legend(fontsize=7)
    fig.suptitle("Generated tool-tip trajectories, evaluation seeds 1000+", fontsize=10)
    fig.tight_layout()
    return atomic_write_figure(path, fig)


FIGURES = (
    ("training_curves.png", "Training reward per cell, seed bands"),
    ("training_trajectories.png", "Generated tool-tip trajectories"),
)

HEADER = """# Training: the paper's study on the `-v1` envs, with statistics

Made by `drake-tooluse study-report --update-docs` from `docs/results/paper_study.json`, which
`drake-tooluse study --update-docs` writes run by run (a re-run picks up every run where it
stopped; it also makes this page again after each run it finishes; committing both is yours).
The cells are `drake_tooluse/experiments/paper_study.yaml`'s. The earlier study, on the `-v0`
envs (both protocols, Env2, Env3 fine-tuning, DDPG at 300k steps), and its tables stay at
{earlier}: its docs/TRAINING.md.

- **Env:** {envs}.
{protocol}
{commit}
- **Runs:** each a `drake-tooluse train` command (its exact command is in the JSON), on the
  exact tool-tip IK, with randomized starts (box ±2 cm, yaw ±0.2 rad, mass and friction ±30 %,
  the grasp ±1 cm along and ±0.5 cm across the tool), two env processes, observation and reward
  normalisation and the hyperparameters of `drake_tooluse/learning/hyperparams/`.
- **Figures:** `drake-tooluse evaluate --to-time-limit` of each run's best policy (by periodic
  evaluation) over **100 episodes, seeds 1000–1099**. Statistics: rliable (Agarwal et al. 2021)
  over the seeds of a cell, each seed's score its mean over the 100 episodes: interquartile mean
  (IQM) and mean with 95 % bootstrap confidence intervals over the seeds ({reps} resamples; with
  3 seeds the IQM is the mean and the intervals are wide, as they should be).

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
The paper: PPO 7.74 cm, TRPO 11.9 cm, DDPG 35.1 cm, A2C 40.9 cm (final box–goal distance, mean
of 100 episodes of one run each at 1.25 M steps, ~7 h on 32 cores, in MuJoCo with a Fetch-style
env and mocap control: beside ours, not like for like). Its PPO acted with the 7-d action; its
figure stands beside both PPO cells. "Ours against the paper's" places the paper's figure
against the CI of our mean.

{settings}
**Still to run**, in the order the job runs it (each run resumes where it stopped):

{missing}
## Figures

{figures}

## The study's costs

Each run's wall time over all its sessions (its summary.json, which the results hold), on this
machine (2 cores, shared with other work: a run's wall time moves with what runs beside it).

{costs}"""


def _protocol() -> str:
    """The page's protocol bullet: the paper's, the -v1 envs' only one."""
    text = (
        f"- **Protocol:** the paper's. Every episode runs to its {MAX_EPISODE_STEPS}-step limit "
        "and is judged where the box ends, in training and in every figure here: a policy must "
        "push the box to the goal and hold it there."
    )
    return textwrap.fill(text, 100, subsequent_indent="  ")


def _recorded_commits(results: dict, cell: str) -> list[str]:
    """The commits a cell's finished runs record (`train`'s summary.json "code"; a checkout
    with changes marked "+changes"), in seed order, without repeats."""
    commits = []
    for entry in finished(results, cell).values():
        code = (entry.get("train") or {}).get("code") or {}
        if code.get("commit"):
            text = code["commit"][:7] + (" +changes" if code.get("modified") else "")
            if text not in commits:
                commits.append(text)
    return commits


def _commit(results: dict, cells: dict) -> str:
    """The page's commit bullet: what each cell with finished runs was trained at, as its runs
    record it, else as TRAINED_AT knows it."""
    done = [cell for cell in cells if finished(results, cell)]
    recorded = {c: _recorded_commits(results, c) for c in done}
    parts = [f"`{c}` at {', '.join(f'`{x}`' for x in recorded[c])}" for c in done if recorded[c]]
    known = [f"`{c}` at `{TRAINED_AT[c]}`" for c in done if not recorded[c] and c in TRAINED_AT]
    unknown = [f"`{c}`" for c in done if not recorded[c] and c not in TRAINED_AT]
    text = "- **Commit:**"
    if parts:
        text += f" as the runs record it (`train`'s summary.json): {', '.join(parts)}."
    if known:
        text += (
            f" Runs that record none, known by the job that trained them: {', '.join(known)} "
            "(it ran from a clean checkout of that commit, made a second before its first run "
            "and not moved since)."
        )
    if unknown:
        text += f" Not known for {', '.join(unknown)}."
    return textwrap.fill(text, 100, subsequent_indent="  ")


def training_page(results: dict, cells: dict, files: StudyFiles) -> str:
    """docs/TRAINING.md's text: the setting, the table, what is still to run (of the runs'
    archive), the figures that exist and the costs."""
    where = Path(os.path.relpath(files.figures, files.page.parent))
    figures = "\n\n".join(
        f"![{caption}]({(where / name).as_posix()})"
        for name, caption in FIGURES
        if (files.figures / name).is_file()
    )
    settings = _settings(cells)
    return HEADER.format(
        earlier=EARLIER,
        envs=", ".join(f"`{e}`" for e in dict.fromkeys(c["env"] for c in cells.values())),
        protocol=_protocol(),
        commit=_commit(results, cells),
        reps=f"{BOOTSTRAP_REPS:,}",
        table=study_table(results, cells),
        settings=f"Settings over the hyperparameter files':\n\n{settings}" if settings else "",
        missing=missing_runs(results, cells, files.archive),
        figures=figures or "No cell has finished runs yet.",
        costs=costs(results, cells),
    )


def without_queue(page: str) -> str:
    """The page without its list of runs still to run, which tells the state of the run
    directories of the machine that made it (a run training there is "training now"), not the
    results."""
    start = page.find("**Still to run**")
    end = page.find("\n## ", start)
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
    written = [
        figure_curves(results, cells, files.archive, files.figures),
        figure_trajectories(results, cells, files.archive, files.figures, trajectories),
    ]
    atomic_write_text(files.page, training_page(results, cells, files))
    return {
        "page": str(files.page),
        "figures": [str(f) for f in written if f is not None],
        "table": study_table(results, cells),
    }
