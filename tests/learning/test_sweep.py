"""The sweep on Ray Tune (the `cluster` extra, also in `test`): a failed cell is reported while
the others finish; on a 2-node cluster a killed worker's cell continues from its checkpoint on
another node; a killed sweep resumes, keeping finished cells (the last two are slow)."""

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

import pytest

from drake_tooluse.cli import main

ray = pytest.importorskip("ray")
pytest.importorskip("ray.tune")

TINY = {"n_envs": 1, "eval_freq": 10_000_000, "eval_episodes": 1, "checkpoint_freq": 256}


def _rows(out):
    return {(r["algo"], r["seed"]): r for r in json.loads((out / "sweep.json").read_text())}


def _trials(out, algo):
    """Tune's trial directories of `algo`'s cells (their params.json names the cell)."""
    return [
        d
        for d in out.glob("tune-*/*")
        if (d / "params.json").is_file()
        and json.loads((d / "params.json").read_text())["cell"]["algo"] == algo
    ]


def _wait_for(paths, timeout_s=240):
    deadline = time.monotonic() + timeout_s
    while not all(p.is_file() for p in paths):
        assert time.monotonic() < deadline, f"timed out waiting for {paths}"
        time.sleep(0.2)


@pytest.mark.slow  # ~45 s: a Ray sweep; .ci/run runs it
def test_a_failed_cell_is_reported_and_the_others_finish(tmp_path, capsys):
    # PPO refuses n_steps * n_envs = 1 when it is built (inside the cell); A2C takes it. The
    # refusal is deterministic: the cell ends with it (no trial error), and is not retried.
    hp = {**TINY, "n_steps": 1}
    argv = ["sweep", "--algos", "ppo", "a2c", "--timesteps", "256", "--out", str(tmp_path)]
    argv += ["--num-cpus", "2", "--episodes", "1", "--max-failures", "2"]
    assert main([*argv, "--hyperparams", json.dumps(hp), "--json"]) == 3
    out = json.loads(capsys.readouterr().out)
    rows = {r["algo"]: r for r in out["runs"]}
    assert rows["ppo"]["status"] == "failed"
    assert "n_steps * n_envs` must be greater than 1" in rows["ppo"]["error"]
    assert "\n" not in rows["ppo"]["error"]
    assert rows["a2c"]["status"] == "finished" and rows["a2c"]["timesteps"] >= 256
    # Everything of the finished cell is under --out (it trained in a scratch directory).
    run = tmp_path / rows["a2c"]["run"]
    for name in ("cell.json", "summary.json", "best/policy.json", "final/policy.json"):
        assert (run / name).is_file(), name
    assert json.loads((tmp_path / "sweep.json").read_text()) == out["runs"]
    # Tune saw the PPO cell end without an error (so it retried nothing): its one result is
    # the refusal.
    (trial,) = _trials(tmp_path, "ppo")
    assert not list(trial.glob("error.*"))
    results = [json.loads(line) for line in (trial / "result.json").read_text().splitlines()]
    assert len(results) == 1 and "must be greater than 1" in results[0]["refused"]
    table = (tmp_path / "sweep.md").read_text().splitlines()
    assert len(table) == 4 and "| failed: ValueError" in table[2] and "| finished |" in table[3]
    # A new sweep into the same directory is refused; --resume names it.
    assert main(["sweep", "--out", str(tmp_path)]) == 2
    assert f"--out '{tmp_path}' already holds a sweep; continue it with --resume" in (
        capsys.readouterr().err
    )


def test_a_cell_s_scratch_left_by_a_killed_process_is_removed(tmp_path, monkeypatch):
    from drake_tooluse.learning.sweep import SCRATCH_PREFIX, scratch_dir

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    host = socket.gethostname()
    stale = tmp_path / f"{SCRATCH_PREFIX}{host}_pid{gone.pid}_abc"
    kept = [
        tmp_path / f"{SCRATCH_PREFIX}{host}_pid{os.getpid()}_def",  # a live process's
        tmp_path / f"{SCRATCH_PREFIX}otherhost_pid{gone.pid}_ghi",  # another host's
        tmp_path / f"{SCRATCH_PREFIX}{gone.pid}_jk",  # an older name (mkdtemp's random part)
    ]
    for d in (stale, *kept):
        (d / "run").mkdir(parents=True)
    new = scratch_dir()
    assert not stale.exists() and all(d.is_dir() for d in kept)
    assert new.parent == tmp_path
    assert new.name.startswith(f"{SCRATCH_PREFIX}{host}_pid{os.getpid()}_")


def test_resume_refuses_a_second_grid(tmp_path, capsys):
    assert main(["sweep", "--resume", str(tmp_path), "--algos", "a2c"]) == 2
    assert "leave out --algos" in capsys.readouterr().err
    assert main(["sweep", "--resume", str(tmp_path)]) == 2
    assert "nothing to resume" in capsys.readouterr().err


