"""Training and evaluation: a smoke run per algorithm, resume after SIGKILL, evaluate, bad input."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import drake_tooluse
from drake_tooluse.cli import main
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.learning.train import train

ENV = "drake_tooluse/ToolPush-v1"
TINY = {"eval_freq": 10_000_000, "checkpoint_freq": 512, "eval_episodes": 1}
PER_ALGO = {
    "ppo": {"n_steps": 256, "batch_size": 64, "n_epochs": 1},
    "a2c": {"n_steps": 8},
    "trpo": {"n_steps": 256, "batch_size": 64},
    "ddpg": {"learning_starts": 200, "buffer_size": 5000},
}


# PPO by default; A2C (~4 s), DDPG (~20 s, its replay buffer) and TRPO (~6 s) slow, run by
# .ci/run.
SLOW_ALGOS = ("a2c", "ddpg", "trpo")


@pytest.mark.parametrize(
    "algo", [pytest.param(a, marks=pytest.mark.slow) if a in SLOW_ALGOS else a for a in PER_ALGO]
)
def test_smoke_run_per_algorithm(algo, tmp_path):
    config = resolve_config(ENV, algo, 1000, 1, 0, overrides={**TINY, **PER_ALGO[algo]})
    summary = train(config, tmp_path / "run", progress_bar=False)
    assert summary["timesteps"] >= 1000
    # The code it was made with: this checkout's commit (None where installed from a wheel).
    code = summary["code"]
    assert code["version"] == drake_tooluse.__version__
    assert code["commit"] is None or re.fullmatch(r"[0-9a-f]{40}", code["commit"])
    for sub in ("final", "best"):
        assert (tmp_path / "run" / sub / "policy.safetensors").is_file()
        assert not list((tmp_path / "run" / sub).glob("*.pkl"))
    assert (tmp_path / "run" / "logs" / "progress.csv").is_file()
    assert list((tmp_path / "run" / "logs").glob("events.out.tfevents.*"))
    policy = load_policy(tmp_path / "run" / "final")
    assert policy.meta.algo == algo and policy.meta.action_shape == [3]


@pytest.mark.slow  # ~30 s; .ci/run runs it
def test_resume_after_sigkill_loses_at_most_one_checkpoint_interval(tmp_path):
    out = tmp_path / "run"
    hp = json.dumps({**TINY, **PER_ALGO["ppo"]})
    args = [
        sys.executable,
        "-m",
        "drake_tooluse.cli",
        "train",
        "--env",
        ENV,
        "--algo",
        "ppo",
        "--timesteps",
        "3072",
        "--n-envs",
        "1",
        "--seed",
        "1",
        "--out",
        str(out),
        "--hyperparams",
        hp,
        "--no-progress",
    ]
    proc = subprocess.Popen(
        args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    latest = out / "checkpoints" / "latest.json"
    deadline = time.time() + 120
    while time.time() < deadline and not (
        latest.is_file() and json.loads(latest.read_text())["timesteps"] >= 1024
    ):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    saved = json.loads(latest.read_text())["timesteps"]
    assert 1024 <= saved < 3072
    resume = args[: args.index("--out")] + [
        "--resume",
        str(out),
        "--hyperparams",
        hp,
        "--no-progress",
    ]
    assert subprocess.run(resume, capture_output=True).returncode == 0
    assert json.loads(latest.read_text())["timesteps"] >= 3072
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timesteps"] >= 3072 and summary["resumes"][0]["from_timesteps"] == saved


def test_a_hyperparameter_the_algorithm_does_not_take(tmp_path):
    with pytest.raises(ValueError, match=r"unknown hyperparameter\(s\) \['batch_size'\] for a2c"):
        resolve_config(ENV, "a2c", 100, 1, 0, overrides={**TINY, "batch_size": 64})
    # A value the algorithm refuses is found before anything is written.
    config = resolve_config(ENV, "ppo", 100, 1, 0, overrides={**TINY, "n_steps": 1})
    with pytest.raises(ValueError, match="bad hyperparameters for ppo"):
        train(config, tmp_path / "run", progress_bar=False)
    assert not (tmp_path / "run" / "config.json").exists()


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_resume_with_different_hyperparameters_is_refused(tmp_path):
    config = resolve_config(ENV, "ppo", 300, 1, 0, overrides={**TINY, **PER_ALGO["ppo"]})
    train(config, tmp_path / "run", progress_bar=False)
    changed = resolve_config(
        ENV, "ppo", 600, 1, 0, overrides={**TINY, **PER_ALGO["ppo"], "learning_rate": 0.1}
    )
    with pytest.raises(ValueError, match=r"different settings.*learning_rate"):
        train(changed, tmp_path / "run", resume=True, progress_bar=False)
    with pytest.raises(FileExistsError, match="already holds a run"):
        train(config, tmp_path / "run", progress_bar=False)


@pytest.fixture(scope="module")
def tiny_policy(tmp_path_factory):
    out = tmp_path_factory.mktemp("policy") / "run"
    config = resolve_config(ENV, "ppo", 300, 1, 0, overrides={**TINY, **PER_ALGO["ppo"]})
    train(config, out, progress_bar=False)
    return out / "final"


def test_evaluate_json_is_reproducible(tiny_policy, capsys):
    argv = ["evaluate", "--policy", str(tiny_policy), "--episodes", "2", "--seed", "3", "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out) == first
    for key in (
        "final_object_to_goal_mean_m",
        "final_object_to_goal_median_m",
        "final_object_to_goal_std_m",
        "success_rate",
        "object_travel_mean_m",
        "episode_length_mean",
    ):
        assert key in first


def test_mismatched_policy_is_a_clear_error(tiny_policy):
    with pytest.raises(ValueError, match=r"trained for observations \[30\] and actions \[3\]"):
        evaluate(tiny_policy, episodes=1, env_kwargs={"action_mode": "position_quaternion"})


def test_init_from_a_policy_of_other_spaces_is_refused_before_training(tiny_policy, tmp_path):
    overrides = {**TINY, **PER_ALGO["ppo"], "env_kwargs": {"action_mode": "position_quaternion"}}
    config = resolve_config(ENV, "ppo", 300, 1, 0, str(tiny_policy), overrides=overrides)
    with pytest.raises(
        ValueError,
        match=r"init_from \(--init-from\) '.*final' was trained for "
        r"observations \[30\] and actions \[3\], but this env has observations "
        r"\[30\] and actions \[7\]",
    ):
        train(config, tmp_path / "run", progress_bar=False)
    assert not (tmp_path / "run" / "checkpoints").exists()


def test_corrupt_or_missing_policy_is_a_clear_error(tiny_policy, tmp_path):
    with pytest.raises(FileNotFoundError, match="not a policy directory"):
        load_policy(tmp_path / "missing")
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "policy.json").write_text((Path(tiny_policy) / "policy.json").read_text())
    (broken / "normalization.json").write_text(
        (Path(tiny_policy) / "normalization.json").read_text()
    )
    (broken / "policy.safetensors").write_bytes(b"not safetensors")
    with pytest.raises(ValueError, match="cannot load"):
        load_policy(broken)


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["train", "--algo", "sac", "--out", "x"],
            "unknown algorithm 'sac'; choose one of ['ppo', 'a2c', 'ddpg', 'trpo']",
        ),
        (["train", "--env", "Nope-v0", "--out", "x"], "unknown env 'Nope-v0'; choose one of"),
        (
            ["train", "--env", "drake_tooluse/ToolPull-v0", "--out", "x"],
            "is an earlier version of 'drake_tooluse/ToolPull-v1', no longer registered: it and "
            "its figures are reproducible at git tag figures-v0",
        ),
        (["train", "--timesteps", "0", "--out", "x"], "--timesteps=0 is outside the allowed range"),
        (["train"], "give --out DIR for a new run"),
        (["evaluate", "--policy", "/nonexistent"], "is not a policy directory"),
    ],
)
def test_train_and_evaluate_bad_input(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow  # ~1.2-2.4 s: with the slow tests CI runs
def test_resume_with_flags_that_match_the_run_takes_the_rest_from_it(tmp_path, capsys):
    """`train --resume RUN --algo ppo --env ITS_ENV`: the settings not given are the run's
    (it was refused, "hyperparams.n_envs: saved 1, asked 2", for a value never given)."""
    from drake_tooluse.cli import main

    out = str(tmp_path / "run")
    hyperparams = json.dumps({**TINY, **PER_ALGO["ppo"]})
    first = ["train", "--env", ENV, "--algo", "ppo", "--timesteps", "256", "--n-envs", "1"]
    assert main([*first, "--hyperparams", hyperparams, "--out", out, "--no-progress"]) == 0
    again = ["train", "--resume", out, "--algo", "ppo", "--env", ENV, "--timesteps", "512"]
    assert main([*again, "--no-progress"]) == 0, capsys.readouterr().err
