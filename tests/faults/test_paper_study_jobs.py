"""The paper study's runner (`experiments.paper_study` on `learning.jobs`) keeps what it has
when things go wrong around it: a fine-tuning runs right after the lost run it starts from is
trained again; a finished fine-tuning keeps its results when its source is lost; a lost run
whose retraining fails keeps its evaluation; a stray folder in the archive is not taken for a
run; a run trained under a mode's old name is still its cell's, a run trained otherwise is not;
a training is not left running when the runner stops on an error; runs in parallel wait for the
run they start from, and one that fails hard, or a stop signal, stops those beside it. No
training runs here (fast)."""

import copy
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from drake_tooluse.cli import main as cli_main
from drake_tooluse.experiments import paper_study
from drake_tooluse.experiments.paper_study import Study, run_dir
from drake_tooluse.experiments.paper_study_cells import StudyFiles, load_cells
from drake_tooluse.learning import jobs

ROOT = Path(__file__).resolve().parents[2]

CELLS = dict(
    source=dict(env="drake_tooluse/ToolPush-v1", algo="ppo", timesteps=100, seeds=[0, 1]),
    other=dict(env="drake_tooluse/ToolPush-v1", algo="ppo", timesteps=100, seeds=[0]),
    finetune=dict(
        env="drake_tooluse/ToolPushFar-v1",
        algo="ppo",
        timesteps=50,
        seeds=[0, 1],
        init_from="source",
    ),
)


@pytest.fixture
def study(tmp_path) -> Study:
    files = StudyFiles(
        results=tmp_path / "study.json",
        archive=tmp_path / "archive",
        runs=tmp_path / "runs",
        page=tmp_path / "TRAINING.md",
        figures=tmp_path / "figures",
    )
    return Study(copy.deepcopy(CELLS), files)


