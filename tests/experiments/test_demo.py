"""`drake-tooluse demo` end to end: measure, push in the perturbed reality, write the run."""

import json
from pathlib import Path

import pytest

from drake_tooluse.cli import main
from drake_tooluse.experiments.demo import run_demo


def test_demo_end_to_end(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "demo"
    assert main(["demo", "--out", "demo", "--seed", "1"]) == 0  # a relative --out
    printed = capsys.readouterr()
    assert "[1/3] measuring" in printed.err and "[3/3]" in printed.err  # progress
    assert "recording.html" in printed.out
    metrics = json.loads((out / "metrics.json").read_text())
    tool = metrics["tool"]
    assert tool["true_length_m"] == 0.125
    assert abs(tool["measurement_error_m"]) < 0.002
    assert metrics["seed"] == 1 and set(metrics["perturbation"]) >= {
        "grasp_along",
        "box_mass_scale",
    }
    push = metrics["run"]
    assert 1 <= push["steps"] <= 100 and push["final_object_to_goal_m"] >= 0
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
    # One rule for paths: every one is absolute, and names a file that is there.
    files = metrics["files"]
    paths = [metrics["policy"], metrics["scenario"], *files["camera_views"]]
    paths += [v for k, v in files.items() if k != "camera_views"]
    assert all(Path(p).is_absolute() and Path(p).exists() for p in paths), paths
    assert files["summary"] == str(out / "summary.png")


def test_demo_refuses_a_used_directory_and_bad_input(tmp_path):
    used = tmp_path / "used"
    used.mkdir()
    (used / "keep.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not empty"):
        run_demo(used, progress=False)
    assert (used / "keep.txt").read_text() == "mine"
    with pytest.raises(ValueError, match=r"0.9.*\(0, 0.6\]"):
        run_demo(tmp_path / "new", tool_length=0.9, progress=False)
    with pytest.raises(FileNotFoundError):
        run_demo(tmp_path / "new", policy_dir=tmp_path / "no_policy", progress=False)
    assert not (tmp_path / "new").exists()


def test_a_failed_demo_leaves_nothing(tmp_path, monkeypatch):
    """A failure half-way (here: the push) leaves no half-written run directory."""
    import drake_tooluse.experiments.demo as demo

    def fail(*args, **kwargs):
        raise RuntimeError("simulated failure during the push")

    monkeypatch.setattr(demo, "run_policy", fail)
    with pytest.raises(RuntimeError, match="simulated failure"):
        run_demo(tmp_path / "demo", progress=False)
    assert list(tmp_path.iterdir()) == []
