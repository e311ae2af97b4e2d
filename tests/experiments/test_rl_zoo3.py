"""The rl-baselines3-zoo hyperparameter file (`learning/hyperparams/rl_zoo3.yaml`, read with
`python -m rl_zoo3.train --conf-file`) holds the project's values (ppo.yaml's), and rl-zoo3
reads it as meant, evaluations included (skipped where rl_zoo3 is not installed: the bench and
test extras hold it)."""

import argparse
import ast
import itertools
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from drake_tooluse.learning.config import RUN_KEYS, load_hyperparams
from drake_tooluse.paths import HYPERPARAMS_DIR
from drake_tooluse.tasks.push.registration import ENV_IDS

CONF = HYPERPARAMS_DIR / "rl_zoo3.yaml"
# The training page of the user guide, which shows the rl_zoo3 command line.
GUIDE = Path(__file__).resolve().parents[2] / "docs" / "guide" / "training.md"
# Run settings rl-zoo3 takes as flags, not from the file: ours -> its flag.
ZOO_FLAGS = {
    "eval_freq": "--eval-freq",
    "eval_episodes": "--eval-episodes",
    "checkpoint_freq": "--save-freq",
}


def _train_default_timesteps() -> int:
    """`train --timesteps`' default for a new run."""
    from drake_tooluse.cli.learning import DEFAULT_TIMESTEPS

    return DEFAULT_TIMESTEPS


def _expected(env_id: str) -> dict:
    hp = load_hyperparams("ppo", env_id)
    return {
        "n_timesteps": _train_default_timesteps(),
        **{k: v for k, v in hp.items() if k not in ZOO_FLAGS},
    }


def test_the_rl_zoo3_file_holds_the_projects_ppo_hyperparameters():
    conf = yaml.safe_load(CONF.read_text())
    assert set(conf) == set(ENV_IDS)
    for env_id in ENV_IDS:
        assert conf[env_id] == _expected(env_id), env_id


def test_the_guide_and_the_file_give_rl_zoo3_the_run_settings_as_flags():
    hp = load_hyperparams("ppo", "drake_tooluse/ToolPush-v1")
    flags = " ".join(f"{flag} {hp[key]}" for key, flag in ZOO_FLAGS.items())
    guide = " ".join(GUIDE.read_text().split())
    commands = re.findall(r"python -m rl_zoo3\.train [^`\n]*", guide)
    assert commands, "docs/guide/training.md shows no rl_zoo3 command"
    assert all("--conf-file drake_tooluse/learning/hyperparams/rl_zoo3.yaml" in c for c in commands)
    assert all("--gym-packages drake_tooluse" in c and flags in c for c in commands)
    header = " ".join(
        line.lstrip("# ") for line in CONF.read_text().splitlines() if line[:1] == "#"
    )
    assert flags in " ".join(header.replace("\\", " ").split())


def _guide_env_kwargs() -> dict:
    """The training guide's `--env-kwargs` for rl_zoo3, read as rl_zoo3 reads them (`key:value`, the
    value a Python literal)."""
    guide = " ".join(GUIDE.read_text().split())
    (command,) = re.findall(r"python -m rl_zoo3\.train [^`\n]*?(?=```|$)", guide)
    words = shlex.split(command)
    start = words.index("--env-kwargs") + 1
    pairs = itertools.takewhile(lambda w: not w.startswith("-"), words[start:])
    return {key: ast.literal_eval(value) for key, value in (w.split(":", 1) for w in pairs)}


def test_the_guide_gives_rl_zoo3_the_files_env_kwargs_for_both_envs():
    # rl_zoo3 builds its evaluation env from the command line's env kwargs only: the guide's
    # must be the file's, or its first evaluation meets the wrong action space.
    conf = yaml.safe_load(CONF.read_text())
    assert _guide_env_kwargs() == conf["drake_tooluse/ToolPush-v1"]["env_kwargs"]


def test_rl_zoo3_reads_the_file_into_the_projects_run(tmp_path):
    pytest.importorskip("rl_zoo3")
    from rl_zoo3.exp_manager import ExperimentManager

    import drake_tooluse  # noqa: F401  (registers the env ids, as --gym-packages does)

    env_id = "drake_tooluse/ToolPush-v1"
    manager = ExperimentManager(
        args=argparse.Namespace(),
        algo="ppo",
        env_id=env_id,
        log_folder=str(tmp_path),
        config=str(CONF),
        verbose=0,
    )
    hyperparams, _ = manager.read_hyperparameters()
    kwargs, *_ = manager._preprocess_hyperparams(hyperparams)
    ours = load_hyperparams("ppo", env_id)
    assert manager.n_envs == ours["n_envs"] and manager.env_kwargs == ours["env_kwargs"]
    assert manager.normalize is True and manager.normalize_kwargs == {"gamma": ours["gamma"]}
    assert manager.n_timesteps == _train_default_timesteps()
    algorithm = {k: getattr(v, "val", v) for k, v in kwargs.items()}  # constant schedules
    assert algorithm.pop("policy") == ours["policy"]
    assert algorithm == {k: v for k, v in ours.items() if k not in RUN_KEYS}


@pytest.mark.slow
def test_rl_zoo3_trains_the_env_with_the_file(tmp_path):
    pytest.importorskip("rl_zoo3")
    command = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "ppo",
        "--env",
        "drake_tooluse/ToolPush-v1",
        "--gym-packages",
        "drake_tooluse",
        "--conf-file",
        str(CONF),
        "-n",
        "256",
        "--hyperparams",
        "n_steps:128",
        "batch_size:64",
        "--env-kwargs",
        *(f"{key}:{value!r}" for key, value in _guide_env_kwargs().items()),
        "--eval-freq",
        "128",
        "--eval-episodes",
        "1",
        "-f",
        str(tmp_path),
        "--seed",
        "0",
    ]
    done = subprocess.run(
        command,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "CUDA_VISIBLE_DEVICES": ""},
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"Loading hyperparameters from: {CONF}" in done.stdout
    assert "Eval num_timesteps=" in done.stdout  # an evaluation ran, with the file's env kwargs
    (run,) = (tmp_path / "ppo").iterdir()
    assert (run / "drake_tooluse-ToolPush-v1.zip").is_file()
    # rl-zoo3 saves what it ran with as a tagged OrderedDict: read its pairs without the tag.
    text = (run / "drake_tooluse-ToolPush-v1" / "config.yml").read_text()
    (pairs,) = yaml.safe_load(text.split("\n", 1)[1])  # the OrderedDict(...) call's argument
    saved = dict(pairs)
    assert saved["learning_rate"] == 0.0003 and saved["n_epochs"] == 10 and saved["n_steps"] == 128
