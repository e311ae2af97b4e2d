"""The command line's boundary: argument errors (JSON with `--json`, no abbreviated options),
warnings that do not precede an error's one line, an IK target of any finite quaternion, a
result made of several files written as one set, the sweep's checks made before Ray and in
time linear in its grid, and a resumed run's budget.

Covers: a 1e200 quaternion (and any finite one, hypothesis); `measure --save-images` killed
mid-way; `sweep --resume` after sweep_config.json was edited; a grid of 10,000 seeds; argparse's
errors with `--json`; `--tool` for `--tool-length`; warnings before an error; `train --resume`
without and with another `--timesteps`."""

import json
import time
import warnings
from dataclasses import asdict, replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydrake.common.eigen_geometry import Quaternion

import drake_tooluse.builders.measurement as measurement
import drake_tooluse.cli.robot as robot_cli
from drake_tooluse.cli import EXIT_USAGE, main
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.validation import check_unit_quaternion
from drake_tooluse.world.scenario import Scenario, with_tool_length
from tests.faults.common import KILLED, TINY, die, run_killed

ENV = "drake_tooluse/ToolPush-v1"


def one_line(capsys, argv, code=EXIT_USAGE) -> str:
    got = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert got == code, captured.err
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    return lines[0]


# -- an IK target's quaternion -----------------------------------------------------------------


def test_a_quaternion_of_1e200_is_a_rotation_not_a_bug(capsys):
    argv = ["ik", "--tool-length", "0.175", "--position", "0.65", "-0.25", "-0.1", "--json"]
    code = main([*argv, "--quaternion", "1e200", "0", "0", "0"])
    out = json.loads(capsys.readouterr().out)
    assert code in (0, 3), out
    assert "error" not in out


@settings(max_examples=200, deadline=None, database=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=4, max_size=4))
def test_any_finite_quaternion_is_a_unit_one_or_a_value_error(q):
    try:
        unit = check_unit_quaternion(q)
    except ValueError as e:
        assert "has zero norm" in str(e)
        return
    assert abs(np.linalg.norm(unit) - 1) < 1e-12
    Quaternion(unit)  # Drake takes it


# -- a result of several files is one set ----------------------------------------------------


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_measure_images_killed_midway_leave_the_old_set_whole(tmp_path, monkeypatch):
    images = tmp_path / "images"
    images.mkdir()
    old = {f"measure_{v.name}.png": f"old {v.name}".encode() for v in measurement.MEASUREMENT_VIEWS}
    for name, data in old.items():
        (images / name).write_bytes(data)
    written = []
    real = measurement.atomic_write_image

    def write_then_die(path, image, bgr=False):
        if written:
            die()  # SIGKILL-like: after the first view, before the second
        written.append(path)
        return real(path, image, bgr=bgr)

    monkeypatch.setattr(measurement, "atomic_write_image", write_then_die)
    scenario = with_tool_length(Scenario(), 0.175)
    assert run_killed(measurement.measure_tool, scenario, save_images_dir=images) == KILLED
    assert {p.name: p.read_bytes() for p in images.iterdir()} == old
    # Run whole, the new views replace the old ones at once.
    monkeypatch.setattr(measurement, "atomic_write_image", real)
    result = measurement.measure_tool(scenario, save_images_dir=images)
    assert sorted(p.name for p in images.iterdir()) == sorted(old)
    assert all(p.read_bytes() != old[p.name] for p in images.iterdir())
    assert sorted(p.name for p in result.image_files) == sorted(old)


