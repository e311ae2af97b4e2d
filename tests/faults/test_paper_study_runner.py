"""The paper study's runner (benchmarks/paper_experiments.py) survives the machine: a cell that
fails is recorded and the job goes on; a job killed mid-run (its whole process group, SIGKILL)
on a machine that is then lost (its run directories deleted) resumes that run, on a new one,
from the checkpoint archived in the repo; a finished run is not trained again; a run whose
files are lost altogether trains again; the report is regenerated after each run that
finished in the job. Tiny cells stand in for the study's (slow: ~1.5 min)."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TINY = {"n_envs": 1, "eval_freq": 10_000_000, "eval_episodes": 1, "checkpoint_freq": 256}
CELLS = {
    # PPO refuses n_steps * n_envs = 1 when it is built: this cell fails, the next one runs.
    "ppo_fails": dict(
        env="drake_tooluse/ToolPush-v0",
        algo="ppo",
        timesteps=512,
        seeds=[0],
        hyperparams={**TINY, "n_steps": 1},
    ),
    "a2c_tiny": dict(
        env="drake_tooluse/ToolPush-v0", algo="a2c", timesteps=4000, seeds=[0], hyperparams=TINY
    ),
}
# The runner with the tiny cells, 2 evaluation episodes, and a report that only says it ran
# (the real one writes docs/TRAINING.md).
WRAPPER = """
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("paper_experiments", sys.argv[1])
m = importlib.util.module_from_spec(spec)
sys.modules["paper_experiments"] = m
spec.loader.exec_module(m)
m.CELLS.clear()
m.CELLS.update(json.loads(sys.argv[2]))
m.EPISODES = 2
m.ARCHIVE_EVERY = 0.5
m.report = lambda runs_dir, results: print("REPORT", flush=True)
sys.argv = ["paper_experiments.py", *sys.argv[3:]]
sys.exit(m.main())
"""


def _runner(tmp_path) -> list[str]:
    script = tmp_path / "runner.py"
    script.write_text(WRAPPER)
    runner = str(ROOT / "benchmarks" / "paper_experiments.py")
    args = ["--runs-dir", str(tmp_path / "runs"), "--out", str(tmp_path / "study.json")]
    args += ["--archive", str(tmp_path / "archive")]
    return [sys.executable, str(script), runner, json.dumps(CELLS), *args]


def _wait_for(path: Path, process, timeout_s: float = 240) -> None:
    deadline = time.monotonic() + timeout_s
    while not path.is_file():
        assert process.poll() is None, f"the runner ended before {path} appeared"
        assert time.monotonic() < deadline, f"timed out waiting for {path}"
        time.sleep(0.05)


@pytest.mark.slow
def test_the_study_runner_records_failures_resumes_after_a_kill_and_reports(tmp_path):
    cmd = _runner(tmp_path)
    study = tmp_path / "study.json"
    run = tmp_path / "runs" / "a2c_tiny" / "s0"
    archived = tmp_path / "archive" / "a2c_tiny" / "s0"
    # 1. Killed (SIGKILL, the whole process group) once the A2C run's checkpoint is archived;
    # then the machine is lost: only the archive (the repo) is left.
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
    shutil.rmtree(tmp_path / "runs")
    # The failed cell was recorded before the job moved on to the next one.
    results = json.loads(study.read_text())
    error = results["ppo_fails"]["seeds"]["0"]["error"]
    assert "n_steps * n_envs` must be greater than 1" in error and "\n" not in error
    assert "a2c_tiny" not in results

    # 2. Re-run: the killed run resumes from its checkpoint and is evaluated; one report, for
    # that run (none for the failed one).
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("REPORT") == 1
    entry = json.loads(study.read_text())["a2c_tiny"]["seeds"]["0"]
    assert entry["train"]["timesteps"] >= 4000 and entry["train"]["sessions"] == 2
    assert entry["train"]["resumes"][0]["from_timesteps"] >= checkpointed
    assert len(entry["evaluate_best"]["per_episode"]["success"]) == 2
    assert entry["evaluate_best_time_limit"]["to_time_limit"]
    assert entry["evaluate_best_time_limit"]["episode_length_mean"] == 100
    assert "--to-time-limit" in entry["evaluate_time_limit_command"]
    assert "--resume" in done.stdout  # the log shows the command that continued it
    assert f"restored {run}" in done.stdout
    # The finished run's archive holds what the report needs, and no checkpoint.
    assert (archived / "best" / "policy.json").is_file()
    assert (archived / "logs" / "progress.csv").is_file()
    assert json.loads((archived / "summary.json").read_text())["timesteps"] >= 4000
    assert not (archived / "checkpoints").exists()

    # 3. Re-run again: nothing trained, nothing evaluated, no report; the entry unchanged.
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "REPORT" not in again.stdout and "a2c_tiny seed 0: drake-tooluse" not in again.stdout
    assert json.loads(study.read_text())["a2c_tiny"]["seeds"]["0"] == entry

    # 4. A new machine with the archive: restored, nothing trained. Without it (the files
    # lost altogether): the evaluated run trains again and is evaluated anew.
    shutil.rmtree(tmp_path / "runs")
    restored = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert restored.returncode == 0, restored.stdout + restored.stderr
    assert "REPORT" not in restored.stdout
    assert "a2c_tiny seed 0: drake-tooluse" not in restored.stdout
    assert json.loads(study.read_text())["a2c_tiny"]["seeds"]["0"] == entry
    shutil.rmtree(tmp_path / "runs")
    shutil.rmtree(tmp_path / "archive")
    lost = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert lost.returncode == 0, lost.stdout + lost.stderr
    assert "its files were lost; trains again" in lost.stdout and "--out" in lost.stdout
    assert lost.stdout.count("REPORT") == 1 and (archived / "best" / "policy.json").is_file()
