"""The docs' Meshcat screenshots are current, and recordings open framed on the task.

None of these needs Chromium: the check compares what a picture shows (the recording's scene
digest), not its pixels."""

import base64
import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from drake_tooluse.builders import visualization
from drake_tooluse.builders.visualization import show_task, start_meshcat
from drake_tooluse.experiments import screenshots
from drake_tooluse.experiments.screenshots import (
    SCREENSHOTS,
    camera_of,
    render_all,
    scene_commands,
    scene_digest,
)
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import FLOOR_Z, goal_position

FIGURES = Path(__file__).resolve().parents[2] / "docs" / "figures"


def _framed_html(scenario, meshcat=None) -> str:
    meshcat = meshcat or start_meshcat()
    show_task(meshcat, scenario)
    return meshcat.StaticHtml()


def _transform(commands, path) -> np.ndarray:
    (matrix,) = [
        c["matrix"] for c in commands if c["type"] == "set_transform" and c["path"] == path
    ]
    return np.array(matrix).reshape(4, 4).T  # three.js: column-major


def test_committed_screenshots_are_current():
    assert render_all(FIGURES, check=True) == {name: {"current": True} for name in SCREENSHOTS}
    meta = json.loads((FIGURES / "simulate_meshcat.json").read_text())
    assert meta["camera"]["position_W_m"] == list(visualization.CAMERA_IN_WORLD)
    assert (FIGURES / "simulate_meshcat.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_recording_opens_on_the_task_with_the_goal_and_the_grid_at_the_floor():
    scenario = Scenario()
    commands = scene_commands(_framed_html(scenario))
    camera = camera_of(commands)
    assert np.allclose(camera["position_W_m"], visualization.CAMERA_IN_WORLD)
    assert np.allclose(camera["target_W_m"], visualization.CAMERA_TARGET)
    grid = _transform(commands, "/Grid")
    assert np.allclose(grid[:3, :3], np.eye(3)) and np.allclose(grid[:3, 3], [0, 0, FLOOR_Z])
    goal = _transform(commands, visualization.GOAL_PATH)
    assert np.allclose(goal[:2, 3], goal_position(scenario)[:2])
    assert scenario.table.top_z < goal[2, 3] < scenario.table.top_z + 0.005  # on the table
    (disc,) = [
        c for c in commands if c["type"] == "set_object" and c["path"] == visualization.GOAL_PATH
    ]
    (geometry,) = disc["object"]["geometries"]
    assert geometry["type"] == "CylinderGeometry"
    assert geometry["radiusTop"] == pytest.approx(visualization.GOAL_RADIUS)


def test_the_digest_ignores_run_ids_and_sees_the_camera_and_the_goal(monkeypatch):
    scenario = Scenario()
    a, b = _framed_html(scenario), _framed_html(scenario)
    # Uuids (three.js's object ids) are Drake's choice; renumbered, they do not count.
    commands = scene_commands(a)
    text = json.dumps(commands, default=str)
    ids = sorted(set(re.findall(r"[0-9a-f]{8}(?:-[0-9a-f]{4}){3}-[0-9a-f]{12}", text)))
    assert ids
    for i, old in enumerate(ids):
        text = text.replace(old, f"{i:08d}-0000-4000-8000-{len(ids) - i:012d}")
    other = json.loads(text)
    assert other != commands
    assert screenshots._normalised(other, {}) == screenshots._normalised(commands, {})
    window = (1280, 800)
    assert scene_digest(a, window) == scene_digest(b, window)
    assert scene_digest(a, window) != scene_digest(a, (800, 600))
    moved_goal = dataclasses.replace(scenario, goal_offset=[0.0, 0.15, 0.0])
    assert scene_digest(_framed_html(moved_goal), window) != scene_digest(a, window)
    monkeypatch.setattr(visualization, "CAMERA_TARGET", (0.45, -0.15, -0.09))
    moved = scene_digest(_framed_html(scenario), window)
    assert moved["scene_sha256"] != scene_digest(a, window)["scene_sha256"]


def test_check_names_a_stale_screenshot(tmp_path):
    for suffix in (".png", ".json"):
        shutil.copy(FIGURES / f"simulate_meshcat{suffix}", tmp_path)
    meta = json.loads((tmp_path / "simulate_meshcat.json").read_text())
    meta["scene_sha256"] = "0" * 64
    (tmp_path / "simulate_meshcat.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="simulate_meshcat.png is out of date.*render-figures"):
        render_all(tmp_path, check=True)
    (tmp_path / "simulate_meshcat.json").unlink()
    with pytest.raises(ValueError, match="is missing"):
        render_all(tmp_path, check=True)


def test_without_chromium_the_command_says_so_in_one_line(tmp_path, monkeypatch, capsys):
    from drake_tooluse.cli import main

    monkeypatch.setattr(screenshots.shutil, "which", lambda name: None)
    with pytest.raises(RuntimeError, match="apt-get install chromium"):
        render_all(tmp_path)
    assert main(["dev", "render-figures", "--figures-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Chromium" in err
    assert not list(tmp_path.iterdir())  # nothing simulated or written


def test_the_recording_decoder_reads_what_msgpack_writes():
    msgpack = pytest.importorskip("msgpack")
    value = {
        "type": "set_object",
        "ints": [0, 127, 128, 255, 65535, 2**32, -1, -32, -33, -(2**15), -(2**40)],
        "floats": [0.5, -1e-300, 1e300],
        "text": ["", "x" * 31, "y" * 40, "z" * 300, "w" * 70000],
        "flags": [True, False, None],
        "blob": b"\x00\x01" * 200,
        "typed": msgpack.ExtType(0x17, b"\x00" * 12),
        "big": list(range(20)),
        "map": {str(i): i for i in range(20)},
    }
    (decoded,) = scene_commands(_as_html(msgpack.packb(value, use_bin_type=True)))
    expected = dict(value, typed=(0x17, b"\x00" * 12))
    assert decoded == expected


def _as_html(data: bytes) -> str:
    return f'fetch("data:application/octet-binary;base64,{base64.b64encode(data).decode()}")'
