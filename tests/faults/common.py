"""Fault injection from outside the package: a process killed at a named moment (a forked
child that `os._exit`s, as SIGKILL leaves things: no cleanup, no `finally`), a RuntimeError or
a NaN state injected into Drake's simulator, booby-trapped files."""

import csv
import json
import os
import re
from pathlib import Path

import numpy as np
import torch

from drake_tooluse.learning.config import resolve_config

ENV = "drake_tooluse/ToolPush-v1"
# Rollouts of 64 steps, a checkpoint every 2 of them, an evaluation (1 episode) every 4.
TINY = {
    "n_steps": 64,
    "batch_size": 64,
    "n_epochs": 1,
    "checkpoint_freq": 128,
    "eval_freq": 256,
    "eval_episodes": 1,
}
# DDPG's: the same checkpoints and evaluations; learning from step 64, with a small network and
# a buffer that never fills in these runs (every transition stays to be compared).
TINY_DDPG = {
    "learning_starts": 64,
    "batch_size": 32,
    "buffer_size": 2048,
    "policy_kwargs": {"net_arch": [32, 32]},
    **{k: TINY[k] for k in ("checkpoint_freq", "eval_freq", "eval_episodes")},
}
KILLED = 137
ORPHAN = re.compile(r"\.tmp-\d+@")


def tiny_config(timesteps: int = 384, seed: int = 0, algo: str = "ppo", **overrides):
    tiny = {"ppo": TINY, "ddpg": TINY_DDPG}[algo]
    return resolve_config(ENV, algo, timesteps, 1, seed, overrides={**tiny, **overrides})


def run_killed(target, *args, **kwargs) -> int:
    """Runs `target(*args, **kwargs)` in a forked child and returns its exit code: KILLED when
    a fault planted in the child ended it with `die()`, 0 when it ran to the end."""
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 1
        try:
            torch.set_num_threads(1)
            target(*args, **kwargs)
            code = 0
        except BaseException:
            code = 1
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


def die() -> None:
    """What SIGKILL does to the writer: it stops here, and nothing after runs."""
    os._exit(KILLED)


def orphans(*folders) -> list[str]:
    return [
        p.name
        for f in folders
        if Path(f).is_dir()
        for p in Path(f).iterdir()
        if ORPHAN.search(p.name)
    ]


def csv_steps(path) -> list[int]:
    with open(path) as f:
        return [int(float(row["time/total_timesteps"])) for row in csv.DictReader(f)]


def csv_column(path, column) -> list[str]:
    with open(path) as f:
        return [row.get(column, "") for row in csv.DictReader(f)]


def evaluations(run: Path) -> dict:
    with np.load(run / "eval" / "evaluations.npz") as data:
        return {k: data[k].tolist() for k in data.files}


def read_json(path) -> dict:
    return json.loads(Path(path).read_text())
