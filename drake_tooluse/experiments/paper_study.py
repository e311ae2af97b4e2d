"""The paper's study at its scale, several seeds per cell, as a job that survives the machine
(`drake-tooluse study`; the cells are data: `paper_study.yaml`).

Each run is a `drake-tooluse train` command (continued with `train --resume` when a run was
stopped), its best policy evaluated with `drake-tooluse evaluate` over the study's seeded
episodes (100, seeds 1000-1099), each run to its 100-step limit and judged where the box ends
(the paper's protocol; stored twice, as `evaluate_best` and, with `--to-time-limit`,
`evaluate_best_time_limit`, the key the report reads). The runs are commands on this
machine, N at a time (`learning.jobs`).

Re-running it picks up every run where it stopped: a finished run is not trained again, a stopped
one resumes from its last checkpoint, a failed one is recorded (its error) and the job goes on. A
run whose settings are not its cell's (a cell redefined) is refused, not reused. The results are
written atomically after every run. The run directories do not outlive the machine, so each run's
small files are archived (`archive_run`: config, summary, best policy, progress.csv, evaluations;
while it trains, every `archive_every` its latest checkpoint too, unless a replay buffer makes it
over ARCHIVE_MAX_CHECKPOINT: DDPG's starts over on a new machine); a new machine restores them into
the run directories before anything runs. A run evaluated in the results whose files are in neither
place (trained before the archive existed) is trained again after every run still missing (but right
before a missing fine-tuning that starts from it), so that its curve and policy exist for the
figures and the runs that start from it; if that retraining fails, its evaluation stays (with the
error) and the next job tries again. After each run that finished in this job the report is made
again (`drake-tooluse study-report`, a subprocess: one that fails is logged and the job goes on). No
git command runs: committing the files is the user's.

Where the files go (`StudyFiles`): by default all under one directory (`runs/study`); with
`--update-docs`, a checkout's docs: docs/results/paper_study.json, the archive
docs/results/paper_study/CELL/sSEED/, docs/TRAINING.md and docs/figures/training_*.png, with the
run directories in runs/paper.
"""

from __future__ import annotations

import dataclasses as dc
import json
import re
import shlex
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

from drake_tooluse.experiments.paper_study_cells import StudyFiles, check_cell_names
from drake_tooluse.experiments.runs import stderr_log
from drake_tooluse.files import atomic_dir, atomic_write_json, lock_holder, run_lock
from drake_tooluse.learning.figures import format_figures
from drake_tooluse.learning.jobs import Commands, last_line, run_queue, this_interpreter
from drake_tooluse.learning.task_envs import episode_metrics
from drake_tooluse.limits import MAX_PARALLEL
from drake_tooluse.progress import progress_bar
from drake_tooluse.validation import check_int

# What of a run directory is archived (TensorBoard's events and `final/` are not: the report
# needs none of them, and a resume rewrites the events).
ARCHIVED = ("config.json", "summary.json", "best", "logs/progress.csv", "eval/evaluations.npz")
ARCHIVE_EVERY = 20 * 60  # s between two archives of a run that is training
ARCHIVE_MAX_CHECKPOINT = 4 << 20  # bytes: PPO's, TRPO's and A2C's are ~1 MB, DDPG's ~82 MB (a full
# buffer of 300k transitions of ToolPush-v1, 264 bytes each)
PROGRESS_POLL = 5.0  # s between two reads of the runs' training logs for the study's bar
REPLAY_BUFFER = ("ddpg",)  # algorithms whose checkpoints hold a replay buffer


def _log_to_stderr(text: str) -> None:
    stderr_log(f"[{time.strftime('%H:%M:%S')}] {text}")


@dc.dataclass
class Study:
    """A study: its cells (name -> spec, in the order they run), its files, its evaluation,
    and how the job reports. `report_command`: the command that makes the report of these
    files (None: no report)."""

    cells: dict
    files: StudyFiles
    episodes: int = 100
    evaluation_seed: int = 1000
    archive_every: float = ARCHIVE_EVERY
    report_command: list[str] | None = None
    log: Callable[[str], None] = _log_to_stderr
    commands: Commands = dc.field(default_factory=Commands)


def run_dir(runs_dir: Path, cell: str, seed: int) -> Path:
    return Path(runs_dir) / cell / f"s{seed}"