def test_measure_refuses_a_directory_holding_other_files_before_work(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    line = one_line(capsys, ["measure", "--save-images", tmp_path])
    assert "holds files other than a measurement's views (notes.txt)" in line
    assert (tmp_path / "notes.txt").read_text() == "mine"


# -- the sweep: checked before Ray, in linear time ----------------------------------------


@pytest.fixture
def no_ray(monkeypatch):
    ray = pytest.importorskip("ray")

    def refuse(*args, **kwargs):
        raise AssertionError("Ray was started")

    monkeypatch.setattr(ray, "init", refuse)


def test_an_edited_sweep_config_is_refused_before_ray_starts(tmp_path, capsys, no_ray):
    out = tmp_path / "sweep"
    settings_ = {
        "algos": ["ppo"],
        "envs": [ENV],
        "seeds": [0],
        "timesteps": 512,
        "overrides": {**TINY, "n_envs": 1},
        "episodes": 1,
    }
    run = out / "runs" / "ppo_ToolPush-v1_s0"
    run.mkdir(parents=True)
    config = resolve_config(ENV, "ppo", 512, None, 0, overrides=settings_["overrides"])
    (run / "config.json").write_text(json.dumps({**asdict(config), "command": "x"}))
    settings_["overrides"] = {**settings_["overrides"], "learning_rate": 0.1}
    (out / "sweep_config.json").write_text(json.dumps(settings_))
    start = time.perf_counter()
    line = one_line(capsys, ["sweep", "--resume", out, "--num-cpus", "2"])
    assert time.perf_counter() - start < 10
    assert "no longer matches its run" in line
    assert "hyperparams.learning_rate: saved 0.0003, asked 0.1" in line


def test_a_grid_of_10000_seeds_is_checked_in_seconds(tmp_path, capsys, no_ray):
    seeds = [str(s) for s in range(10_000)]
    start = time.perf_counter()
    main(["sweep", "--seeds", *seeds, "--out", str(tmp_path / "s"), "--timesteps", "64"])
    assert time.perf_counter() - start < 8
    assert "Ray was started" in capsys.readouterr().err  # every check passed before
    start = time.perf_counter()
    line = one_line(capsys, ["sweep", "--seeds", *seeds, "10000", "--out", tmp_path / "t"])
    assert time.perf_counter() - start < 8
    assert "10001 values; a grid has at most 10000 runs" in line


# -- argument errors ---------------------------------------------------------------------


def test_an_argument_error_with_json_is_a_json_object(capsys):
    code = main(["ik", "--tool-length", "nope", "--json"])
    captured = capsys.readouterr()
    assert code == EXIT_USAGE
    assert json.loads(captured.out)["exit_code"] == EXIT_USAGE
    assert "invalid float value: 'nope'" in json.loads(captured.out)["error"]
    assert captured.err.strip().splitlines() == [
        "drake-tooluse ik: error: argument --tool-length: invalid float value: 'nope'"
    ]


def test_an_option_is_never_abbreviated(capsys):
    argv = ["ik", "--tool", "0.2", "--position", "0.65", "-0.25", "-0.1", "--json"]
    assert main(argv) == EXIT_USAGE
    assert "unrecognized arguments: --tool 0.2" in json.loads(capsys.readouterr().out)["error"]


def test_warnings_do_not_come_before_an_error(monkeypatch, capsys):
    def warn_then_fail(args):
        warnings.warn("a library's warning", UserWarning, stacklevel=1)
        raise ValueError("x=1 is outside the allowed range [2, 3]")

    monkeypatch.setattr(robot_cli, "cmd_fk", warn_then_fail)
    line = one_line(capsys, ["fk", "--no-tool", "--q", *["0"] * 7])
    assert line.endswith("x=1 is outside the allowed range [2, 3]")

    def warn_then_succeed(args):
        warnings.warn("a library's warning", UserWarning, stacklevel=1)
        return {"ok": 1}

    monkeypatch.setattr(robot_cli, "cmd_fk", warn_then_succeed)
    assert main(["fk", "--no-tool", "--q", *["0"] * 7, "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out) == {"ok": 1} and "a library's warning" in captured.err


# -- a resumed run's budget ------------------------------------------------------------------


def test_resume_keeps_the_run_s_budget_unless_told_and_says_so(tmp_path, monkeypatch, capsys):
    import drake_tooluse.learning.train as train_module

    asked = []

    def fake_train(config, out, **kwargs):
        asked.append(config.timesteps)
        return {
            "timesteps": config.timesteps,
            "wall_time_s": 1.0,
            "steps_per_s": None,
            "sessions": 2,
            "resumes": [],
            "out": str(out),
        }

    monkeypatch.setattr(train_module, "train", fake_train)
    run = tmp_path / "run"
    run.mkdir()
    saved = resolve_config(ENV, "ppo", 1000, 1, 0)
    (run / "config.json").write_text(json.dumps({**asdict(saved), "command": ""}))
    assert main(["train", "--resume", str(run), "--n-envs", "1", "--json"]) == 0
    assert asked == [1000] and "budget_changed_from" not in json.loads(capsys.readouterr().out)
    assert main(["train", "--resume", str(run), "--n-envs", "1", "--timesteps", "3000"]) == 0
    assert asked == [1000, 3000]
    assert "its budget changed from 1000 steps" in capsys.readouterr().out


def test_resume_alone_continues_with_the_run_s_own_settings(tmp_path, monkeypatch, capsys):
    import drake_tooluse.learning.train as train_module

    asked = []

    def fake_train(config, out, **kwargs):
        asked.append(config)
        return {"timesteps": config.timesteps, "wall_time_s": 1.0, "out": str(out)}

    monkeypatch.setattr(train_module, "train", fake_train)
    run = tmp_path / "run"
    run.mkdir()
    saved = resolve_config(
        "drake_tooluse/ToolPull-v1", "a2c", 1000, 1, 7, overrides={"learning_rate": 1e-4}
    )
    (run / "config.json").write_text(json.dumps({**asdict(saved), "command": ""}))
    assert main(["train", "--resume", str(run), "--timesteps", "2000", "--json"]) == 0
    assert asked[-1] == replace(saved, timesteps=2000)  # not the defaults (ToolPush-v1, ppo, 0)
    # Flags given with --resume are the settings asked (train compares them with the run's);
    # the env, algorithm and seed not given are the run's.
    assert main(["train", "--resume", str(run), "--n-envs", "2", "--json"]) == 0
    assert (asked[-1].env_id, asked[-1].algo, asked[-1].seed, asked[-1].n_envs) == (
        "drake_tooluse/ToolPull-v1",
        "a2c",
        7,
        2,
    )
