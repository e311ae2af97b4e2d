"""A tiny grid on a local Ray instance (Ray: the `cluster` extra, also in `test`)."""

import json

import pytest

from drake_tooluse.cli import main

ray = pytest.importorskip("ray")


def test_tiny_grid_on_local_ray(tmp_path, capsys):
    hp = {
        "n_envs": 1,
        "n_steps": 128,
        "eval_freq": 10_000_000,
        "eval_episodes": 1,
        "checkpoint_freq": 10_000_000,
    }
    argv = [
        "sweep",
        "--algos",
        "ppo",
        "a2c",
        "--seeds",
        "0",
        "--timesteps",
        "256",
        "--out",
        str(tmp_path),
        "--num-cpus",
        "2",
        "--episodes",
        "1",
        "--hyperparams",
        json.dumps(hp),
        "--json",
    ]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert {(r["algo"], r["seed"]) for r in out["runs"]} == {("ppo", 0), ("a2c", 0)}
    assert all(r["timesteps"] >= 256 for r in out["runs"])
    table = (tmp_path / "sweep.md").read_text().splitlines()
    assert len(table) == 2 + 2 and table[0].startswith("| algo | env | seed |")
    assert json.loads((tmp_path / "sweep.json").read_text()) == out["runs"]


def test_unknown_algorithm_in_a_sweep(tmp_path, capsys):
    assert main(["sweep", "--algos", "sac", "--out", str(tmp_path)]) == 2
    assert "unknown algorithm 'sac'" in capsys.readouterr().err