def train_command(cells: dict, cell: str, seed: int, runs_dir: Path, resume: bool) -> list[str]:
    c = cells[cell]
    out = run_dir(runs_dir, cell, seed)
    cmd = ["drake-tooluse", "train", "--env", c["env"], "--algo", c["algo"]]
    cmd += ["--timesteps", str(c["timesteps"]), "--seed", str(seed), "--no-progress"]
    cmd += ["--resume" if resume else "--out", str(out)]
    if "hyperparams" in c:
        cmd += ["--hyperparams", json.dumps(c["hyperparams"])]
    if "init_from" in c:
        cmd += ["--init-from", str(run_dir(runs_dir, c["init_from"], seed) / "best")]
    return cmd


# Each run's best policy is evaluated twice, both to the 100-step limit (the -v1 envs end no
# episode early): the results of the -v0 study, whose cells could end early, had both keys.
# result key -> (key of its command, extra arguments)
EVALUATIONS = {
    "evaluate_best": ("evaluate_command", []),
    "evaluate_best_time_limit": ("evaluate_time_limit_command", ["--to-time-limit"]),
}


def evaluate_command(policy: Path, env_id: str, episodes: int, seed: int, extra=()) -> list[str]:
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
        str(seed),
        "--no-progress",
        "--per-episode",
        "--json",
        *extra,
    ]


def evaluated(entry: dict) -> bool:
    """Whether a run's entry holds every evaluation and no error."""
    return "error" not in entry and all(k in entry for k in EVALUATIONS)


def read_results(path: Path) -> dict:
    """The study's results file ({} if there is none yet); one that is not a JSON object is a
    one-line error naming it."""
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        results = json.loads(path.read_text(), parse_constant=_no_constant)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: not a readable JSON results file ({e})") from None
    except ValueError as e:  # NaN or Infinity: no figure of a finished run is either
        raise ValueError(f"{path}: {e}; a results file holds finite numbers only") from None
    if not isinstance(results, dict):
        raise ValueError(
            f"{path}: a results file is a JSON object (cell -> seeds), not {type(results).__name__}"
        )
    for cell, entry in results.items():
        seeds = entry.get("seeds", {}) if isinstance(entry, dict) else None
        if not isinstance(seeds, dict):
            raise ValueError(f"{path}: cell {cell!r} is not an object with a 'seeds' object")
        for seed in seeds:
            if not (seed.isdigit() and isinstance(seeds[seed], dict)):
                raise ValueError(
                    f"{path}: cell {cell!r} has seed {seed!r}; seeds are non-negative "
                    "integers, each an object"
                )
    return results


def _no_constant(name: str):
    raise ValueError(f"it holds {name}")


def _summary(out: Path) -> dict | None:
    path = out / "summary.json"
    return json.loads(path.read_text()) if path.is_file() else None


def trained(out: Path, timesteps: int) -> bool:
    summary = _summary(out)
    return summary is not None and summary["timesteps"] >= timesteps


def steps_trained(out: Path) -> int:
    """The steps the run in `out` has trained so far: its training log's last complete row
    (`logs/progress.csv`, time/total_timesteps); 0 before its first row."""
    path = out / "logs" / "progress.csv"
    try:
        with path.open("rb") as f:
            column = f.readline().decode().rstrip().split(",").index("time/total_timesteps")
            start = max(0, path.stat().st_size - 8192)  # the log's tail: its last rows
            f.seek(start)
            # Whole rows only: the last one (after the last newline) may be being written,
            # and the first is cut where the tail starts mid-file.
            rows = f.read().decode(errors="replace").split("\n")[1 if start else 0 : -1]
    except (OSError, ValueError):
        return 0
    for row in reversed(rows):
        cells = row.split(",")
        if len(cells) > column and cells[column].isdigit():
            return int(cells[column])
    return 0


@contextmanager
def study_progress(study: Study, queue: list[tuple[str, int]]):
    """A bar of the training steps of the runs of `queue` on stderr where it is a terminal,
    each run's read from its training log every PROGRESS_POLL s (the runs are other
    processes)."""
    runs = [(run_dir(study.files.runs, c, s), study.cells[c]["timesteps"]) for c, s in queue]

    def done() -> int:
        return sum(min(steps_trained(out), target) for out, target in runs)

    total = sum(target for _, target in runs)
    with progress_bar(total, "study", "step", initial=done()) as bar:
        stop = threading.Event()

        def poll():
            while not stop.wait(PROGRESS_POLL):
                bar.update(done() - bar.n)

        watcher = threading.Thread(target=poll, daemon=True)
        if not bar.disable:
            watcher.start()
        try:
            yield
        finally:
            stop.set()
            if watcher.is_alive():
                watcher.join()


