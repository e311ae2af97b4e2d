"""The paper study's runner keeps what it has when things go wrong around it: a fine-tuning
runs right after the lost run it starts from is trained again; a finished fine-tuning keeps
its results when its source is lost; a lost run whose retraining fails keeps its evaluation;
a stray folder in the archive is not taken for a run; a training is not left running when
the runner stops on an error; runs in parallel wait for the run they start from, and one
that fails hard, or a stop signal, stops those beside it. No training runs here (fast)."""

import importlib.util
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def runner():
    spec = importlib.util.spec_from_file_location(
        "paper_experiments_under_test", ROOT / "benchmarks" / "paper_experiments.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.CELLS.clear()
    module.CELLS.update(
        source=dict(env="drake_tooluse/ToolPush-v0", algo="ppo", timesteps=100, seeds=(0, 1)),
        other=dict(env="drake_tooluse/ToolPush-v0", algo="ppo", timesteps=100, seeds=(0,)),
        finetune=dict(
            env="drake_tooluse/ToolPushFar-v0",
            algo="ppo",
            timesteps=50,
            seeds=(0, 1),
            init_from="source",
        ),
    )
    return module


@pytest.fixture
def started(runner, monkeypatch) -> list[subprocess.Popen]:
    """The commands the runner starts, as they start."""
    commands = []

    class Recorded(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            commands.append(self)

    monkeypatch.setattr(runner.subprocess, "Popen", Recorded)
    return commands


def _evaluated(summary: dict) -> dict:
    episodes = {"per_episode": {"final_box_to_goal_m": [0.01], "success": [True]}}
    return {"train": summary, "evaluate_best": episodes, "evaluate_best_time_limit": episodes}


def _trained_run(runner, runs: Path, cell: str, seed: int) -> dict:
    """A finished run's config and summary, as `drake-tooluse train` leaves them."""
    c, out = runner.CELLS[cell], runner.run_dir(runs, cell, seed)
    out.mkdir(parents=True)
    config = {"env_id": c["env"], "algo": c["algo"], "seed": seed, "hyperparams": {}}
    config["timesteps"] = c["timesteps"]
    if "init_from" in c:
        config["init_from"] = str(runner.run_dir(runs, c["init_from"], seed) / "best")
    (out / "config.json").write_text(json.dumps(config))
    summary = {"timesteps": c["timesteps"], "wall_time_s": 60.0, "steps_per_s": 2.0}
    (out / "summary.json").write_text(json.dumps(summary))
    return summary


def test_a_finetuning_trains_right_after_its_lost_source(runner, tmp_path):
    # Every source run was evaluated and its files lost; finetune seed 1 is done already.
    results = {"source": {"seeds": {s: _evaluated({"timesteps": 100}) for s in ("0", "1")}}}
    summary = _trained_run(runner, tmp_path, "finetune", 1)
    results["finetune"] = {"seeds": {"1": _evaluated(summary)}}
    queue = [(cell, seed) for cell, c in runner.CELLS.items() for seed in c["seeds"]]
    assert runner.order(queue, tmp_path, results) == [
        ("other", 0),
        ("source", 0),
        ("finetune", 0),
        ("finetune", 1),
        ("source", 1),  # nothing missing needs it: after every missing run
    ]


def test_a_finished_finetuning_keeps_its_results_when_its_source_was_lost(runner, tmp_path):
    runs, archive = tmp_path / "runs", tmp_path / "archive"
    summary = _trained_run(runner, runs, "finetune", 0)
    results = {"finetune": {"seeds": {"0": _evaluated(summary)}}}
    entry = runner.run_one("finetune", 0, runs, results, archive)
    assert "error" not in entry and entry["evaluate_best"] == _evaluated(summary)["evaluate_best"]
    # It had not been archived since it finished: it is now.
    assert json.loads((archive / "finetune" / "s0" / "summary.json").read_text()) == summary


def test_a_lost_run_whose_retraining_fails_keeps_its_evaluation(runner, tmp_path, monkeypatch):
    study = tmp_path / "study.json"
    old = _evaluated({"timesteps": 100})
    study.write_text(json.dumps({"source": {"seeds": {"0": old}}}))
    monkeypatch.setattr(runner, "run_one", lambda *a, **k: {"error": "out of memory"})
    monkeypatch.setattr(runner, "report", lambda *a: pytest.fail("nothing new to report"))
    argv = ["paper_experiments.py", "--runs-dir", str(tmp_path / "runs"), "--out", str(study)]
    argv += ["--archive", str(tmp_path / "archive"), "--only", "source", "--seeds", "0"]
    monkeypatch.setattr(sys, "argv", argv)
    assert runner.main() == 0
    entry = json.loads(study.read_text())["source"]["seeds"]["0"]
    assert entry == {**old, "retrain_error": "out of memory"} and runner.evaluated(entry)


def test_a_stray_folder_in_the_archive_is_not_a_run(runner, tmp_path):
    archive, runs = tmp_path / "archive", tmp_path / "runs"
    _trained_run(runner, archive, "source", 0)
    (archive / "source" / "s0_old").mkdir()
    (archive / "source" / "s0_old" / "config.json").write_text("{}")
    (archive / "source" / "seeds.txt").write_text("notes")
    assert runner.restore_runs(runs, archive) == [runs / "source" / "s0"]


def test_status_tells_a_trained_run_waiting_for_its_evaluation(runner, tmp_path, capsys):
    _trained_run(runner, tmp_path, "other", 0)
    runner.status(tmp_path, tmp_path / "archive", {"other": {"seeds": {"0": {"error": "x"}}}})
    assert "other              seed 0: trained, not evaluated yet" in capsys.readouterr().out


def test_a_training_does_not_outlive_the_runner(runner, tmp_path, monkeypatch, started):
    def archive_fails(*args):
        raise RuntimeError("the disk went away")

    monkeypatch.setattr(runner, "ARCHIVE_EVERY", 0.2)
    monkeypatch.setattr(runner, "archive_run", archive_fails)
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    with pytest.raises(RuntimeError, match="the disk went away"):
        runner.train_and_archive(sleeper, tmp_path, tmp_path / "archive", lambda: None)
    assert started and started[0].poll() is not None  # killed, not orphaned


def test_status_tells_a_run_training_now_from_a_stopped_one(runner, tmp_path, capsys):
    out = runner.run_dir(tmp_path, "other", 0)
    out.mkdir(parents=True)
    (out / "config.json").write_text("{}")
    (out / ".lock").write_text(str(os.getpid()))  # this process: alive
    runner.status(tmp_path, tmp_path / "archive", {})
    assert f"other              seed 0: training now (pid {os.getpid()})" in capsys.readouterr().out
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], text=True, capture_output=True
    ).stdout.strip()
    (out / ".lock").write_text(dead)  # a process that has ended
    runner.status(tmp_path, tmp_path / "archive", {})
    assert (
        "other              seed 0: stopped at 0 of 100 steps (resumes)" in capsys.readouterr().out
    )