@pytest.fixture
def started(monkeypatch) -> list[subprocess.Popen]:
    """The commands the runner starts, as they start."""
    commands = []

    class Recorded(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            commands.append(self)

    monkeypatch.setattr(jobs.subprocess, "Popen", Recorded)
    return commands


def _evaluated(summary: dict) -> dict:
    episodes = {"per_episode": {"final_object_to_goal_m": [0.01], "success": [True]}}
    return {"train": summary, "evaluate_best": episodes, "evaluate_best_time_limit": episodes}


def _trained_run(study: Study, runs: Path, cell: str, seed: int, **config) -> dict:
    """A finished run's config and summary, as `drake-tooluse train` leaves them."""
    c, out = study.cells[cell], run_dir(runs, cell, seed)
    out.mkdir(parents=True)
    config = {"env_id": c["env"], "algo": c["algo"], "seed": seed, "hyperparams": {}, **config}
    config["timesteps"] = c["timesteps"]
    if "init_from" in c:
        config["init_from"] = str(run_dir(runs, c["init_from"], seed) / "best")
    (out / "config.json").write_text(json.dumps(config))
    summary = {"timesteps": c["timesteps"], "wall_time_s": 60.0, "steps_per_s": 2.0}
    (out / "summary.json").write_text(json.dumps(summary))
    return summary


def test_a_finetuning_trains_right_after_its_lost_source(study):
    # Every source run was evaluated and its files lost; finetune seed 1 is done already.
    runs = study.files.runs
    results = {"source": {"seeds": {s: _evaluated({"timesteps": 100}) for s in ("0", "1")}}}
    summary = _trained_run(study, runs, "finetune", 1)
    results["finetune"] = {"seeds": {"1": _evaluated(summary)}}
    queue = paper_study.queue_of(study)
    assert paper_study.order(study.cells, queue, runs, results) == [
        ("other", 0),
        ("source", 0),
        ("finetune", 0),
        ("finetune", 1),
        ("source", 1),  # nothing missing needs it: after every missing run
    ]


def test_a_finished_finetuning_keeps_its_results_when_its_source_was_lost(study):
    summary = _trained_run(study, study.files.runs, "finetune", 0)
    results = {"finetune": {"seeds": {"0": _evaluated(summary)}}}
    entry = paper_study.run_one(study, "finetune", 0, results)
    assert "error" not in entry and entry["evaluate_best"] == _evaluated(summary)["evaluate_best"]
    # It had not been archived since it finished: it is now.
    archived = study.files.archive / "finetune" / "s0" / "summary.json"
    assert json.loads(archived.read_text()) == summary


def test_a_lost_run_whose_retraining_fails_keeps_its_evaluation(study, monkeypatch):
    old = _evaluated({"timesteps": 100})
    study.files.results.write_text(json.dumps({"source": {"seeds": {"0": old}}}))
    monkeypatch.setattr(paper_study, "run_one", lambda *a, **k: {"error": "out of memory"})
    monkeypatch.setattr(paper_study, "report", lambda *a: pytest.fail("nothing new to report"))
    rows = paper_study.run_study(study, only=["source"], seeds=[0])
    entry = json.loads(study.files.results.read_text())["source"]["seeds"]["0"]
    assert entry == {**old, "retrain_error": "out of memory"} and paper_study.evaluated(entry)
    assert rows == [
        {
            "cell": "source",
            "seed": 0,
            "state": "evaluated, but its files (curve, policy) were lost: trains again "
            "(last try: out of memory)",
            "error": "out of memory",
        }
    ]


def test_a_stray_folder_in_the_archive_is_not_a_run(study):
    archive, runs = study.files.archive, study.files.runs
    _trained_run(study, archive, "source", 0)
    (archive / "source" / "s0_old").mkdir()
    (archive / "source" / "s0_old" / "config.json").write_text("{}")
    (archive / "source" / "seeds.txt").write_text("notes")
    assert paper_study.restore_runs(runs, archive) == [runs / "source" / "s0"]


PAPER_ACTION = {"action_mode": "position_quaternion", "randomize": True}


def test_a_run_trained_with_other_env_kwargs_is_refused_not_reused(study):
    study.cells["other"]["hyperparams"] = {"env_kwargs": PAPER_ACTION}
    runs = study.files.runs
    _trained_run(study, runs, "other", 0, hyperparams={"env_kwargs": PAPER_ACTION})
    out = run_dir(runs, "other", 0)
    assert paper_study.settings_differ(study.cells, out, "other", 0) is None
    position = {"env_kwargs": {"action_mode": "position", "randomize": True}}
    config = json.loads((out / "config.json").read_text())
    (out / "config.json").write_text(json.dumps({**config, "hyperparams": position}))
    differ = paper_study.settings_differ(study.cells, out, "other", 0)
    assert differ is not None and "'position'" in differ
    assert paper_study.run_one(study, "other", 0, {}) == {
        "error": f"{out} holds a run trained otherwise: {differ}; move it away to rerun the cell"
    }


def test_status_tells_a_trained_run_waiting_for_its_evaluation(study):
    _trained_run(study, study.files.runs, "other", 0)
    rows = paper_study.status(study, {"other": {"seeds": {"0": {"error": "x"}}}})
    text = paper_study.format_status(rows)
    assert "other              seed 0: trained, not evaluated yet" in text


def test_a_training_does_not_outlive_the_runner(study, tmp_path, monkeypatch, started):
    def archive_fails(*args):
        raise RuntimeError("the disk went away")

    study.archive_every = 0.2
    monkeypatch.setattr(paper_study, "archive_run", archive_fails)
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    with pytest.raises(RuntimeError, match="the disk went away"):
        paper_study.train_and_archive(study, sleeper, tmp_path, tmp_path / "archive")
    assert started and started[0].poll() is not None  # killed, not orphaned


def test_status_tells_a_run_training_now_from_a_stopped_one(study):
    out = run_dir(study.files.runs, "other", 0)
    out.mkdir(parents=True)
    (out / "config.json").write_text("{}")
    (out / ".lock").write_text(str(os.getpid()))  # this process: alive

    def state():
        return paper_study.status(study, {}, [("other", 0)])[0]["state"]

    assert state() == f"training now (pid {os.getpid()}), last checkpoint at 0 of 100 steps"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], text=True, capture_output=True
    ).stdout.strip()
    (out / ".lock").write_text(dead)  # a process that has ended
    assert state() == "stopped at 0 of 100 steps (resumes)"


