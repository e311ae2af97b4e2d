"""The paper's study at its scale, several seeds per cell, as a job that survives the machine:
each run is a `drake-tooluse train` command (continued with `train --resume` when a run was
stopped), its best policy evaluated with `drake-tooluse evaluate` over 100 seeded episodes (seeds
1000-1099) twice: in the cell's protocol, and run on to the 100-step limit (`--to-time-limit`:
where the box ends, the paper's protocol). Two protocols: the first study's cells trained and
were judged with an early end at success (`end_at_success`); the `hold_*` cells train and are
judged in the paper's, every episode to its limit (the envs' default), so a policy learns to
push the box to the goal and hold it there.

    python benchmarks/paper_experiments.py [--runs-dir runs/paper] [--only CELL ...]
                                           [--seeds N ...] [--parallel N] [--commit] [--status]

Re-running it picks up every run where it stopped: a finished run is not trained again, a
stopped one resumes from its last checkpoint, a failed one is recorded (its error) and the job
goes on. The run directories (runs/paper, not in git) do not outlive the machine, so each run's
small files are archived in the repo, docs/results/paper_study/CELL/sSEED/ (`archive_run`:
config, summary, best policy, progress.csv, evaluations; while it trains, every ARCHIVE_EVERY
its latest checkpoint too, unless a replay buffer makes it over ARCHIVE_MAX_CHECKPOINT: DDPG's
starts over on a new machine) and, with `--commit`, committed; a new checkout restores them
into the run directories before anything runs. A run evaluated in the results whose files are
in neither place (trained before the archive existed) is trained again after every run still
missing (but right before a missing fine-tuning that starts from it), so that its curve and
policy exist for the figures and the runs that start from it; if that retraining fails, its
evaluation stays (with the error) and the next job tries again.
Results are written atomically to docs/results/paper_study.json after every run; with
`--commit` each is also committed (that file, and the run's archive). After each run that
finished in this job the report is regenerated (`python benchmarks/paper_report.py`:
docs/TRAINING.md's tables and figures, needs the `bench` extra's rliable; a report that fails is
logged and the job goes on) and, with `--commit`, committed (the page and its figures), so the
page is current whenever a session ends. `--status` prints what is done, what is missing
and the measured time per run. `--parallel N` runs N at a time (a fine-tuning waits while the
run it starts from is still to run or running): it gains where one run leaves cores idle
(DDPG's training is one process; PPO's, TRPO's and A2C's learner and its two env processes
wait for each other). Runs that share the cores, with each other or with a report being
made, record a lower steps/s and a longer wall time than a run alone.

Cells, cheapest evidence first (the order they run in, but for DDPG's: a run whose replay
buffer makes its checkpoint too big to archive goes first, to finish within the job):
  hold_ppo_env1_paper, hold_ppo_env1, hold_trpo_env1, hold_a2c_env1
                     the paper's protocol (to the step limit): the paper's 7-d action (3 seeds,
                     500k steps), then PPO, TRPO and A2C at the paper's 1.25 M steps
the first study, in the early-end protocol:
  ppo_env1_paper     PPO, Env1, the paper's 7-d action (tip position + quaternion change) and
                     observation, exploration noise std e^-1 (log_std_init -1); tuned on seed 0
                     at 300k steps, run on seeds 1-3
  ppo_env1_paper_std1  the same with SB3's default noise (std 1), seed 1: the control
  ppo_env1           PPO, Env1, position action, 1.25 M steps
  trpo_env1, a2c_env1   TRPO and A2C, the same
  ppo_env2           PPO, Env2 (reward -d(box, goal) only): does it learn to use the tool?
  ppo_env3_finetune  PPO, Env3 (goal 0.10 m further), 225k steps from ppo_env1's best policy
  ppo_env3_scratch   PPO, Env3 from scratch, 1.475 M steps (the fine-tuning's total)
  ddpg_env1          DDPG, Env1, position action: one gradient step per env step makes it ~5x
                     slower per step on this machine, so 300k steps
"""

