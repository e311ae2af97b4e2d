"""Interrupts and a full disk: Ctrl-C to `train`'s process group (its env processes included)
is exit 130 with one line, never a bug's EOFError; Ctrl-C to `sweep` is exit 130 with the
command that resumes it, and the cell that was training is listed `interrupted`, not
`pending`; the benchmark scripts end on Ctrl-C with one line; a disk that fills under `train`
is exit 2 naming the file (the slow ones run in .ci/run)."""

import ast
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from drake_tooluse.cli.common import EXIT_INTERRUPTED, run_script
from drake_tooluse.learning.checkpoint import latest_checkpoint
from tests.faults.common import TINY

ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "drake_tooluse.cli"]
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


def _start(argv, **kwargs):
    return subprocess.Popen(
        [*CLI, *map(str, argv)],
        env=ENV,
        start_new_session=True,  # its own process group, as a terminal's Ctrl-C reaches it
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def _wait_for(path: Path, proc, timeout_s=300):
    deadline = time.monotonic() + timeout_s
    while not path.is_file():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, f"timed out waiting for {path}"
        time.sleep(0.1)


def _interrupt(proc, timeout_s=120):
    """Ctrl-C as a terminal sends it: SIGINT to the whole process group."""
    os.killpg(proc.pid, signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        raise
    return proc.returncode, out, err


@pytest.mark.slow  # ~1.5 min: three training runs interrupted
@pytest.mark.parametrize("delay_s", [0.0, 0.7, 1.9])
def test_ctrl_c_to_train_s_process_group_is_exit_130(tmp_path, delay_s):
    out = tmp_path / "run"
    hp = json.dumps({**TINY, "eval_freq": 10_000_000})
    proc = _start(
        ["train", "--out", out, "--n-envs", "2", "--timesteps", "100000", "--no-progress"]
        + ["--hyperparams", hp]
    )
    _wait_for(out / "checkpoints" / "latest.json", proc)
    time.sleep(delay_s)  # at another moment of the rollout each time
    code, _, err = _interrupt(proc)
    assert code == EXIT_INTERRUPTED, err
    last = err.strip().splitlines()[-1]
    # With a checkpoint saved, the line says how to go on.
    assert last == "drake-tooluse train: error: interrupted" or last.startswith(
        "drake-tooluse train: error: interrupted: the run so far is saved in "
    ), err
    assert "Traceback" not in err and "EOFError" not in err and "internal error" not in err
    assert latest_checkpoint(out) is not None  # a resume starts from it


@pytest.mark.slow  # ~1 min: a Ray sweep interrupted
def test_ctrl_c_to_a_sweep_is_exit_130_and_lists_the_cell_as_interrupted(tmp_path):
    pytest.importorskip("ray.tune")
    out = tmp_path / "sweep"
    hp = json.dumps({**TINY, "n_envs": 1, "eval_freq": 10_000_000})
    proc = _start(
        ["sweep", "--timesteps", "100000", "--out", out, "--num-cpus", "2", "--episodes", "1"]
        + ["--hyperparams", hp]
    )
    cell = out / "runs" / "ppo_ToolPush-v1_s0"
    _wait_for(cell / "checkpoints" / "latest.json", proc)
    code, _, err = _interrupt(proc)
    assert code == EXIT_INTERRUPTED, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("drake-tooluse sweep: error: interrupted: the sweep in"), err
    assert f"drake-tooluse sweep --resume {out}" in last
    (row,) = json.loads((out / "sweep.json").read_text())
    assert row["status"] == "interrupted"
    assert "Traceback" not in err


BENCHMARKS = sorted(
    p
    for p in (ROOT / "benchmarks").glob("*.py")
    if p.name not in ("env_throughput.py", "behaviour_snapshot.py")
)


@pytest.mark.parametrize("script", BENCHMARKS, ids=lambda p: p.name)
def test_a_benchmark_script_ends_on_ctrl_c_with_one_line(script):
    """Each script's entry point runs its main through `run_script`."""
    tree = ast.parse(script.read_text())
    (block,) = [n for n in tree.body if isinstance(n, ast.If) and "__main__" in ast.unparse(n.test)]
    assert ast.unparse(block.body[0]) == "sys.exit(run_script(main))", script


def test_run_script_turns_ctrl_c_into_one_line_and_130(capsys):
    def interrupted():
        raise KeyboardInterrupt

    assert run_script(interrupted) == EXIT_INTERRUPTED
    assert capsys.readouterr().err.strip().endswith(": interrupted")
    assert run_script(lambda: None) == 0 and run_script(lambda: 3) == 3


@pytest.mark.slow  # ~30 s: a training run on a disk that fills
def test_a_full_disk_under_train_is_exit_2_naming_the_file(tmp_path):
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        pytest.skip("needs root and unshare(1) to mount a small file system")
    disk = tmp_path / "disk"
    disk.mkdir()
    hp = json.dumps({**TINY, "eval_freq": 10_000_000})
    train = [*CLI, "train", "--out", str(disk / "run"), "--n-envs", "1", "--timesteps", "384"]
    train += ["--no-progress", "--hyperparams", hp]
    script = f"mount -t tmpfs -o size=600k tmpfs {disk} && exec {' '.join(map(repr, train))}"
    probe = subprocess.run(["unshare", "-m", "true"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"unshare -m is not permitted here: {probe.stderr.decode().strip()}")
    done = subprocess.run(
        ["unshare", "-m", "sh", "-c", script], env=ENV, capture_output=True, text=True
    )
    assert done.returncode == 2, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert "No space left on device" in last and str(disk / "run") in last, done.stderr
    assert "internal error" not in done.stderr


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_envs_close_in_bounded_time_after_a_ctrl_c_between_two_step_results():
    """The Ctrl-C that lands in step_wait after the first env process's result was read: that
    process has nothing more to send, and SubprocVecEnv's own close would wait for it forever."""
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor

    from drake_tooluse.learning.train import close_envs

    venv = VecMonitor(SubprocVecEnv([lambda: gym.make("CartPole-v1")] * 2))
    venv.reset()
    venv.step_async(np.zeros(2, dtype=np.int64))
    venv.unwrapped.remotes[0].recv()  # the first result read; the interrupt comes here
    start = time.monotonic()
    close_envs(venv, timeout_s=5.0)
    assert time.monotonic() - start < 10.0
    assert venv.unwrapped.closed
    assert not any(process.is_alive() for process in venv.unwrapped.processes)


def test_an_interrupted_training_says_how_to_go_on(tmp_path, monkeypatch, capsys):
    """Ctrl-C in `train` (of any task) after a checkpoint: exit 130 with the command that
    resumes the run (it printed only "interrupted")."""
    import drake_tooluse.learning.train as training
    from drake_tooluse.cli import main

    def interrupted(config, out, **kwargs):
        (Path(out) / "checkpoints").mkdir(parents=True)
        (Path(out) / "checkpoints" / "latest.json").write_text("{}")
        raise KeyboardInterrupt

    monkeypatch.setattr(training, "train", interrupted)
    out = tmp_path / "run"
    argv = ["train", "--env", "drake_tooluse/ToolPull-v1", "--timesteps", "256", "--out", str(out)]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert f"go on with `drake-tooluse train --resume {out}`" in err


def test_an_interrupted_study_says_how_to_go_on(tmp_path, monkeypatch, capsys):
    """Ctrl-C in `study`: exit 130, where the finished runs are, and the command that picks up
    every run where it stopped (it printed only "interrupted")."""
    import drake_tooluse.experiments.paper_study as paper_study
    from drake_tooluse.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(paper_study, "run_study", interrupted)
    out = tmp_path / "study"
    assert main(["study", "--out", str(out), "--no-report"]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "the runs so far are recorded in" in err
    assert f"go on with `drake-tooluse study --out {out} --no-report`" in err