def test_parallel_runs_wait_for_the_run_they_start_from(study, monkeypatch):
    spans, lock = {}, threading.Lock()

    def run_one(study, cell, seed, results):
        began = time.monotonic()
        time.sleep(0.3)
        with lock:
            spans[(cell, seed)] = (began, time.monotonic())
        return _evaluated({"timesteps": study.cells[cell]["timesteps"]})

    monkeypatch.setattr(paper_study, "run_one", run_one)
    reports = []
    monkeypatch.setattr(paper_study, "report", reports.append)
    # The fine-tunings first in the queue: they have to wait.
    paper_study.run_study(study, only=["finetune", "source"], parallel=2)
    assert set(spans) == {(c, s) for c in ("finetune", "source") for s in (0, 1)}
    at_once = max(sum(b <= t < e for b, e in spans.values()) for t, _ in spans.values())
    assert at_once == 2
    for seed in (0, 1):  # each fine-tuning began once its source had finished
        assert spans[("finetune", seed)][0] >= spans[("source", seed)][1]
    results = json.loads(study.files.results.read_text())
    assert all(paper_study.evaluated(e) for c in results.values() for e in c["seeds"].values())
    assert len(reports) == 4  # one after each run that finished in the job


@pytest.mark.parametrize("stop", ["error", signal.SIGTERM, signal.SIGHUP])
def test_a_run_that_fails_hard_or_a_signal_stops_the_runs_beside_it(
    study, tmp_path, monkeypatch, started, stop
):
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    handlers = {signum: signal.getsignal(signum) for signum in jobs.STOP_SIGNALS}

    def run_one(study, cell, seed, results):
        if cell == "other":
            while not started:
                time.sleep(0.05)
            if stop == "error":
                raise RuntimeError("the disk went away")
            os.kill(os.getpid(), stop)  # as `kill PID` would
            return {}
        return paper_study.train_and_archive(study, sleeper, tmp_path, tmp_path / "archive")

    monkeypatch.setattr(paper_study, "run_one", run_one)
    began = time.monotonic()
    with pytest.raises(RuntimeError if stop == "error" else KeyboardInterrupt):
        paper_study.run_study(study, only=["source", "other"], seeds=[0], parallel=2)
    assert time.monotonic() - began < 30 and started[0].poll() is not None  # killed, not waited
    assert {signum: signal.getsignal(signum) for signum in handlers} == handlers  # restored


def test_bad_arguments_are_one_line_errors(tmp_path, capsys):
    out = str(tmp_path / "study")
    for argv, says in (
        (["--parallel", "0"], "--parallel=0 is outside the allowed range [1, 64]"),
        (["--only", "nope"], "unknown cell(s) ['nope']"),
        (["--seeds", "7"], "seeds [7] are in no cell of ["),
        (["--out", out, "--update-docs"], "give --out DIR or --update-docs, not both"),
    ):
        assert (
            cli_main(
                ["study", "--out", out, *argv] if "--update-docs" not in argv else ["study", *argv]
            )
            == 2
        )
        err = capsys.readouterr().err
        assert says in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "study" / "runs").exists()  # refused before anything ran


def test_a_run_that_cannot_be_archived_mid_way_goes_first(study):
    study.cells["replay"] = dict(
        env="drake_tooluse/ToolPush-v1", algo="ddpg", timesteps=9, seeds=[0]
    )
    queue = paper_study.queue_of(study)
    assert paper_study.order(study.cells, queue, study.files.runs, {})[:2] == [
        ("replay", 0),
        ("source", 0),
    ]