import argparse
import json
import re
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from pathlib import Path

from drake_tooluse.cli.common import run_script
from drake_tooluse.tasks.push.env import current_kwargs
from drake_tooluse.files import atomic_dir, atomic_write_json, lock_holder, run_lock

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results" / "paper_study.json"
ARCHIVE = ROOT / "docs" / "results" / "paper_study"  # each run's small files: CELL/sSEED/
# What of a run directory is archived (TensorBoard's events and `final/` are not: the report
# needs none of them, and a resume rewrites the events).
ARCHIVED = ("config.json", "summary.json", "best", "logs/progress.csv", "eval/evaluations.npz")
ARCHIVE_EVERY = 20 * 60  # s between two archives of a run that is training
ARCHIVE_MAX_CHECKPOINT = 4 << 20  # bytes: PPO's, TRPO's and A2C's are ~1 MB, DDPG's ~100 MB
REPORT = ROOT / "docs" / "TRAINING.md"
FIGURES = ROOT / "docs" / "figures"  # the report's figures: training_*.png
ENV1, ENV2, ENV3 = (
    "drake_tooluse/ToolPush-v0",
    "drake_tooluse/ToolPushBoxReward-v0",
    "drake_tooluse/ToolPushFar-v0",
)
PAPER_ACTION = {
    "env_kwargs": {"action_mode": "position_quaternion", "randomize": True},
    "policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0},
}
PAPER_STEPS = 1_250_000
# The protocols: "to-limit", the paper's (every episode runs to its 100-step limit and is
# judged where the box ends; the envs' default), and "early-end", the first study's (an
# episode ends at its first success: `end_at_success`). A cell without one is "early-end".
EARLY_END = {"end_at_success": True}
CELLS = {
    # The paper's protocol, cheapest evidence first: the paper's 7-d action, then PPO at the
    # paper's budget, then TRPO and A2C.
    "hold_ppo_env1_paper": dict(
        env=ENV1,
        algo="ppo",
        timesteps=500_000,
        seeds=(1, 2, 3),
        hyperparams=PAPER_ACTION,
        protocol="to-limit",
    ),
    "hold_ppo_env1": dict(
        env=ENV1, algo="ppo", timesteps=PAPER_STEPS, seeds=(0, 1, 2, 3, 4), protocol="to-limit"
    ),
    "hold_trpo_env1": dict(
        env=ENV1, algo="trpo", timesteps=PAPER_STEPS, seeds=(0, 1, 2), protocol="to-limit"
    ),
    "hold_a2c_env1": dict(
        env=ENV1, algo="a2c", timesteps=PAPER_STEPS, seeds=(0, 1, 2), protocol="to-limit"
    ),
    # The first study, in the earlier protocol.
    "ppo_env1_paper": dict(
        env=ENV1, algo="ppo", timesteps=500_000, seeds=(1, 2, 3), hyperparams=PAPER_ACTION
    ),
    # The same with SB3's default exploration noise (std 1): the control for the cell above.
    "ppo_env1_paper_std1": dict(
        env=ENV1,
        algo="ppo",
        timesteps=500_000,
        seeds=(1,),
        hyperparams={**PAPER_ACTION, "policy_kwargs": {"net_arch": [128, 128]}},
    ),
    "ppo_env1": dict(env=ENV1, algo="ppo", timesteps=PAPER_STEPS, seeds=(0, 1, 2, 3, 4)),
    "trpo_env1": dict(env=ENV1, algo="trpo", timesteps=PAPER_STEPS, seeds=(0, 1, 2)),
    "a2c_env1": dict(env=ENV1, algo="a2c", timesteps=PAPER_STEPS, seeds=(0, 1, 2)),
    "ppo_env2": dict(env=ENV2, algo="ppo", timesteps=PAPER_STEPS, seeds=(0, 1, 2)),
    "ppo_env3_finetune": dict(
        env=ENV3, algo="ppo", timesteps=225_000, seeds=(0, 1, 2), init_from="ppo_env1"
    ),
    "ppo_env3_scratch": dict(env=ENV3, algo="ppo", timesteps=1_475_000, seeds=(0, 1, 2)),
    "ddpg_env1": dict(env=ENV1, algo="ddpg", timesteps=300_000, seeds=(0, 1, 2)),
}
EPISODES, EVALUATION_SEED = 100, 1000
REPLAY_BUFFER = ("ddpg",)  # algorithms whose checkpoints hold a replay buffer (~100 MB)
# The job's running commands (trainings, evaluations): killed when the job stops on an error,
# so that no run goes on without the job that records it.
_LIVE: set[subprocess.Popen] = set()
_LIVE_LOCK = threading.Lock()
_STOPPING = threading.Event()
_GIT_LOCK = threading.Lock()  # one git command at a time: the runs commit from their threads