def test_cells_too_large_for_the_cpus_are_refused_before_ray_starts(tmp_path, capsys):
    argv = ["sweep", "--out", str(tmp_path), "--num-cpus", "1", "--hyperparams", '{"n_envs": 2}']
    assert main(argv) == 2
    assert "reserves 2 CPUs, but num_cpus (--num-cpus) gives 1" in capsys.readouterr().err
    assert not (tmp_path / "sweep_config.json").exists()


@pytest.mark.slow
def test_on_two_nodes_a_killed_worker_s_cell_continues_and_a_failed_cell_is_reported(tmp_path):
    """Two 1-CPU nodes; A2C seeds 0 and 1 start one on each; the worker node is removed once
    both have a checkpoint on the driver's disk. PPO refuses the grid's n_steps · n_envs = 1
    when it is built: its two cells fail (refused, not retried) while the A2C cells finish."""
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    worker = cluster.add_node(num_cpus=1)
    cluster.wait_for_nodes()
    head_id, worker_id = cluster.head_node.node_id, worker.node_id
    runs = tmp_path / "runs"
    latest = [runs / f"a2c_ToolPush-v1_s{s}" / "checkpoints" / "latest.json" for s in (0, 1)]

    saved = {}

    def kill_the_worker():  # once both A2C cells (one on each node) have a checkpoint here
        _wait_for(latest)
        saved.update({p.parent.parent.name: json.loads(p.read_text())["timesteps"] for p in latest})
        cluster.remove_node(worker)

    killer = threading.Thread(target=kill_the_worker)
    killer.start()
    try:
        argv = ["sweep", "--algos", "a2c", "ppo", "--seeds", "0", "1", "--timesteps", "3000"]
        argv += ["--out", str(tmp_path), "--address", cluster.address, "--episodes", "1"]
        argv += ["--max-failures", "1", "--hyperparams", json.dumps({**TINY, "n_steps": 1})]
        assert main(argv) == 3  # a cell failed
    finally:
        killer.join()
        cluster.shutdown()
    rows = _rows(tmp_path)
    for seed in (0, 1):
        assert rows[("ppo", seed)]["status"] == "failed"
        assert "n_steps * n_envs` must be greater than 1" in rows[("ppo", seed)]["error"]
    a2c = [rows[("a2c", seed)] for seed in (0, 1)]
    assert all(r["status"] == "finished" and r["timesteps"] >= 3000 for r in a2c)
    resumed = [r for r in a2c if r["resumes"]]
    assert len(resumed) == 1, "the killed cell continued from its checkpoint, the other did not"
    (r,) = resumed
    # It continued from the checkpoint it had sent before the kill (or a later one), not
    # from an older copy or from the start.
    assert r["resumes"][0]["from_timesteps"] >= saved[r["run"].split("/")[-1]] >= 256
    first = json.loads((tmp_path / r["run"] / "config.json").read_text())["command"]
    assert f"on node {worker_id}" in first and f"on node {head_id}" in r["resumes"][0]["command"]
    assert r["node_id"] == head_id


@pytest.mark.slow
def test_a_killed_sweep_resumes_keeping_finished_cells(tmp_path):
    out = tmp_path / "sweep"
    hp = json.dumps({**TINY, "n_steps": 128})
    cmd = [sys.executable, "-m", "drake_tooluse.cli", "sweep", "--algos", "a2c", "ppo"]
    cmd += ["--timesteps", "4000", "--out", str(out), "--num-cpus", "2", "--episodes", "1"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([*cmd, "--hyperparams", hp], env=env, start_new_session=True)
    cells = [out / "runs" / f"{algo}_ToolPush-v1_s0" for algo in ("a2c", "ppo")]
    deadline = time.monotonic() + 240
    try:  # until one cell has finished and the other has a checkpoint
        while not any(
            (done / "cell.json").is_file()
            and (other / "checkpoints" / "latest.json").is_file()
            and not (other / "cell.json").exists()
            for done, other in (cells, cells[::-1])
        ):
            assert time.monotonic() < deadline and proc.poll() is None, "no state to kill in"
            time.sleep(0.1)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    done, other = cells if (cells[0] / "cell.json").is_file() else cells[::-1]
    assert not (other / "cell.json").exists()
    finished = (done / "cell.json").read_bytes()
    assert main(["sweep", "--resume", str(out), "--num-cpus", "2"]) == 0
    assert (done / "cell.json").read_bytes() == finished, "a finished cell was run again"
    row = json.loads((other / "cell.json").read_text())
    assert row["status"] == "finished" and row["timesteps"] >= 4000
    assert row["resumes"][0]["from_timesteps"] >= 256
    assert len(_rows(out)) == 2


def test_a_ray_client_address_is_refused(tmp_path, capsys):
    # The driver's disk holds OUT; through Ray Client it would be the head's.
    assert main(["sweep", "--out", str(tmp_path), "--address", "ray://head:10001"]) == 2
    assert "is a Ray Client address, which is not supported" in capsys.readouterr().err
