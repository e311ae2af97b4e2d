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


@pytest.mark.slow
def test_random_sigkills_and_resumes_give_one_runs_history(tmp_path):
    rng = random.Random(0)
    reference = tmp_path / "reference"
    assert subprocess.run(_command(reference, False), capture_output=True).returncode == 0
    out, kills = tmp_path / "killed", 0
    resume = False
    for _ in range(30):
        proc = subprocess.Popen(
            _command(out, resume),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        time.sleep(rng.uniform(3.5, 6.0))  # start-up is ~3 s: most kills land in training
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            kills += 1
        proc.wait()
        resume = resume or (out / "config.json").exists()
        if (out / "summary.json").exists() and read_json(out / "summary.json")[
            "timesteps"
        ] >= STEPS:
            break
    assert kills >= 3, "the run finished before it was killed often enough"
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
