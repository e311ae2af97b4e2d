"""The command line: JSON output and clear errors on bad input."""

import json

import pytest

from drake_tooluse.cli import EXIT_NOT_REACHED, main
from tests.cli.test_parser import strict_json


def run(capsys, *argv):
    code = main(list(argv))
    captured = capsys.readouterr()
    if "--json" in argv:
        strict_json(captured.out)  # strict JSON: no NaN or Infinity
    return code, captured.out, captured.err


def test_fk_json(capsys):
    code, out, _ = run(
        capsys, "fk", "--tool-length", "0.175", "--q", "0", "0", "0", "0", "0", "0", "0", "--json"
    )
    assert code == 0
    data = json.loads(out)
    assert len(data["tip"]["position_m"]) == 3 and len(data["tip"]["quaternion_wxyz"]) == 4
    # The tip is 0.175 m beyond the gripper along the gripper's z axis.
    g, t = data["gripper"]["position_m"], data["tip"]["position_m"]
    assert sum((a - b) ** 2 for a, b in zip(g, t)) ** 0.5 == pytest.approx(0.175)


def test_ik_json_round_trips_fk(capsys):
    _, out, _ = run(
        capsys,
        "fk",
        "--tool-length",
        "0.125",
        "--q",
        "0.5",
        "-0.6",
        "0.1",
        "1.4",
        "0.2",
        "0.9",
        "0.3",
        "--json",
    )
    tip = json.loads(out)["tip"]
    code, out, _ = run(
        capsys,
        "ik",
        "--tool-length",
        "0.125",
        "--position",
        *map(str, tip["position_m"]),
        "--quaternion",
        *map(str, tip["quaternion_wxyz"]),
        "--json",
    )
    data = json.loads(out)
    assert code == 0 and data["success"] and data["position_error_m"] < 1e-5
    assert len(data["q"]) == 7 and data["solve_time_s"] > 0


def test_simulate_json_and_recording(capsys, tmp_path):
    html = tmp_path / "out.html"
    code, out, _ = run(
        capsys,
        "simulate",
        "--tip-waypoints",
        "0.66,-0.2,-0.12",
        "--move-time",
        "0.5",
        "--dwell",
        "0.5",
        "--record",
        str(html),
        "--json",
    )
    data = json.loads(out)
    assert code == 0 and data["max_position_error_m"] < 1e-3
    assert html.is_file() and data["recording"] == str(html)


def test_simulate_exits_3_when_the_ik_misses_a_waypoint(capsys):
    argv = ["simulate", "--tip-waypoints", "0.66,-0.2,-0.12", "3,0,0", "--move-time", "0.1"]
    argv += ["--dwell", "0"]
    code, out, _ = run(capsys, *argv)
    assert code == EXIT_NOT_REACHED
    assert "NOT REACHED (exit code 3): the IK found no joint angles for waypoint(s) [1]" in out
    code, out, _ = run(capsys, *argv, "--json")
    assert code == EXIT_NOT_REACHED
    assert [w["ik_success"] for w in json.loads(out)["waypoints"]] == [True, False]


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["fk", "--tool-length", "0", "--q", *["0"] * 7],
            "--tool-length=0 m is outside the allowed range (0, 0.6]",
        ),
        (
            ["fk", "--tool-length", "nan", "--q", *["0"] * 7],
            "--tool-length=nan must be a finite number",
        ),
        (["fk", "--tool-length", "0.7", "--q", *["0"] * 7], "outside the allowed range (0, 0.6]"),
        (["fk", "--no-tool", "--q", *["0"] * 6], "--q has 6 values; it needs exactly 7"),
        (
            ["fk", "--no-tool", "--q", "0", "3", *["0"] * 5],
            "right_s1=3 rad outside [-2.147, 1.047]",
        ),
        (
            ["ik", "--tool-length", "0.1", "--position", "0.6", "inf", "0"],
            "--position=[0.6, inf, 0.0] must be finite",
        ),
        (
            [
                "ik",
                "--tool-length",
                "0.1",
                "--position",
                "0.6",
                "0",
                "0",
                "--quaternion",
                "0",
                "0",
                "0",
                "0",
            ],
            "zero norm",
        ),
        (["ik", "--position", "0.6", "0", "0"], "give --tool-length L"),
        (
            ["simulate", "--scenario", "missing.yaml", "--tip-waypoints", "0.6,0,0"],
            "scenario file not found: 'missing.yaml'",
        ),
        (["simulate", "--tip-waypoints", "0.6,0"], "needs 3 (x,y,z m) or 6"),
    ],
)
def test_bad_input_exits_2_with_a_clear_message(capsys, argv, message):
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert message in err


def test_measure_box_json(capsys):
    code, out, _ = run(capsys, "measure-box", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["error_m"] < 0.002
    assert data["top_face_points"] > 100


@pytest.mark.slow  # ~6 s: two extractions; .ci/run runs it
def test_trajectory_line_contact_and_paper(capsys, tmp_path):
    """`trajectory` makes what `transfer --mode open-loop` replays: by default the line-contact
    trajectory for the nominal box start (the tool tilted: its axis leaves the vertical), or
    with `--extraction paper` the paper's (the tool as recorded, pointing down)."""
    import numpy as np
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    from drake_tooluse.paths import TRANSFER_POLICY
    from drake_tooluse.systems.tip_trajectory import TipTrajectory

    tilts, made = {}, {}
    for extraction in ("line-contact", "mean-achieved"):
        out = tmp_path / extraction
        code, text, err = run(
            capsys, "trajectory", "--policy", str(TRANSFER_POLICY), "--episodes", "2",
            "--tool-length", "0.15", "--extraction", extraction, "--out", str(out), "--json",
            "--calibration-draws", "1",
        )  # fmt: skip
        assert code == 0, err
        made[extraction] = data = json.loads(text)
        assert data["extraction"] == extraction
        last = TipTrajectory.load(out / "trajectory.npz").quaternions[-1]
        axis = RotationMatrix(Quaternion(last / np.linalg.norm(last))).matrix()[:, 2]
        tilts[extraction] = np.degrees(np.arccos(-axis[2]))
    assert (
        made["line-contact"]["line_contact"]["tilt_deg"] == 30
        and "line_contact" not in made["mean-achieved"]
    )
    assert abs(tilts["line-contact"] - 30) < 1 and tilts["mean-achieved"] < 5, tilts
