"""`record-video`: an episode of a policy as a GIF of the scene camera's frames."""

import io
import json

import numpy as np
from PIL import Image

from drake_tooluse.cli import EXIT_USAGE, main
from drake_tooluse.experiments.video import HOLD_LAST_S, gif_bytes


def test_an_episode_becomes_a_gif(capsys, tmp_path):
    out = tmp_path / "episode.gif"
    argv = ["record-video", "--out", str(out), "--render-size", "64", "48", "--every", "25"]
    assert main([*argv, "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    # The shipped tip policy runs to the 100-step limit: a frame at steps 0, 25, 50, 75, 100.
    assert result["steps"] == 100 and result["frames"] == 5 and result["size_px"] == [64, 48]
    assert result["fps"] == 1.0 and result["bytes"] == out.stat().st_size
    assert 0 <= result["final_object_to_goal_m"] < 1
    with Image.open(out) as gif:
        assert gif.format == "GIF" and gif.size == (64, 48) and gif.n_frames == 5
        gif.seek(4)
        assert gif.info["duration"] == HOLD_LAST_S * 1000  # the end held


def test_bad_arguments_are_refused_before_any_episode(capsys, tmp_path):
    assert main(["record-video", "--out", str(tmp_path / "x.mp4")]) == EXIT_USAGE
    assert "must be a .gif file" in capsys.readouterr().err
    argv = ["record-video", "--out", str(tmp_path / "x.gif"), "--render-size", "8", "8"]
    assert main(argv) == EXIT_USAGE
    assert "render_size=(8, 8) px: each side must be in [32, 2048]" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_one_palette_keeps_a_still_background_still():
    rng = np.random.default_rng(0)
    background = rng.integers(0, 255, (40, 60, 3), dtype=np.uint8)
    frames = []
    for k in range(4):  # a small square moving over a fixed background
        f = background.copy()
        f[10:20, 10 + 5 * k : 20 + 5 * k] = (200, 30, 30)
        frames.append(f)
    data = gif_bytes(frames, fps=10, colors=64)
    decoded = []
    with Image.open(io.BytesIO(data)) as gif:
        for i in range(gif.n_frames):
            gif.seek(i)
            decoded.append(np.array(gif.convert("RGB")))
    # Away from the square, every frame is the first one's, pixel for pixel.
    for f in decoded[1:]:
        assert np.array_equal(f[25:], decoded[0][25:])