def test_a_trained_finetuning_does_not_wait_for_its_source(study, tmp_path):
    _trained_run(study, tmp_path, "finetune", 1)
    pending = [("source", 1), ("finetune", 0)]
    cells = study.cells
    assert paper_study.ready(cells, ("finetune", 1), pending, [], tmp_path)
    assert not paper_study.ready(cells, ("finetune", 1), [], [("source", 1)], tmp_path / "x")
    assert paper_study.ready(cells, ("finetune", 0), pending, [("source", 1)], tmp_path)


def test_the_archive_tells_a_replay_buffer_run_starts_over(study):
    study.cells["replay"] = dict(
        env="drake_tooluse/ToolPush-v1", algo="ddpg", timesteps=9, seeds=[0]
    )
    for cell in ("replay", "other"):
        out = run_dir(study.files.archive, cell, 0)
        out.mkdir(parents=True)
        (out / "config.json").write_text("{}")  # started, not finished

    def state(cell):
        return paper_study.status(study, {}, [(cell, 0)])[0]["state"]

    assert (
        state("replay")
        == "started on another machine: its checkpoint is not archived, it starts over"
    )
    assert state("other") == "last archived checkpoint at 0 of 100 steps (resumes from it)"


def test_the_study_file_is_checked(tmp_path):
    path = tmp_path / "cells.yaml"
    good = {"env": "drake_tooluse/ToolPush-v1", "algo": "ppo", "timesteps": 10, "seeds": [0]}
    for cells, says in (
        ({"a": {**good, "algo": "sac"}}, "algo='sac' is not allowed"),
        ({"a": {**good, "seeds": [0, 0]}}, "repeats a seed"),
        ({"a": {**good, "init_from": "b"}}, "init_from='b' must name another cell"),
        ({"a": {**good, "protcol": "to-limit"}}, "unknown key(s) ['protcol']"),
        ({"a/b": good}, "a cell's name is a folder name"),
    ):
        path.write_text(json.dumps({"cells": cells}))  # JSON is YAML
        with pytest.raises(ValueError, match="cell") as e:
            load_cells(path)
        assert says in str(e.value) and str(path) in str(e.value)
    # The shipped study loads, in its order.
    cells, episodes, seed = load_cells()
    assert list(cells)[:2] == ["v1_ppo", "v1_ppo_paper_action"] and episodes == 100
    assert seed == 1000


