"""`drake-tooluse study` survives the machine: a cell that fails is recorded and the job goes
on; a job killed mid-run (its whole process group, SIGKILL) on a machine that is then lost (its
run directories deleted) resumes that run, on a new one, from the checkpoint in the archive; a
finished run is not trained again; a run whose files are lost altogether trains again; the
report is made after each run that finished in the job. Tiny cells (a study file of its own)
stand in for the paper's (slow: 6.4 min on a shared 2-core machine)."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

TINY = {"n_envs": 1, "eval_freq": 10_000_000, "eval_episodes": 1, "checkpoint_freq": 256}
STUDY = {
    "episodes": 2,
    "evaluation_seed": 1000,
    "cells": {
        # PPO refuses n_steps * n_envs = 1 when it is built: this cell fails, the next one runs.
        "ppo_fails": dict(
            env="drake_tooluse/ToolPush-v1",
            algo="ppo",
            timesteps=512,
            seeds=[0],
            hyperparams={**TINY, "n_steps": 1},
        ),
        "a2c_tiny": dict(
            env="drake_tooluse/ToolPush-v1",
            algo="a2c",
            timesteps=4000,
            seeds=[0],
            hyperparams=TINY,
        ),
    },
}
REPORTED = "report made again"


def _command(tmp_path) -> list[str]:
    cells = tmp_path / "tiny.yaml"
    cells.write_text(json.dumps(STUDY))  # JSON is YAML
    out = ["--out", str(tmp_path / "study"), "--cells", str(cells), "--archive-every", "0.5"]
    return [sys.executable, "-m", "drake_tooluse.cli", "study", *out]


def _wait_for(path: Path, process, timeout_s: float = 240) -> None:
    deadline = time.monotonic() + timeout_s
    while not path.is_file():
        assert process.poll() is None, f"the job ended before {path} appeared"
        assert time.monotonic() < deadline, f"timed out waiting for {path}"
        time.sleep(0.05)


@pytest.mark.slow
def test_the_study_records_failures_resumes_after_a_kill_and_reports(tmp_path):
    cmd = _command(tmp_path)
    study = tmp_path / "study"
    results_file = study / "paper_study.json"
    run = study / "runs" / "a2c_tiny" / "s0"
    archived = study / "paper_study" / "a2c_tiny" / "s0"
    # 1. Killed (SIGKILL, the whole process group) once the A2C run's checkpoint is archived;
    # then the machine is lost: only the archive is left.
    job = subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    _wait_for(archived / "checkpoints" / "latest.json", job)
    os.killpg(job.pid, signal.SIGKILL)
    job.wait(timeout=60)
    latest = archived / "checkpoints" / "latest.json"
    checkpointed = json.loads(latest.read_text())["timesteps"]
    assert checkpointed < 4000 and not (archived / "summary.json").is_file()
    assert not list(archived.rglob("events.out.tfevents.*"))  # what the report needs, only
    shutil.rmtree(study / "runs")
    # The failed cell was recorded before the job moved on to the next one.
    results = json.loads(results_file.read_text())
    error = results["ppo_fails"]["seeds"]["0"]["error"]
    assert "n_steps * n_envs` must be greater than 1" in error and "\n" not in error
    assert "a2c_tiny" not in results

    # 2. Re-run: the killed run resumes from its checkpoint and is evaluated; one report, for
    # that run (none for the failed one, which fails again: exit code 3).
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 3, done.stdout + done.stderr
    assert done.stderr.count(REPORTED) == 1 and (study / "TRAINING.md").is_file()
    entry = json.loads(results_file.read_text())["a2c_tiny"]["seeds"]["0"]
    assert entry["train"]["timesteps"] >= 4000 and entry["train"]["sessions"] == 2
    assert entry["train"]["resumes"][0]["from_timesteps"] >= checkpointed
    assert len(entry["evaluate_best"]["per_episode"]["success"]) == 2
    assert entry["evaluate_best_time_limit"]["to_time_limit"]
    assert entry["evaluate_best_time_limit"]["episode_length_mean"] == 100
    assert "--to-time-limit" in entry["evaluate_time_limit_command"]
    assert "--resume" in done.stderr  # the log shows the command that continued it
    assert f"restored {run}" in done.stderr
    assert "a2c_tiny           seed 0: done" in done.stdout  # the runs' states, at the end
    assert "ppo_fails          seed 0: failed: " in done.stdout
    # The finished run's archive holds what the report needs, and no checkpoint.
    assert (archived / "best" / "policy.json").is_file()
    assert (archived / "logs" / "progress.csv").is_file()
    assert json.loads((archived / "summary.json").read_text())["timesteps"] >= 4000
    assert not (archived / "checkpoints").exists()

    # 3. Re-run again: nothing trained, nothing evaluated, no report; the entry unchanged.
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert again.returncode == 3, again.stdout + again.stderr
    assert REPORTED not in again.stderr and "a2c_tiny seed 0: drake-tooluse" not in again.stderr
    assert json.loads(results_file.read_text())["a2c_tiny"]["seeds"]["0"] == entry

    # 4. A new machine with the archive: restored, nothing trained. Without it (the files
    # lost altogether): the evaluated run trains again and is evaluated anew.
    shutil.rmtree(study / "runs")
    restored = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert restored.returncode == 3, restored.stdout + restored.stderr
    assert REPORTED not in restored.stderr
    assert "a2c_tiny seed 0: drake-tooluse" not in restored.stderr
    assert json.loads(results_file.read_text())["a2c_tiny"]["seeds"]["0"] == entry
    shutil.rmtree(study / "runs")
    shutil.rmtree(study / "paper_study")
    lost = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert lost.returncode == 3, lost.stdout + lost.stderr
    assert "its files were lost; trains again" in lost.stderr and "--out" in lost.stderr
    assert lost.stderr.count(REPORTED) == 1 and (archived / "best" / "policy.json").is_file()