def _tree_size(path: Path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def _target(out: Path) -> int:
    """The steps the run in `out` was asked for (its config.json)."""
    return int(json.loads((out / "config.json").read_text())["timesteps"])


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


def restore_runs(runs_dir: Path, archive: Path) -> list[Path]:
    """Copies each archived run that `runs_dir` does not hold into it (a new machine's runs
    continue from the archive); the runs restored."""
    restored = []
    for archived in sorted(Path(archive).glob("*/s*")):
        if not re.fullmatch(r"s\d+", archived.name):  # not a run's folder: nothing to restore
            continue
        out = run_dir(runs_dir, archived.parent.name, int(archived.name[1:]))
        if archived.is_dir() and (archived / "config.json").is_file() and not out.exists():
            with atomic_dir(out) as work:
                shutil.copytree(archived, work, dirs_exist_ok=True)
            restored.append(out)
    return restored


def train_and_archive(
    study: Study, cmd: list[str], out: Path, archived: Path
) -> subprocess.CompletedProcess:
    """Runs the training command, archiving the run every `study.archive_every` while it trains
    and once when it ends; what it printed and its exit code."""
    job = study.commands.start(cmd)
    try:
        while True:
            try:
                stdout, stderr = job.communicate(timeout=study.archive_every)
                break
            except subprocess.TimeoutExpired:  # still training: no output is lost by waiting
                archive_run(out, archived)
    finally:  # the job stopped (a signal, an error): no training goes on without it
        study.commands.end(job)
    if (out / "config.json").is_file():
        archive_run(out, archived)
    return subprocess.CompletedProcess(cmd, job.returncode, stdout, stderr)


def settings_differ(cells: dict, out: Path, cell: str, seed: int) -> str | None:
    """How the run in `out` (its config.json) was trained other than the cell asks, or None:
    a cell redefined must not reuse (or resume) runs of its old definition."""
    path = out / "config.json"
    if not path.is_file():
        return None
    saved, c = json.loads(path.read_text()), cells[cell]
    differences = [
        f"{key} {saved.get(key)!r} (the cell: {want!r})"
        for key, want in (("env_id", c["env"]), ("algo", c["algo"]), ("seed", seed))
        if saved.get(key) != want
    ]
    for key, want in c.get("hyperparams", {}).items():
        have = saved.get("hyperparams", {}).get(key)
        if have != want:
            differences.append(f"{key} {have!r} (the cell: {want!r})")
    source = saved.get("init_from")
    if "init_from" in c and (
        source is None or Path(source).parts[-3:-1] != (c["init_from"], f"s{seed}")
    ):
        differences.append(f"init_from {source!r} (the cell: {c['init_from']}/s{seed}/best)")
    return "; ".join(differences) or None


def run_one(study: Study, cell: str, seed: int, results: dict) -> dict:
    """Trains (or resumes) one run, archiving it (`archive_run`), and evaluates its best
    policy; a failure is recorded in the entry it returns."""
    c, runs_dir, archive, log = study.cells[cell], study.files.runs, study.files.archive, study.log
    out = run_dir(runs_dir, cell, seed)
    entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
    differ = settings_differ(study.cells, out, cell, seed)
    if differ:
        error = f"{out} holds a run trained otherwise: {differ}; move it away to rerun the cell"
        log(f"{cell} seed {seed} skipped: {error}")
        return {"error": error}
    source = c.get("init_from")
    if not trained(out, c["timesteps"]):
        # Only a run still to train needs its source: a finished one keeps its results.
        if source and not trained(
            run_dir(runs_dir, source, seed), study.cells[source]["timesteps"]
        ):
            log(f"{cell} seed {seed} waits for {source} seed {seed}")
            return {
                "error": f"waits for {source} seed {seed} to finish (it starts from its policy)"
            }
        cmd = train_command(
            study.cells, cell, seed, runs_dir, resume=(out / "config.json").is_file()
        )
        log(f"{cell} seed {seed}: {shlex.join(cmd)}")
        done = train_and_archive(study, cmd, out, run_dir(archive, cell, seed))
        if done.returncode != 0:
            error = last_line(done)
            log(f"{cell} seed {seed} failed: {error}")
            return {"train_command": shlex.join(cmd), "error": error}
    elif _summary(run_dir(archive, cell, seed)) != _summary(out):
        archive_run(out, run_dir(archive, cell, seed))  # not archived since it finished
    summary = _summary(out)
    result = {
        "train_command": shlex.join(train_command(study.cells, cell, seed, runs_dir, False)),
        "train": summary,
    }
    for key, (command_key, extra) in EVALUATIONS.items():
        if entry.get("train") == summary and "per_episode" in entry.get(key, {}):
            result[command_key], result[key] = entry.get(command_key), entry[key]  # done
            continue
        cmd = evaluate_command(out / "best", c["env"], study.episodes, study.evaluation_seed, extra)
        finished = study.commands.run(cmd)
        if finished.returncode != 0:
            error = last_line(finished)
            log(f"{cell} seed {seed} ({key}) failed: {error}")
            return {**result, command_key: shlex.join(cmd), "error": error}  # done stays
        e = json.loads(finished.stdout)
        episodes = e.pop("per_episode")  # kept as columns: the statistics resample episodes
        headline = episode_metrics(c["env"])[0]  # the task's first figure
        e["per_episode"] = {k: [r[k] for r in episodes] for k in (headline.name, "success")}
        result[command_key], result[key] = shlex.join(cmd), e
        base, _, unit = headline.name.rpartition("_")
        figures = {
            f"{base}_mean_{unit}": e[f"{base}_mean_{unit}"],
            "success_rate": e["success_rate"],
        }
        log(
            f"{cell} seed {seed} ({key}): {format_figures(figures, e.get('object_name', 'object'))}"
            f", {summary['timesteps']} steps in {summary['wall_time_s'] / 60:.1f} min"
        )
    return result


def lost(runs_dir: Path, results: dict, cell: str, seed: int) -> bool:
    """Whether the run was evaluated but its files are gone (trained before the archive)."""
    entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
    return evaluated(entry) and not (run_dir(runs_dir, cell, seed) / "config.json").is_file()


def order(cells: dict, queue: list, runs_dir: Path, results: dict) -> list[tuple[str, int]]:
    """The runs in the order they train: the missing ones first (those whose checkpoints hold
    a replay buffer first of all: they cannot be archived mid-way, so such a run has to finish
    within one job, and it gets the most of the job's time), each preceded by the lost run it
    starts from (a fine-tuning needs its source's policy); then the other lost runs."""
    queue = sorted(queue, key=lambda run: cells[run[0]]["algo"] not in REPLAY_BUFFER)
    ordered = []
    for cell, seed in queue:
        if lost(runs_dir, results, cell, seed):
            continue
        source = (cells[cell].get("init_from"), seed)
        entry = results.get(cell, {}).get("seeds", {}).get(str(seed), {})
        needs_source = not evaluated(entry) and source in queue and source not in ordered
        if needs_source and lost(runs_dir, results, *source):
            ordered.append(source)
        ordered.append((cell, seed))
    return ordered + [run for run in queue if run not in ordered]


def run_state(cells: dict, runs_dir: Path, archive: Path, results: dict, cell: str, seed: int):
    """Where one run stands: "done, ..." (with its time), training now, stopped (resumes),
    trained but not evaluated, evaluated but its files lost (trains again), failed, missing."""
    c = cells[cell]
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


def status(study: Study, results: dict, runs=None) -> list[dict]:
    """Where each run (of `runs`, default all) stands: cell, seed, state."""
    runs = (
        runs
        if runs is not None
        else [(c, s) for c, spec in study.cells.items() for s in spec["seeds"]]
    )
    files = study.files
    return [
        {
            "cell": cell,
            "seed": seed,
            "state": run_state(study.cells, files.runs, files.archive, results, cell, seed),
        }
        for cell, seed in runs
    ]


def format_status(rows: list[dict]) -> str:
    return "\n".join(f"{r['cell']:18s} seed {r['seed']}: {r['state']}" for r in rows)


def ready(cells: dict, run: tuple, pending, running, runs_dir: Path) -> bool:
    """Whether `run` may start: it has finished training, or the run its training starts from
    (a fine-tuning's source) is neither still to run nor running."""
    cell, seed = run
    if trained(run_dir(runs_dir, cell, seed), cells[cell]["timesteps"]):
        return True
    source = (cells[cell].get("init_from"), seed)
    return source not in pending and source not in running


def report(study: Study) -> bool:
    """Makes the report of the study's files again (its own process: a report that fails is
    logged and the job goes on); whether it was made."""
    if study.report_command is None:
        return False
    done = subprocess.run(this_interpreter(study.report_command), capture_output=True, text=True)
    if done.returncode != 0:
        study.log(f"the report failed: {last_line(done)}")
        return False
    study.log(f"report made again: {study.files.page}")
    return True


def record(study: Study, run: tuple, entry: dict, about: tuple, results: dict) -> None:
    """Writes a finished run's entry into the results (atomically), and makes the report again
    after a run that finished in this job."""
    (cell, seed), (before, was_lost) = run, about
    if was_lost and "error" in entry:  # the evaluation stays; the next job tries again
        entry = {**before, "retrain_error": entry["error"]}
    spec = {k: v for k, v in study.cells[cell].items() if k != "seeds"}
    results.setdefault(cell, {"spec": spec, "seeds": {}})["spec"] = spec
    results[cell]["seeds"][str(seed)] = entry
    atomic_write_json(study.files.results, results)
    if evaluated(entry) and entry != before and "retrain_error" not in entry:
        report(study)  # a run finished in this job


def queue_of(study: Study, only=None, seeds=None) -> list[tuple[str, int]]:
    """The runs of the cells `only` (default all, in the study's order), of the seeds `seeds`
    (default each cell's own); unknown cells, and a seed none of those cells has, are an
    error naming them."""
    check_cell_names(study.cells, only)
    cells = only or list(study.cells)
    if seeds is not None:
        known = sorted({seed for cell in cells for seed in study.cells[cell]["seeds"]})
        missing = [seed for seed in seeds if seed not in known]
        if missing:
            raise ValueError(
                f"seeds {missing} are in no cell of {cells}: nothing would run for them; "
                f"their seeds are {known}"
            )
    return [
        (cell, seed)
        for cell in cells
        for seed in study.cells[cell]["seeds"]
        if seeds is None or seed in seeds
    ]


def run_study(study: Study, only=None, seeds=None, parallel: int = 1) -> list[dict]:
    """Runs what is missing of the study (of the cells `only`, the seeds `seeds`), `parallel`
    runs at a time, resuming stopped runs; the state of each run after the job. One job at a
    time holds the run directories."""
    check_int(parallel, 1, MAX_PARALLEL, "parallel")
    queue = queue_of(study, only, seeds)
    files = study.files
    results = read_results(files.results)
    with run_lock(files.runs):  # a second job would train the same runs
        for out in restore_runs(files.runs, files.archive):
            study.log(f"restored {out} from {files.archive}")

        def prepare(run):
            cell, seed = run
            before = results.get(cell, {}).get("seeds", {}).get(str(seed))
            was_lost = lost(files.runs, results, cell, seed)
            if was_lost:
                study.log(f"{cell} seed {seed}: its files were lost; trains again")
            snapshot = json.loads(json.dumps(results))  # this thread goes on updating `results`
            return (lambda: run_one(study, cell, seed, snapshot)), (before, was_lost)

        with study_progress(study, queue):
            run_queue(
                order(study.cells, queue, files.runs, results),  # the missing first, the lost last
                parallel,
                lambda run, pending, running: ready(study.cells, run, pending, running, files.runs),
                prepare,
                lambda run, entry, about: record(study, run, entry, about, results),
                study.commands,
            )
    rows = status(study, results, queue)
    for row in rows:
        entry = results.get(row["cell"], {}).get("seeds", {}).get(str(row["seed"]), {})
        if "error" in entry or "retrain_error" in entry:
            row["error"] = entry.get("error", entry.get("retrain_error"))
    return rows


def report_command(options: list[str]) -> list[str]:
    """The command that makes the report, with the study's file options (this Python's
    `drake-tooluse study-report`)."""
    return [sys.executable, "-m", "drake_tooluse.cli", "study-report", *options]
