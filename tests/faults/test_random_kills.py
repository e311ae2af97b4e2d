"""`drake-tooluse train` SIGKILLed at random moments, resumed each time: the finished run's
history is one run's (slow: real processes, real kills)."""

import json
import os
import random
import signal
import subprocess
import sys
import time

import pytest

from drake_tooluse.learning.train import checkpoint_dirs
from tests.faults.common import TINY, csv_steps, evaluations, orphans, read_json

STEPS = 6144
KILLS = 6


def _finished(out) -> bool:
    return (out / "summary.json").exists() and read_json(out / "summary.json")["timesteps"] >= STEPS


def _command(out, resume: bool) -> list[str]:
    return [
        sys.executable,
        "-m",
        "drake_tooluse.cli",
        "train",
        "--algo",
        "ppo",
        "--timesteps",
        str(STEPS),
        "--n-envs",
        "1",
        "--seed",
        "4",
        "--resume" if resume else "--out",
        str(out),
        "--hyperparams",
        json.dumps(TINY),
        "--no-progress",
    ]


def _rows(out) -> int:
    path = out / "logs" / "progress.csv"
    try:
        return len(csv_steps(path))
    except (OSError, KeyError, ValueError):  # not there yet, or a row half written
        return 0


def _wait_for_training(proc, out, timeout: float = 300.0) -> float:
    """Seconds until `proc` logs a new progress row (a rollout trained) or ends."""
    start, rows = time.monotonic(), _rows(out)
    while proc.poll() is None and _rows(out) <= rows:
        assert time.monotonic() - start < timeout, "no training within the timeout"
        time.sleep(0.02)
    return time.monotonic() - start


@pytest.mark.slow
def test_random_sigkills_and_resumes_give_one_runs_history(tmp_path):
    rng = random.Random(0)
    reference = tmp_path / "reference"
    proc = subprocess.Popen(_command(reference, False), stdout=subprocess.DEVNULL)
    _wait_for_training(proc, reference)
    started = time.monotonic()
    assert proc.wait() == 0
    # Each kill lands at a random moment of training (checkpoint writes included), however
    # long the machine takes to start a run: up to a third of the reference's training time
    # after the session's first rollout.
    training = time.monotonic() - started
    out, kills = tmp_path / "killed", 0
    resume = False
    for _ in range(KILLS):
        proc = subprocess.Popen(
            _command(out, resume),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        _wait_for_training(proc, out)
        time.sleep(rng.uniform(0.0, training / 3))
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            kills += 1
        proc.wait()
        resume = resume or (out / "config.json").exists()
        if _finished(out):
            break
    assert kills >= 3, "the run finished before it was killed often enough"
    if not _finished(out):  # the last session runs to its end unkilled
        assert subprocess.run(_command(out, resume), capture_output=True).returncode == 0
    summary = read_json(out / "summary.json")
    assert summary["timesteps"] == STEPS and summary["sessions"] >= 2
    assert csv_steps(out / "logs" / "progress.csv") == csv_steps(
        reference / "logs" / "progress.csv"
    )
    ours, theirs = evaluations(out), evaluations(reference)
    assert ours["timesteps"] == theirs["timesteps"]
    means = [sum(r) / len(r) for r in ours["results"]]
    assert read_json(out / "best" / "policy.json")["evaluation"]["mean_reward"] == pytest.approx(
        max(means)
    )
    assert orphans(out, out / "checkpoints", out / "logs") == []
    assert len(checkpoint_dirs(out)) == 1
