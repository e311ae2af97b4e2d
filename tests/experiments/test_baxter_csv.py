"""The real-robot export checks both arms against each other and the table over the whole
trajectory before it writes anything, the left arm stays where the operator says, and a
trajectory too fast for the arm is refused with the smallest `--time-scale` that passes."""

import re

import numpy as np
import pytest
from pydrake.math import RollPitchYaw

from drake_tooluse.cli import main
from drake_tooluse.experiments.baxter_csv import (
    LEFT_ARM_SAFE,
    check_clearance,
    check_left_arm,
    read_baxter_csv,
)
from drake_tooluse.robot.baxter_model import LEFT_ARM_JOINTS
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.world.scenario import RobotConfig, TableConfig

HOME = np.array([RobotConfig().posture_seed])  # the tool tip ~9 cm above the table
ON_THE_TABLE = (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # the left arm straight down and forward
ACROSS = (-1.5, -0.5, 0.0, 1.0, 0.0, 0.5, 0.0)  # the left arm swung into the right's space


def test_the_default_left_arm_pose_is_tucked_and_clear():
    clearance = check_clearance(HOME, None, 0.175)
    assert clearance["arms_m"] > 0.25 and clearance["tool_tip_above_table_m"] > 0.05
    np.testing.assert_array_equal(check_left_arm(None), LEFT_ARM_SAFE)
    # The simulation's welded pose is 12 cm over the table: allowed when asked for.
    assert check_clearance(HOME, RobotConfig().left_arm_q, 0.175)["table_m"] > 0.1


@pytest.mark.parametrize(
    "left_q, message",
    [
        (ON_THE_TABLE, r"the left arm at .* reaches 43.0 cm into the table \(left_gripper_base\)"),
        (ACROSS, r"at t=0 s the right arm's right_hand reaches .* into the left arm's left_lower"),
        ((0.0, 3.0, 0, 0, 0, 0, 0), r"left_q: left_s1=3 rad is outside \[-2.147, 1.047\] rad"),
    ],
)
def test_a_left_arm_in_the_way_is_refused(left_q, message):
    with pytest.raises(ValueError, match=message):
        check_clearance(HOME, left_q, 0.175)


def test_an_arm_or_tool_too_close_to_the_table_is_refused():
    with pytest.raises(ValueError, match=r"tool reaches .* mm into the table"):
        check_clearance(HOME, None, 0.175, TableConfig(top_z=-0.05))
    with pytest.raises(ValueError, match=r"right arm's right_\w+ .* the table"):
        check_clearance(HOME, None, 0.175, TableConfig(top_z=0.05))


def _trajectory(tmp_path, dt=0.5):
    q = RollPitchYaw(*TOOL_DOWN_RPY).ToQuaternion().wxyz()
    path = tmp_path / "t.npz"
    TipTrajectory(
        [0, dt, 2 * dt],
        [[0.62, -0.3, -0.1], [0.63, -0.29, -0.1], [0.64, -0.28, -0.1]],
        [q] * 3,
    ).save(path)
    return path


def test_a_trajectory_too_fast_names_the_smallest_time_scale_that_passes(tmp_path, capsys):
    argv = ["export-csv", "--trajectory", str(_trajectory(tmp_path, dt=0.01)), "--tool-length"]
    argv += ["0.175", "--out", str(tmp_path / "fast.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    found = re.search(r"the smallest --time-scale that keeps every joint .* is ([0-9.]+);", err)
    assert found and "rad/s" in err and "nothing written" in err, err
    smallest = float(found.group(1))
    assert smallest > 1 and not (tmp_path / "fast.csv").exists()
    assert main([*argv, "--time-scale", f"{smallest - 0.01:g}"]) == 2
    assert f"is {smallest:g};" in capsys.readouterr().err  # the same answer from any scale
    assert main([*argv, "--time-scale", f"{smallest:g}"]) == 0
    data = read_baxter_csv(tmp_path / "fast.csv")
    assert data["time"][-1] == pytest.approx(0.02 * smallest, abs=1e-6)


def test_export_csv_keeps_the_left_arm_where_the_operator_says(tmp_path, capsys):
    argv = ["export-csv", "--trajectory", str(_trajectory(tmp_path)), "--tool-length", "0.175"]
    assert main([*argv, "--out", str(tmp_path / "safe.csv"), "--json"]) == 0
    data = read_baxter_csv(tmp_path / "safe.csv")
    for joint, angle in zip(LEFT_ARM_JOINTS, LEFT_ARM_SAFE):
        np.testing.assert_allclose(data[joint], angle, atol=1e-6)
    capsys.readouterr()
    bad = [str(v) for v in ACROSS]
    assert main([*argv, "--out", str(tmp_path / "bad.csv"), "--left-arm-q", *bad]) == 2
    err = capsys.readouterr().err
    assert "into the left arm's" in err and "nothing written" in err
    assert not (tmp_path / "bad.csv").exists()