def _start(cmd: list[str]) -> subprocess.Popen:
    with _LIVE_LOCK:
        if _STOPPING.is_set():
            raise RuntimeError(f"the job is stopping: {shlex.join(cmd)} not started")
        job = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _LIVE.add(job)
    return job


def _end(job: subprocess.Popen) -> None:
    """Kills `job` if it still runs, and forgets it."""
    if job.poll() is None:
        job.kill()
        job.wait()
    with _LIVE_LOCK:
        _LIVE.discard(job)


def stop_live_commands() -> None:
    """Kills every running command of the job and lets no new one start."""
    with _LIVE_LOCK:
        _STOPPING.set()
        for job in _LIVE:
            if job.poll() is None:
                job.kill()


def _run(cmd: list[str]) -> subprocess.CompletedProcess:
    job = _start(cmd)
    try:
        stdout, stderr = job.communicate()
    finally:
        _end(job)
    return subprocess.CompletedProcess(cmd, job.returncode, stdout, stderr)


def run_dir(runs_dir: Path, cell: str, seed: int) -> Path:
    return runs_dir / cell / f"s{seed}"


def protocol_env_kwargs(cell: str) -> dict:
    """The env kwargs of the cell's protocol (the early end, or none: the envs' default)."""
    return {} if CELLS[cell].get("protocol") == "to-limit" else EARLY_END


def train_command(cell: str, seed: int, runs_dir: Path, resume: bool) -> list[str]:
    c = CELLS[cell]
    out = run_dir(runs_dir, cell, seed)
    cmd = ["drake-tooluse", "train", "--env", c["env"], "--algo", c["algo"]]
    cmd += ["--timesteps", str(c["timesteps"]), "--seed", str(seed), "--no-progress"]
    cmd += ["--resume" if resume else "--out", str(out)]
    if "hyperparams" in c:
        cmd += ["--hyperparams", json.dumps(c["hyperparams"])]
    if protocol_env_kwargs(cell):
        cmd += ["--env-kwargs", json.dumps(protocol_env_kwargs(cell))]
    if "init_from" in c:
        cmd += ["--init-from", str(run_dir(runs_dir, c["init_from"], seed) / "best")]
    return cmd


# Each run's best policy is evaluated twice: in its cell's protocol, and run on to the 100-step
# limit, judged where the box ends (the paper's protocol; the same for a "to-limit" cell).
# result key -> (key of its command, extra arguments)
EVALUATIONS = {
    "evaluate_best": ("evaluate_command", []),
    "evaluate_best_time_limit": ("evaluate_time_limit_command", ["--to-time-limit"]),
}


def evaluate_command(policy: Path, env_id: str, extra=()) -> list[str]:
    return [
        "drake-tooluse",
        "evaluate",
        "--policy",
        str(policy),
        "--env",
        env_id,
        "--episodes",
        str(EPISODES),
        "--seed",
        str(EVALUATION_SEED),
        "--no-progress",
        "--per-episode",
        "--json",
        *extra,
    ]