def test_the_committed_study_resumes_in_a_checkout(tmp_path, monkeypatch, capsys):
    """`study --update-docs` picks up the committed results and archive as the earlier runner
    left them: a stopped run is restored and continued with `train --resume` (the earlier
    runner's command line), a trained one is evaluated, and the results keep every other
    entry. (No training here: the commands are recorded and fail.) The committed cell is
    finished; the test sets it back to how an earlier job left it: seed 1 trained but its
    evaluation lost, seed 2 stopped at a checkpoint."""
    results = ROOT / "docs" / "results" / "paper_study.json"
    archived = ROOT / "docs" / "results" / "paper_study" / "v1_ppo"
    (tmp_path / "pyproject.toml").write_text("")
    (tmp_path / "docs" / "results").mkdir(parents=True)
    committed = json.loads(results.read_text())
    seeds = committed["v1_ppo"]["seeds"]
    seeds["1"] = {"error": "an earlier try failed"}
    del seeds["2"]
    (tmp_path / "docs" / "results" / "paper_study.json").write_text(json.dumps(committed))
    copy = tmp_path / "docs" / "results" / "paper_study" / archived.name
    shutil.copytree(archived, copy)
    (copy / "s2" / "summary.json").unlink()
    stopped = copy / "s2" / "checkpoints" / "ckpt-000000350208"
    stopped.mkdir(parents=True)
    (stopped / "checkpoint.json").write_text("{}")
    (copy / "s2" / "checkpoints" / "latest.json").write_text(
        json.dumps({"timesteps": 350208, "checkpoint": stopped.name})
    )
    issued = []

    def refused(cmd, *args):
        issued.append(cmd)
        return subprocess.CompletedProcess(cmd, 1, "", "stopped by the test")

    monkeypatch.setattr(paper_study, "train_and_archive", lambda study, cmd, *a: refused(cmd))
    monkeypatch.setattr(jobs.Commands, "run", lambda self, cmd: refused(cmd))
    monkeypatch.chdir(tmp_path)
    argv = ["study", "--update-docs", "--only", "v1_ppo", "--seeds", "1", "2"]
    assert cli_main(argv) == 3  # a run failed (here: every command)
    runs = tmp_path / "runs" / "paper" / "v1_ppo"
    assert (runs / "s2" / "checkpoints" / "latest.json").is_file()  # restored from the archive
    assert [" ".join(c) for c in issued] == [
        f"drake-tooluse evaluate --policy {runs}/s1/best --env drake_tooluse/ToolPush-v1 "
        "--episodes 100 --seed 1000 --no-progress --per-episode --json",
        "drake-tooluse train --env drake_tooluse/ToolPush-v1 --algo ppo --timesteps 1250000 "
        f"--seed 2 --no-progress --resume {runs}/s2",
    ]
    after = json.loads((tmp_path / "docs" / "results" / "paper_study.json").read_text())
    before = committed
    assert after["v1_ppo"]["seeds"]["2"]["error"] == "stopped by the test"
    assert after["v1_ppo"]["seeds"]["0"] == before["v1_ppo"]["seeds"]["0"]
    assert {c: v for c, v in after.items() if c != "v1_ppo"} == {
        c: v for c, v in before.items() if c != "v1_ppo"
    }
    assert "restored" in capsys.readouterr().err


def test_a_job_runs_drake_tooluse_with_this_interpreter_activated_or_not(monkeypatch):
    """`.venv/bin/drake-tooluse study` from a shell whose PATH lacks the venv: its commands
    still run (they failed with "'drake-tooluse': No such file or directory")."""
    monkeypatch.setenv("PATH", "/nonexistent")
    done = jobs.Commands().run(["drake-tooluse", "--version"])
    assert done.returncode == 0 and done.stdout.startswith("drake-tooluse "), done.stderr
    assert done.args == ["drake-tooluse", "--version"]  # as logged


def test_the_study_shows_its_runs_training_steps_on_a_terminal_only(study, monkeypatch):
    """A bar of the queue's steps, read from each run's training log as it grows (a row cut
    mid-write is skipped); nothing where stderr is a log file."""
    import io

    class Stderr(io.StringIO):
        def __init__(self, tty):
            super().__init__()
            self.tty = tty

        def isatty(self):
            return self.tty

    log = run_dir(study.files.runs, "source", 0) / "logs" / "progress.csv"
    log.parent.mkdir(parents=True)
    log.write_text("a,time/total_timesteps\n1,40\n2,6")  # the last row still being written
    assert paper_study.steps_trained(log.parents[1]) == 40
    assert paper_study.steps_trained(run_dir(study.files.runs, "other", 0)) == 0
    monkeypatch.setattr(paper_study, "PROGRESS_POLL", 0.01)
    queue = [("source", 0), ("other", 0)]
    for tty in (True, False):
        err = Stderr(tty)
        monkeypatch.setattr(sys, "stderr", err)
        with paper_study.study_progress(study, queue):
            log.write_text("a,time/total_timesteps\n1,40\n2,60\n")
            time.sleep(0.2)
        assert ("60/200" in err.getvalue()) == tty and ("\r" in err.getvalue()) == tty
        log.write_text("a,time/total_timesteps\n1,40\n")
