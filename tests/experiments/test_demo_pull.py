"""`drake-tooluse demo --task pull`: a full run, and its argument checks."""

import json

import pytest

from drake_tooluse.cli import main


def test_demo_pull_writes_its_run(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["demo", "--task", "pull", "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "pull (policy ppo_toolpull): cube" in printed and str(out / "recording.html") in printed
    m = json.loads((out / "metrics.json").read_text())
    true, measured = m["hook"]["true"], m["hook"]["measured"]
    assert true == {"handle_length": 0.25, "hook_length": 0.05, "angle": 75.0, "grasp_along": 0.015}
    assert measured["handle_length"] == pytest.approx(0.25, abs=0.005)
    assert measured["hook_length"] == pytest.approx(0.05, abs=0.005)
    assert measured["angle"] == pytest.approx(75.0, abs=3.0)
    assert measured["grasp_along"] == pytest.approx(0.015, abs=0.005)
    pull = m["run"]
    assert m["controller"] == "policy ppo_toolpull"  # the shipped hook policy
    assert pull["success"] is True
    assert pull["final_object_to_goal_m"] < 0.05
    assert 1 <= pull["first_success_step"] <= pull["steps"]
    html = (out / "recording.html").read_text()
    assert "<html" in html.lower() and len(html) > 10_000
    assert (out / "summary.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert m["files"]["summary"] == str((out / "summary.png").resolve())


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--task", "pull", "--tool-length", "0.2"], "--tool-length is for --task push only"),
        (["--hook-angle", "60"], "--hook-angle is for --task pull only"),
        (["--task", "pull", "--hook-angle", "500"], "hook angle=500"),
        (["--task", "pull", "--handle-length", "-1"], "handle length"),
        (["--task", "pound"], "invalid choice"),
        (["--task", "pull", "--policy", "no/such/policy"], "--policy"),
    ],
)
def test_demo_pull_rejects_bad_arguments(tmp_path, capsys, argv, message):
    out = tmp_path / "run"
    assert main(["demo", "--out", str(out), "--no-progress", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_demo_pull_runs_the_scripted_reference_when_asked(tmp_path):
    from drake_tooluse.experiments.demo_pull import SCRIPTED, run_demo_pull

    m = run_demo_pull(tmp_path / "run", max_steps=5, progress=False, policy=SCRIPTED)
    assert m["controller"] == "scripted pull" and m["run"]["steps"] == 5
