"""benchmarks/shape_vision_accuracy.py: bad arguments are one-line errors before any
measurement, and a small run prints both conditions and writes the figures it prints."""

import json

import pytest

from tests.benchmark_scripts import benchmark_script


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--tools", "0"], "--tools=0 is outside the allowed range [1, 100000]"),
        (["--depth-noise", "0.2"], "--depth-noise=0.2"),
        (["--noise", "-1"], "--noise=-1"),
        (["--lighting", "disco"], "--lighting"),
        (["--reference", "-2"], "--reference=-2"),
    ],
)
def test_bad_arguments_are_one_line_errors(argv, message, monkeypatch, capsys):
    monkeypatch.setattr("sys.argv", ["shape_vision_accuracy.py", *argv])
    with pytest.raises(SystemExit) as exit:
        benchmark_script("shape_vision_accuracy").main()
    out, err = capsys.readouterr()
    assert exit.value.code == 2 and message in err and out == ""


@pytest.mark.slow
def test_a_small_run_measures_both_conditions(tmp_path, monkeypatch, capsys):
    out_file = tmp_path / "shape.json"
    argv = ["--tools", "1", "--tool-seed", "3", "--reference", "1", "--out", str(out_file)]
    monkeypatch.setattr("sys.argv", ["shape_vision_accuracy.py", *argv])
    benchmark_script("shape_vision_accuracy").main()
    table = capsys.readouterr().out
    assert "| clean |" in table and "| noisy |" in table and "marker bands" in table
    figures = json.loads(out_file.read_text())
    for condition in ("clean", "noisy"):
        (tool,) = figures["results"]["conditions"][condition]["tools"]
        assert tool["max_frame_error_mm"] == max(tool["frame_errors_mm"].values())
    assert len(figures["results"]["reference"]) == 2