def _main(runner, tmp_path, monkeypatch, *extra) -> Path:
    """Runs the runner's main with `extra` arguments; its results file."""
    study = tmp_path / "study.json"
    argv = ["paper_experiments.py", "--runs-dir", str(tmp_path / "runs"), "--out", str(study)]
    monkeypatch.setattr(sys, "argv", [*argv, "--archive", str(tmp_path / "archive"), *extra])
    assert runner.main() == 0
    return study


def test_parallel_runs_wait_for_the_run_they_start_from(runner, tmp_path, monkeypatch):
    spans, lock = {}, threading.Lock()

    def run_one(cell, seed, *args, **kwargs):
        began = time.monotonic()
        time.sleep(0.3)
        with lock:
            spans[(cell, seed)] = (began, time.monotonic())
        return _evaluated({"timesteps": runner.CELLS[cell]["timesteps"]})

    monkeypatch.setattr(runner, "run_one", run_one)
    monkeypatch.setattr(runner, "report", lambda *a: None)
    # The fine-tunings first in the queue: they have to wait.
    study = _main(runner, tmp_path, monkeypatch, "--parallel", "2", "--only", "finetune", "source")
    assert set(spans) == {(c, s) for c in ("finetune", "source") for s in (0, 1)}
    at_once = max(sum(b <= t < e for b, e in spans.values()) for t, _ in spans.values())
    assert at_once == 2
    for seed in (0, 1):  # each fine-tuning began once its source had finished
        assert spans[("finetune", seed)][0] >= spans[("source", seed)][1]
    results = json.loads(study.read_text())
    assert all(runner.evaluated(e) for c in results.values() for e in c["seeds"].values())


