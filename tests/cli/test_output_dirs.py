"""One rule for result directories: a command never writes into an existing non-empty one (give
a new directory; `train --resume DIR` continues a run), and the library's errors name its own
arguments, not the command line's flags."""

import ast
import json
import re
from dataclasses import asdict
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import drake_tooluse
from drake_tooluse.cli import EXIT_USAGE, main
from drake_tooluse.paths import TRANSFER_POLICY

LIBRARY = Path(drake_tooluse.__file__).parent


def test_no_library_file_exists_error_names_a_command_line_flag():
    found = []
    for path in LIBRARY.rglob("*.py"):
        if "cli" in path.relative_to(LIBRARY).parts:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.Raise)
                and isinstance(node.exc, ast.Call)
                and getattr(node.exc.func, "id", None) == "FileExistsError"
            ):
                text = " ".join(
                    c.value
                    for c in ast.walk(node.exc)
                    if isinstance(c, ast.Constant) and isinstance(c.value, str)
                )
                if re.search(r"(^|\s)--[a-z]", text):
                    found.append(f"{path.name}:{node.lineno}: {text}")
    assert not found


def test_train_refuses_a_started_run_in_the_library_and_cli_words(tmp_path, capsys):
    from drake_tooluse.learning.config import resolve_config
    from drake_tooluse.learning.train import train

    run = tmp_path / "run"
    (run / "final").mkdir(parents=True)
    config = resolve_config("drake_tooluse/ToolPush-v1", "ppo", 1000, 1, 0)
    (run / "config.json").write_text(json.dumps(asdict(config)))
    with pytest.raises(FileExistsError) as e:
        train(config, run)
    assert "resume it (resume=True) or give a new directory" in str(e.value) and "--" not in str(
        e.value
    )
    code = main(["train", "--out", str(run), "--n-envs", "1", "--timesteps", "1000"])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE
    assert f"--out '{run}' already holds a run; continue it with --resume '{run}'" in err
    assert "resume=True" not in err


def test_trajectory_refuses_a_non_empty_out_before_any_work(tmp_path, capsys):
    (tmp_path / "old.txt").write_text("kept")
    argv = ["trajectory", "--policy", str(TRANSFER_POLICY), "--out", str(tmp_path)]
    assert main(argv) == EXIT_USAGE
    assert "exists and is not empty; give a new directory" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["old.txt"]


def test_save_extraction_writes_a_new_directory_whole(tmp_path):
    from drake_tooluse.experiments.trajectory_extraction import save_extraction
    from drake_tooluse.systems.tip_trajectory import TipTrajectory

    q = [1.0, 0.0, 0.0, 0.0]
    kept = TipTrajectory([0.0, 0.1], [[0.6, -0.2, -0.1], [0.6, -0.1, -0.1]], [q, q])
    ex = SimpleNamespace(
        reachability=SimpleNamespace(kept=kept), tip_positions=[kept.positions], smoothed=kept
    )
    npz, png = save_extraction(ex, tmp_path / "t")
    assert npz.is_file() and png.stat().st_size > 1000
    with pytest.raises(FileExistsError, match="exists and is not empty; give a new directory"):
        save_extraction(ex, tmp_path / "t")
    assert np.allclose(TipTrajectory.load(npz).positions, kept.positions)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
@pytest.mark.parametrize(
    "argv",
    [
        ["demo", "--out", "/proc/demo-out"],
        ["measure", "--save-images", "/proc/images"],
        ["choose-tool", "--record", "/proc/choice.html"],
        ["record-video", "--out", "/proc/video.gif"],
    ],
)
def test_an_output_where_nothing_can_be_written_is_refused_before_the_work(argv, capsys):
    # /proc passes os.access for root, and a file in it fails: the check writes one.
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'/proc'" in err, err
    assert "cannot write in '/proc'" in err or "'/proc' is not writable" in err, err
    assert ".tmp-" not in err