def _last_line(done: subprocess.CompletedProcess) -> str:
    """A failed command's error: the last line of its stderr (or its exit code)."""
    return (done.stderr.strip().splitlines() or [f"exit code {done.returncode}"])[-1]


def evaluated(entry: dict) -> bool:
    """Whether a run's entry holds every evaluation and no error."""
    return "error" not in entry and all(k in entry for k in EVALUATIONS)


def read_results(path: Path, ap: argparse.ArgumentParser) -> dict:
    """The study's results file ({} if there is none yet); a file that is not a JSON object
    ends the command with a one-line error naming it."""
    if not path.is_file():
        return {}
    try:
        results = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        ap.error(f"{path}: not a readable JSON results file ({e})")
    if not isinstance(results, dict):
        ap.error(
            f"{path}: a results file is a JSON object (cell -> seeds), not {type(results).__name__}"
        )
    return results


def _summary(out: Path) -> dict | None:
    path = out / "summary.json"
    return json.loads(path.read_text()) if path.is_file() else None


def trained(out: Path, timesteps: int) -> bool:
    summary = _summary(out)
    return summary is not None and summary["timesteps"] >= timesteps


def _stamp() -> str:
    return time.strftime("%H:%M:%S")


def _tree_size(path: Path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def archive_run(out: Path, archived: Path) -> bool:
    """Copies the run's latest checkpoint (unless it has finished, and when no larger than
    ARCHIVE_MAX_CHECKPOINT) and then its ARCHIVED files to `archived`, which is replaced whole
    or not at all. The checkpoint goes first so that the logs are never older than it (a resume
    cuts them back to it). False (and `archived` as it was) if the run changed under the copy,
    as a training process moving on to its next checkpoint does: the next archive catches it."""
    try:
        with atomic_dir(archived, replace=True) as work:
            latest = out / "checkpoints" / "latest.json"
            summary = _summary(out)
            if latest.is_file() and (summary is None or summary["timesteps"] < _target(out)):
                pointer = latest.read_text()
                checkpoint = out / "checkpoints" / json.loads(pointer)["checkpoint"]
                if _tree_size(checkpoint) <= ARCHIVE_MAX_CHECKPOINT:
                    shutil.copytree(checkpoint, work / "checkpoints" / checkpoint.name)
                    (work / "checkpoints" / "latest.json").write_text(pointer)
            for name in ARCHIVED:
                if (out / name).is_dir():
                    shutil.copytree(out / name, work / name)
                elif (out / name).is_file():
                    (work / name).parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(out / name, work / name)
        return True
    except (OSError, json.JSONDecodeError, KeyError):
        return False


def _target(out: Path) -> int:
    """The steps the run in `out` was asked for (its config.json)."""
    return int(json.loads((out / "config.json").read_text())["timesteps"])


def restore_runs(runs_dir: Path, archive: Path) -> list[Path]:
    """Copies each archived run that `runs_dir` does not hold into it (a new checkout's runs
    continue from the repo); the runs restored."""
    restored = []
    for archived in sorted(archive.glob("*/s*")):
        if not re.fullmatch(r"s\d+", archived.name):  # not a run's folder: nothing to restore
            continue
        out = run_dir(runs_dir, archived.parent.name, int(archived.name[1:]))
        if archived.is_dir() and (archived / "config.json").is_file() and not out.exists():
            with atomic_dir(out) as work:
                shutil.copytree(archived, work, dirs_exist_ok=True)
            restored.append(out)
    return restored


def train_and_archive(
    cmd: list[str], out: Path, archived: Path, on_archive
) -> subprocess.CompletedProcess:
    """Runs the training command, archiving the run every ARCHIVE_EVERY while it trains
    (`on_archive()` after each) and once when it ends; what it printed and its exit code."""
    job = _start(cmd)
    try:
        while True:
            try:
                stdout, stderr = job.communicate(timeout=ARCHIVE_EVERY)
                break
            except subprocess.TimeoutExpired:  # still training: no output is lost by waiting
                if archive_run(out, archived):
                    on_archive()
    finally:  # the job stopped (a signal, an error): no training goes on without it
        _end(job)
    if (out / "config.json").is_file() and archive_run(out, archived):
        on_archive()
    return subprocess.CompletedProcess(cmd, job.returncode, stdout, stderr)


def settings_differ(out: Path, cell: str, seed: int) -> str | None:
    """How the run in `out` (its config.json) was trained other than the cell asks, or None:
    a cell redefined in this file must not reuse (or resume) runs of its old definition."""
    path = out / "config.json"
    if not path.is_file():
        return None
    saved, c = json.loads(path.read_text()), CELLS[cell]
    differences = [
        f"{key} {saved[key]!r} (the cell: {want!r})"
        for key, want in (("env_id", c["env"]), ("algo", c["algo"]), ("seed", seed))
        if saved[key] != want
    ]
    for key, want in c.get("hyperparams", {}).items():
        have = saved["hyperparams"].get(key)
        if key == "env_kwargs" and isinstance(have, dict):
            # Runs trained before a mode was renamed stored its old name.
            have, want = current_kwargs(have), current_kwargs(want)
        if have != want:
            differences.append(f"{key} {saved['hyperparams'].get(key)!r} (the cell: {want!r})")
    source = saved.get("init_from")
    if "init_from" in c and (
        source is None or Path(source).parts[-3:-1] != (c["init_from"], f"s{seed}")
    ):
        differences.append(f"init_from {source!r} (the cell: {c['init_from']}/s{seed}/best)")
    return "; ".join(differences) or None


def run_one(
    cell: str, seed: int, runs_dir: Path, results: dict, archive: Path, on_archive=lambda: None
) -> dict:
    """Trains (or resumes) one run, archiving it (`archive_run`, then `on_archive()`), and
    evaluates its best policy; a failure is recorded."""
    c = CELLS[cell]
    out = run_dir(runs_dir, cell, seed)
    entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
    differ = settings_differ(out, cell, seed)
    if differ:
        error = f"{out} holds a run trained otherwise: {differ}; move it away to rerun the cell"
        print(f"[{_stamp()}] {cell} seed {seed} skipped: {error}", flush=True)
        return {"error": error}
    source = c.get("init_from")
    if not trained(out, c["timesteps"]):
        # Only a run still to train needs its source: a finished one keeps its results.
        if source and not trained(run_dir(runs_dir, source, seed), CELLS[source]["timesteps"]):
            print(f"[{_stamp()}] {cell} seed {seed} waits for {source} seed {seed}", flush=True)
            return {
                "error": f"waits for {source} seed {seed} to finish (it starts from its policy)"
            }
        cmd = train_command(cell, seed, runs_dir, resume=(out / "config.json").is_file())
        print(f"[{_stamp()}] {cell} seed {seed}: {shlex.join(cmd)}", flush=True)
        done = train_and_archive(cmd, out, run_dir(archive, cell, seed), on_archive)
        if done.returncode != 0:
            error = _last_line(done)
            print(f"[{_stamp()}] {cell} seed {seed} failed: {error}", flush=True)
            return {"train_command": shlex.join(cmd), "error": error}
    elif _summary(run_dir(archive, cell, seed)) != _summary(out) and archive_run(
        out, run_dir(archive, cell, seed)
    ):
        on_archive()  # not archived since it finished (trained before the archive, or killed)
    summary = _summary(out)
    result = {
        "train_command": shlex.join(train_command(cell, seed, runs_dir, resume=False)),
        "train": summary,
    }
    for key, (command_key, extra) in EVALUATIONS.items():
        if entry.get("train") == summary and "per_episode" in entry.get(key, {}):
            result[command_key], result[key] = (
                entry.get(command_key),
                entry[key],
            )  # evaluated already
            continue
        protocol = protocol_env_kwargs(cell) if not extra else {}
        cmd = evaluate_command(out / "best", c["env"], extra)
        if protocol:
            cmd += ["--env-kwargs", json.dumps(protocol)]
        finished = _run(cmd)
        if finished.returncode != 0:
            error = _last_line(finished)
            print(f"[{_stamp()}] {cell} seed {seed} ({key}) failed: {error}", flush=True)
            return {**result, command_key: shlex.join(cmd), "error": error}  # done stays
        e = json.loads(finished.stdout)
        episodes = e.pop("per_episode")  # kept as columns: the statistics resample episodes
        e["per_episode"] = {k: [r[k] for r in episodes] for k in ("final_box_to_goal_m", "success")}
        result[command_key], result[key] = shlex.join(cmd), e
        print(
            f"[{_stamp()}] {cell} seed {seed} ({key}): final box-goal mean "
            f"{e['final_box_to_goal_mean_m'] * 100:.2f} cm, success {e['success_rate'] * 100:.0f}"
            f" %, {summary['timesteps']} steps in {summary['wall_time_s'] / 60:.1f} min",
            flush=True,
        )
    return result


def commit(paths: list[Path], message: str) -> None:
    """Commits `paths` alone (whatever else is staged stays staged); retried on a busy index."""
    with _GIT_LOCK:
        _commit(paths, message)


def _commit(paths: list[Path], message: str) -> None:
    git = ["git", "-C", str(ROOT)]
    names = [str(p) for p in paths]
    done = None
    for _ in range(10):
        if subprocess.run([*git, "add", "--", *names], capture_output=True).returncode != 0:
            time.sleep(3)  # the index is busy (another git command)
            continue
        unchanged = subprocess.run([*git, "diff", "--cached", "--quiet", "HEAD", "--", *names])
        if unchanged.returncode == 0:
            return
        done = subprocess.run(
            [*git, "commit", "-q", "-m", message, "--", *names], capture_output=True, text=True
        )
        if done.returncode == 0:
            return
        time.sleep(3)
    why = done.stderr.strip() if done is not None else "git add failed (is the index locked?)"
    print(f"[{_stamp()}] could not commit {names}: {why}", flush=True)


def report(runs_dir: Path, results_path: Path) -> list[Path] | None:
    """Regenerates docs/TRAINING.md and its figures; the files written, or None if it failed
    or `results_path` is not the study's own results file (the page is of that file)."""
    if Path(results_path).resolve() != RESULTS.resolve():
        print(f"[{_stamp()}] no report: {results_path} is not {RESULTS}", flush=True)
        return None
    cmd = [
        sys.executable,
        str(Path(__file__).resolve().parent / "paper_report.py"),
        "--runs-dir",
        str(runs_dir),
        "--results",
        str(results_path),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        print(f"[{_stamp()}] the report failed: {_last_line(done)}", flush=True)
        return None
    print(f"[{_stamp()}] report regenerated: {REPORT.relative_to(ROOT)}", flush=True)
    return [REPORT, *sorted(FIGURES.glob("training_*.png"))]


def lost(runs_dir: Path, results: dict, cell: str, seed: int) -> bool:
    """Whether the run was evaluated but its files are gone (trained before the archive)."""
    entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
    return evaluated(entry) and not (run_dir(runs_dir, cell, seed) / "config.json").is_file()


def order(queue: list[tuple[str, int]], runs_dir: Path, results: dict) -> list[tuple[str, int]]:
    """The runs in the order they train: the missing ones first (those whose checkpoints hold
    a replay buffer first of all: they cannot be archived mid-way, so such a run has to finish
    within one job, and it gets the most of the job's time), each preceded by the lost run it
    starts from (a fine-tuning needs its source's policy); then the other lost runs."""
    queue = sorted(queue, key=lambda run: CELLS[run[0]]["algo"] not in REPLAY_BUFFER)
    ordered = []
    for cell, seed in queue:
        if lost(runs_dir, results, cell, seed):
            continue
        source = (CELLS[cell].get("init_from"), seed)
        entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
        needs_source = not evaluated(entry) and source in queue and source not in ordered
        if needs_source and lost(runs_dir, results, *source):
            ordered.append(source)
        ordered.append((cell, seed))
    return ordered + [run for run in queue if run not in ordered]


def run_state(runs_dir: Path, archive: Path, results: dict, cell: str, seed: int) -> str:
    """Where one run stands: "done, ..." (with its time), training now, stopped (resumes),
    trained but not evaluated, evaluated but its files lost (trains again), failed, missing."""
    c = CELLS[cell]
    out = run_dir(runs_dir, cell, seed)
    if not (out / "config.json").is_file():
        out = run_dir(archive, cell, seed)  # not restored yet: the archive tells
    entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
    if evaluated(entry) and trained(out, c["timesteps"]):
        s = entry["train"]
        return f"done, {s['wall_time_s'] / 60:.0f} min ({s['steps_per_s']:.0f} steps/s)"
    if (out / "config.json").is_file() and not trained(out, c["timesteps"]):
        pid = lock_holder(out)  # train's lock (never archived)
        if out == run_dir(archive, cell, seed) and c["algo"] in REPLAY_BUFFER:
            return "started on another machine: its checkpoint is not archived, it starts over"
        try:
            steps = json.loads((out / "checkpoints" / "latest.json").read_text())["timesteps"]
        except (OSError, ValueError, KeyError):  # none yet, or an archive being replaced
            steps = 0
        at = f"{steps} of {c['timesteps']} steps"
        if pid:
            return f"training now (pid {pid}), last checkpoint at {at}"
        if out == run_dir(archive, cell, seed):
            return f"last archived checkpoint at {at} (resumes from it)"
        return f"stopped at {at} (resumes)"
    if trained(out, c["timesteps"]):
        why = f" (last try: {entry['error']})" if "error" in entry else ""
        return f"trained, not evaluated yet: the job evaluates it{why}"
    if evaluated(entry):
        state = "evaluated, but its files (curve, policy) were lost: trains again"
        if "retrain_error" in entry:
            state += f" (last try: {entry['retrain_error']})"
        return state
    if "error" in entry:
        return f"failed: {entry['error']}"
    return "missing"


def status(runs_dir: Path, archive: Path, results: dict) -> None:
    for cell, c in CELLS.items():
        for seed in c["seeds"]:
            print(f"{cell:18s} seed {seed}: {run_state(runs_dir, archive, results, cell, seed)}")


def ready(run: tuple[str, int], pending, running, runs_dir: Path) -> bool:
    """Whether `run` may start: it has finished training, or the run its training starts from
    (a fine-tuning's source) is neither still to run nor running."""
    cell, seed = run
    if trained(run_dir(runs_dir, cell, seed), CELLS[cell]["timesteps"]):
        return True
    source = (CELLS[cell].get("init_from"), seed)
    return source not in pending and source not in running


def record(cell: str, seed: int, entry: dict, before, was_lost: bool, results: dict, args) -> None:
    """Writes a finished run's entry into the results (and commits it), and regenerates the
    report after a run that finished in this job."""
    if was_lost and "error" in entry:  # the evaluation stays; the next job tries again
        entry = {**before, "retrain_error": entry["error"]}
    spec = {k: v for k, v in CELLS[cell].items() if k != "seeds"}
    results.setdefault(cell, {"spec": spec, "seeds": {}})["spec"] = spec
    results[cell]["seeds"][str(seed)] = entry
    atomic_write_json(args.out, results)
    if args.commit:
        commit([args.out], f"Paper study: {cell} seed {seed}")
    if evaluated(entry) and entry != before and "retrain_error" not in entry:
        # a run finished in this job
        written = report(args.archive, args.out)
        if written and args.commit:
            commit(written, f"TRAINING.md regenerated: {cell} seed {seed}")


def _submit(pool: ThreadPoolExecutor, cell: str, seed: int, results: dict, args):
    """Starts one run in `pool`; its future and what `record` needs of it."""
    before = results.get(cell, {}).get("seeds", {}).get(str(seed))
    was_lost = lost(args.runs_dir, results, cell, seed)
    if was_lost:
        print(f"[{_stamp()}] {cell} seed {seed}: its files were lost; trains again", flush=True)
    archived = run_dir(args.archive, cell, seed)

    def on_archive():
        if args.commit:
            commit([archived], f"Paper study: {cell} seed {seed} archived")

    snapshot = json.loads(json.dumps(results))  # the main thread goes on updating `results`
    future = pool.submit(run_one, cell, seed, args.runs_dir, snapshot, args.archive, on_archive)
    return future, (cell, seed, before, was_lost)


STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)  # stop the job as Ctrl-C does


def _interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


def run_queue(pending: list[tuple[str, int]], results: dict, args) -> None:
    """Runs `pending` in its order, `args.parallel` at a time (a run waits while its source is
    still to run or running), recording each as it finishes; if the job stops on an error or
    a signal (SIGINT, SIGTERM, SIGHUP; SIGKILL cannot be caught: kill the job's process
    group), every command still running is killed first."""
    running = {}  # future -> (cell, seed, its entry before, whether its files were lost)
    _STOPPING.clear()
    handlers = {signum: signal.signal(signum, _interrupt) for signum in STOP_SIGNALS}
    with ThreadPoolExecutor(max_workers=args.parallel) as pool:

        def start_ready():
            for run in list(pending):
                busy = [r[:2] for r in running.values()]
                if len(running) < args.parallel and ready(run, pending, busy, args.runs_dir):
                    pending.remove(run)
                    future, about = _submit(pool, *run, results, args)
                    running[future] = about

        try:
            start_ready()
            while running:
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                ended = [(future, running.pop(future)) for future in finished]
                failed = [future.exception() for future, _ in ended if future.exception()]
                if not failed:  # before the records: a report takes minutes, a core would idle
                    start_ready()
                for future, (cell, seed, before, was_lost) in ended:
                    if future.exception() is None:
                        record(cell, seed, future.result(), before, was_lost, results, args)
                if failed:
                    raise failed[0]
        except BaseException:  # no run goes on without the job that records it
            stop_live_commands()
            raise
        finally:
            for signum, handler in handlers.items():
                signal.signal(signum, handler)


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--runs-dir", type=Path, default=ROOT / "runs" / "paper")
    ap.add_argument("--only", nargs="+", choices=list(CELLS), help="these cells (default: all)")
    ap.add_argument("--seeds", type=int, nargs="+", help="only these seeds of each cell")
    ap.add_argument("--out", type=Path, default=RESULTS, help="results JSON, updated run by run")
    ap.add_argument("--archive", type=Path, default=ARCHIVE, help="each run's files, in the repo")
    ap.add_argument("--commit", action="store_true", help="git-commit the results after each run")
    ap.add_argument("--status", action="store_true", help="print what is done and missing")
    ap.add_argument(
        "--parallel",
        type=int,
        default=1,
        help="runs at a time (default 1): more where runs leave cores idle",
    )
    args = ap.parse_args()
    if args.parallel < 1:
        ap.error(f"--parallel {args.parallel}: runs at a time must be at least 1")
    results = read_results(args.out, ap)
    if args.status:
        status(args.runs_dir, args.archive, results)
        return 0
    with run_lock(args.runs_dir):  # one job at a time: a second would train the same runs
        for out in restore_runs(args.runs_dir, args.archive):
            print(f"[{_stamp()}] restored {out} from {args.archive}", flush=True)
        queue = [
            (cell, seed)
            for cell in args.only or list(CELLS)
            for seed in CELLS[cell]["seeds"]
            if args.seeds is None or seed in args.seeds
        ]
        if args.commit:  # what a job killed between an archive and its commit left
            commit([args.archive, args.out], "Paper study: the archive as the last job left it")
        # What is missing first; runs whose evaluation survived but whose files did not last.
        run_queue(order(queue, args.runs_dir, results), results, args)
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