@pytest.mark.parametrize("stop", ["error", signal.SIGTERM, signal.SIGHUP])
def test_a_run_that_fails_hard_or_a_signal_stops_the_runs_beside_it(
    runner, tmp_path, monkeypatch, started, stop
):
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    handlers = {signum: signal.getsignal(signum) for signum in runner.STOP_SIGNALS}

    def run_one(cell, seed, runs_dir, results, archive, on_archive):
        if cell == "other":
            while not started:
                time.sleep(0.05)
            if stop == "error":
                raise RuntimeError("the disk went away")
            os.kill(os.getpid(), stop)  # as `kill PID` would
            return {}
        return runner.train_and_archive(sleeper, tmp_path, archive, on_archive)

    monkeypatch.setattr(runner, "run_one", run_one)
    began = time.monotonic()
    with pytest.raises(RuntimeError if stop == "error" else KeyboardInterrupt):
        _main(
            runner,
            tmp_path,
            monkeypatch,
            "--parallel",
            "2",
            "--only",
            "source",
            "other",
            "--seeds",
            "0",
        )
    assert time.monotonic() - began < 30 and started[0].poll() is not None  # killed, not waited
    assert {signum: signal.getsignal(signum) for signum in handlers} == handlers  # restored


def test_parallel_must_be_at_least_one(runner, tmp_path, monkeypatch, capsys):
    with pytest.raises(SystemExit):
        _main(runner, tmp_path, monkeypatch, "--parallel", "0")
    assert "--parallel 0: runs at a time must be at least 1" in capsys.readouterr().err


def test_a_run_that_cannot_be_archived_mid_way_goes_first(runner, tmp_path):
    runner.CELLS["replay"] = dict(
        env="drake_tooluse/ToolPush-v0", algo="ddpg", timesteps=9, seeds=(0,)
    )
    queue = [(cell, seed) for cell, c in runner.CELLS.items() for seed in c["seeds"]]
    assert runner.order(queue, tmp_path, {})[:2] == [("replay", 0), ("source", 0)]


def test_a_trained_finetuning_does_not_wait_for_its_source(runner, tmp_path):
    _trained_run(runner, tmp_path, "finetune", 1)
    pending = [("source", 1), ("finetune", 0)]
    assert runner.ready(("finetune", 1), pending, [], tmp_path)
    assert not runner.ready(("finetune", 1), [], [("source", 1)], tmp_path / "elsewhere")
    assert runner.ready(("finetune", 0), pending, [("source", 1)], tmp_path)


def test_the_archive_tells_a_replay_buffer_run_starts_over(runner, tmp_path):
    runner.CELLS["replay"] = dict(
        env="drake_tooluse/ToolPush-v0", algo="ddpg", timesteps=9, seeds=(0,)
    )
    for cell in ("replay", "other"):
        out = runner.run_dir(tmp_path, cell, 0)
        out.mkdir(parents=True)
        (out / "config.json").write_text("{}")  # started, not finished

    def state(cell):
        return runner.run_state(tmp_path / "runs", tmp_path, {}, cell, 0)

    assert (
        state("replay")
        == "started on another machine: its checkpoint is not archived, it starts over"
    )
    assert state("other") == "last archived checkpoint at 0 of 100 steps (resumes from it)"
