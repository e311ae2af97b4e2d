"""`drake-tooluse demo` end to end, for every task: measure an unseen tool, do the task with it
in the perturbed reality, write the run."""

import json
from pathlib import Path

import pytest

from drake_tooluse.cli import main
from drake_tooluse.experiments.demo import demo_controller, run_demo
from drake_tooluse.experiments.task_worlds import TOOL_TASKS
from drake_tooluse.paths import POLICIES_DIR
from drake_tooluse.robot.tool_generator import generate_tool


def _paths_are_absolute_and_there(metrics) -> None:
    """One rule for paths: every one is absolute, and names a file that is there."""
    files = metrics["files"]
    paths = [metrics["scenario"], *files["camera_views"]]
    paths += [v for k, v in files.items() if k != "camera_views"]
    if metrics["policy"] != "scripted":
        paths.append(metrics["policy"])
    assert all(Path(p).is_absolute() and Path(p).exists() for p in paths), paths


def test_the_push_demo_end_to_end(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "demo"
    assert main(["demo", "--out", "demo", "--seed", "1"]) == 0  # a relative --out
    printed = capsys.readouterr()
    assert "[1/3] measuring" in printed.err and "[3/3]" in printed.err  # progress
    assert "push (policy ppo_toolpush_tip): box" in printed.out and "recording.html" in printed.out
    metrics = json.loads((out / "metrics.json").read_text())
    tool = metrics["tool"]
    assert tool["given"] == "straight:0.125" and tool["true"]["length_m"] == 0.125
    assert abs(tool["measured"]["length_m"] - 0.125) < 0.002
    assert abs(tool["measured"]["grasp_along_m"] - tool["true"]["grasp_along_m"]) < 0.003
    assert metrics["seed"] == 1 and set(metrics["perturbation"]) >= {
        "grasp_along",
        "box_mass_scale",
    }
    run = metrics["run"]
    assert run["steps"] == 100 and run["final_object_to_goal_m"] >= 0
    html = (out / "recording.html").read_text()
    assert "meshcat" in html.lower() and len(html) > 100_000  # the scene and its animation
    for name in (
        "trajectory.png",
        "summary.png",
        "final_scene.png",
        "camera/measure_grip_right.png",
    ):
        assert (out / name).stat().st_size > 5_000, name
    assert metrics["times"]["total_s"] < 180
    _paths_are_absolute_and_there(metrics)
    assert metrics["files"]["summary"] == str(out / "summary.png")


@pytest.mark.slow  # ~3 s; the push demo's end to end runs in the default suite
def test_the_pull_demo_end_to_end(tmp_path, capsys):
    """The same command and the same run directory for the pull: the task's own tool (a
    hook), its shipped policy, its object (the cube)."""
    out = tmp_path / "run"
    assert main(["demo", "--task", "pull", "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "pull (policy ppo_toolpull): cube" in printed and str(out / "recording.html") in printed
    m = json.loads((out / "metrics.json").read_text())
    true, measured = m["tool"]["true"], m["tool"]["measured"]
    assert m["tool"]["given"] == "hook:0.25,0.05,75"
    assert {k: true[k] for k in ("handle_length_m", "hook_length_m", "angle_deg")} == {
        "handle_length_m": 0.25,
        "hook_length_m": 0.05,
        "angle_deg": 75.0,
    }
    assert measured["handle_length_m"] == pytest.approx(0.25, abs=0.005)
    assert measured["hook_length_m"] == pytest.approx(0.05, abs=0.005)
    assert measured["angle_deg"] == pytest.approx(75.0, abs=3.0)
    assert measured["grasp_along_m"] == pytest.approx(true["grasp_along_m"], abs=0.005)
    run = m["run"]
    assert m["controller"] == "policy ppo_toolpull" and m["object"] == "cube"
    assert run["success"] is True and run["final_object_to_goal_m"] < 0.05
    assert 1 <= run["first_success_step"] <= run["steps"]
    assert (out / "summary.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "final_scene.png").stat().st_size > 5_000
    _paths_are_absolute_and_there(m)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--task", "pull", "--tool-length", "0.2"], "no pull policy for a straight tool"),
        (["--tool", "hook:0.25,0.05,90"], "no push policy for a hook"),
        (["--tool", "straight:0.2", "--tool-length", "0.2"], "not both"),
        (["--task", "pull", "--tool", "hook:0.25,0.05,500"], "hook angle=500"),
        (["--task", "pull", "--tool", "hook:-1,0.05,90"], "hook handle length"),
        (["--tool", "hook:1,2"], "--tool: tool 'hook:1,2' is not straight:L"),
        (["--tool-length", "0.9"], "0.9"),
        (["--task", "pound"], "invalid choice"),
        (["--task", "pull", "--policy", "no/such/policy"], "--policy"),
        (["--task", "pull", "--policy", "models/policies/ppo_toolpush_tip"], "the push task"),
    ],
)
def test_the_demo_refuses_bad_arguments_before_any_work(tmp_path, capsys, argv, message):
    out = tmp_path / "run"
    assert main(["demo", "--out", str(out), "--no-progress", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.slow  # ~2-3 s each
@pytest.mark.parametrize("task", ["push-far", "pull"])
def test_the_demo_runs_a_tasks_scripted_reference_when_asked(tmp_path, task):
    m = run_demo(tmp_path / "run", task, "scripted", max_steps=5, progress=False)
    assert m["controller"] == f"scripted {task.removesuffix('-far')}" and m["run"]["steps"] == 5


def test_demo_refuses_a_used_directory_and_bad_input(tmp_path):
    used = tmp_path / "used"
    used.mkdir()
    (used / "keep.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not empty"):
        run_demo(used, progress=False)
    assert (used / "keep.txt").read_text() == "mine"
    with pytest.raises(ValueError, match=r"0.9.*\(0, 0.6\]"):
        run_demo(tmp_path / "new", tool="straight:0.9", progress=False)
    with pytest.raises(FileNotFoundError):
        run_demo(tmp_path / "new", policy_dir=tmp_path / "no_policy", progress=False)
    with pytest.raises(ValueError, match="task='pound'"):
        run_demo(tmp_path / "new", "pound", progress=False)
    assert not (tmp_path / "new").exists()


@pytest.mark.slow  # ~1.2-2.4 s: with the slow tests CI runs
def test_a_failed_demo_leaves_nothing(tmp_path, monkeypatch):
    """A failure half-way (here: the run) leaves no half-written run directory."""
    import drake_tooluse.experiments.demo as demo

    def fail(*args, **kwargs):
        raise RuntimeError("simulated failure during the run")

    monkeypatch.setattr(demo.LearnedPolicy, "run", fail)
    with pytest.raises(RuntimeError, match="simulated failure"):
        run_demo(tmp_path / "demo", progress=False)
    assert list(tmp_path.iterdir()) == []


def test_a_generated_tool_is_pushed_by_the_policy_for_every_shape():
    """The push's shipped policy for a tool of any shape (`ToolTask.shapes_policy`) takes a
    generated tool; a rod keeps the tip policy, and a policy given is the one used."""
    push = TOOL_TASKS["push"]
    rake = generate_tool("rake", 2)
    assert demo_controller("push", tool=rake).directory.name == push.shapes_policy
    assert demo_controller("push").directory.name == push.policy
    given = demo_controller("push", POLICIES_DIR / push.policy, tool=rake)
    assert given.directory.name == push.policy
