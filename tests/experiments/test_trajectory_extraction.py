"""Trajectory averaging, the reachability filter, files, and the Baxter playback CSV."""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix

from drake_tooluse.experiments.baxter_csv import CSV_HEADER, export_baxter_csv, read_baxter_csv
from drake_tooluse.experiments.trajectory_extraction import (
    average_episodes,
    average_quaternions,
    filter_reachable,
    pad_episodes,
    shifted,
    smooth,
)
from drake_tooluse.robot.baxter_model import RIGHT_ARM_JOINTS
from drake_tooluse.robot.ik import ToolTipIK, rotation_angle_between
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tip_trajectory import TipTrajectory


def _quat(rpy):
    return RollPitchYaw(rpy).ToQuaternion().wxyz()


def test_quaternion_average_ignores_sign_and_recovers_the_mean_rotation():
    rng = np.random.default_rng(0)
    R0 = RotationMatrix(RollPitchYaw(0.3, -0.2, 1.0))
    qs = []
    for _ in range(200):
        dR = RotationMatrix(RollPitchYaw(rng.normal(0, 0.05, 3)))
        q = (R0 @ dR).ToQuaternion().wxyz()
        qs.append(q if rng.random() < 0.5 else -q)  # random signs: same rotations
    mean = average_quaternions(np.array(qs))
    assert rotation_angle_between(RotationMatrix(Quaternion(mean)), R0) < 0.01
    # A naive component mean of sign-mixed quaternions is wrong; this one is not fooled.
    assert abs(np.linalg.norm(np.mean(qs, axis=0))) < 0.5


def test_average_of_episodes_and_padding():
    a = np.array([[0.0, 0, 0], [1, 0, 0]])
    b = np.array([[0.0, 2, 0], [1, 2, 0], [2, 2, 0]])
    padded = pad_episodes([a, b])
    assert padded.shape == (2, 3, 3) and np.all(padded[0, 2] == [1, 0, 0])
    q = np.tile(_quat(TOOL_DOWN_RPY), (2, 3, 1))
    traj = average_episodes(padded, q, period=0.04)
    np.testing.assert_allclose(traj.positions[2], [1.5, 1, 0])
    np.testing.assert_allclose(traj.times, [0, 0.04, 0.08])
    assert len(smooth(traj, 3)) == 3


def test_reachability_filter_drops_unreachable_poses():
    q_down = _quat(TOOL_DOWN_RPY)
    positions = np.array(
        [[0.65, -0.25, -0.1], [0.66, -0.24, -0.1], [3.0, 0.0, 0.0], [0.67, -0.23, -0.1]]
    )
    traj = TipTrajectory(np.arange(4) * 0.04, positions, np.tile(q_down, (4, 1)))
    report = filter_reachable(traj, 0.175)
    assert report.poses == 4 and report.reachable == 3 and report.dropped_indices == [2]
    ik = ToolTipIK(0.175, library_size=1)
    for q, p in zip(report.joint_positions, report.kept.positions):
        assert np.linalg.norm(ik.fk(q).translation() - p) < 1e-4
        assert -1.35 <= q[1] <= 1.0  # the conservative s1 limits


def test_trajectory_file_round_trip_and_malformed_file(tmp_path):
    traj = TipTrajectory([0, 0.04], [[0.6, 0, 0], [0.6, 0.01, 0]], [_quat(TOOL_DOWN_RPY)] * 2)
    path = traj.save(tmp_path / "t.npz")
    back = TipTrajectory.load(path)
    np.testing.assert_array_equal(back.positions, traj.positions)
    (tmp_path / "bad.npz").write_bytes(b"junk")
    with pytest.raises(ValueError, match="malformed trajectory file"):
        TipTrajectory.load(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="NaN or infinite"):
        TipTrajectory([0], [[np.nan, 0, 0]], [[1, 0, 0, 0]])
    with pytest.raises(ValueError, match="increase strictly"):
        TipTrajectory([0, 0], [[0, 0, 0]] * 2, [[1, 0, 0, 0]] * 2)
    # The arm posture a replay starts from travels with the file, and with a shifted copy.
    assert back.arm_start is None
    planned = TipTrajectory(traj.times, traj.positions, traj.quaternions, np.arange(7) * 0.1)
    again = TipTrajectory.load(planned.save(tmp_path / "planned.npz"))
    np.testing.assert_array_equal(again.arm_start, planned.arm_start)
    np.testing.assert_array_equal(shifted(again, (0.01, 0.0)).arm_start, planned.arm_start)
    with pytest.raises(ValueError, match="arm_start must be 7 joint angles"):
        TipTrajectory([0], [[0, 0, 0]], [[1, 0, 0, 0]], [0.0] * 6)


def test_baxter_csv_format_read_back(tmp_path):
    times = np.array([0.0, 0.5, 1.0])
    right = np.array([[0.1, -0.5, 0, 1.2, 0, 0.8, 0]] * 3) + np.array([[0], [0.05], [0.1]])
    left = [-0.6, -1.0, 0.0, 2.0, 0.0, 0.6, 0.0]
    path = export_baxter_csv(tmp_path / "t.csv", times, right, left)
    header = path.read_text().splitlines()[0].split(",")
    assert header == CSV_HEADER
    assert header[0] == "time" and header[8] == "left_gripper" and header[-1] == "right_gripper"
    data = read_baxter_csv(path)
    np.testing.assert_allclose(data["time"], times)
    for i, name in enumerate(RIGHT_ARM_JOINTS):
        np.testing.assert_allclose(data[name], right[:, i], atol=1e-6)
    assert np.all((data["left_gripper"] >= 0) & (data["right_gripper"] <= 100))


def test_baxter_csv_refuses_limits_and_writes_nothing(tmp_path):
    times = np.array([0.0, 0.1])
    right = np.array([[0.1, -0.5, 0, 1.2, 0, 0.8, 0], [0.1, -0.5, 0, 1.2, 0, 0.8, 0]])
    fast = right.copy()
    fast[1, 0] += 0.5  # 5 rad/s on s0 (limit 1.5)
    with pytest.raises(ValueError, match=r"right_s0 moves at 5 rad/s.*limit is 1.5 rad/s"):
        export_baxter_csv(tmp_path / "fast.csv", times, fast, [0] * 7)
    outside = right.copy()
    outside[0, 3] = 3.0  # e1 upper limit 2.618
    with pytest.raises(ValueError, match=r"right_e1=3 rad at t=0 s is outside"):
        export_baxter_csv(tmp_path / "out.csv", times, outside, [0] * 7)
    assert not list(tmp_path.iterdir())


def test_export_csv_cli_refuses_unreachable_or_malformed_trajectories(tmp_path, capsys):
    from drake_tooluse.cli import main

    q_down = _quat(TOOL_DOWN_RPY)
    good = TipTrajectory(
        [0, 0.5, 1.0], [[0.62, -0.3, -0.1], [0.63, -0.29, -0.1], [0.64, -0.28, -0.1]], [q_down] * 3
    )
    good.save(tmp_path / "good.npz")
    out = tmp_path / "t.csv"
    assert (
        main(
            [
                "export-csv",
                "--trajectory",
                str(tmp_path / "good.npz"),
                "--tool-length",
                "0.175",
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    assert len(out.read_text().splitlines()) == 4
    far = TipTrajectory([0, 0.5], [[0.62, -0.3, -0.1], [3.0, 0, 0]], [q_down] * 2)
    far.save(tmp_path / "far.npz")
    assert (
        main(
            [
                "export-csv",
                "--trajectory",
                str(tmp_path / "far.npz"),
                "--tool-length",
                "0.175",
                "--out",
                str(tmp_path / "far.csv"),
            ]
        )
        == 2
    )
    assert "1 of 2 poses" in capsys.readouterr().err and not (tmp_path / "far.csv").exists()
    (tmp_path / "bad.npz").write_text("no")
    assert (
        main(
            [
                "export-csv",
                "--trajectory",
                str(tmp_path / "bad.npz"),
                "--tool-length",
                "0.175",
                "--out",
                str(tmp_path / "bad.csv"),
            ]
        )
        == 2
    )
    assert "malformed trajectory file" in capsys.readouterr().err


def test_delay_to_event_aligns_the_first_contacts():
    from drake_tooluse.experiments.trajectory_extraction import delay_to_event

    a = np.arange(5, dtype=float)[:, None]  # touches at step 1
    b = np.arange(10, 16, dtype=float)[:, None]  # touches at step 3
    c = np.zeros((2, 1))  # never touches
    out = delay_to_event([a, b, c], [1, 3, None])
    assert out[0][3, 0] == a[1, 0] and out[1][3, 0] == b[3, 0]  # both touch at step 3
    np.testing.assert_array_equal(out[0][:3, 0], [0, 0, 0])  # held at the start meanwhile
    assert out[2] is c


def test_bad_alignment_is_refused(capsys):
    from drake_tooluse.cli import main

    assert main(["transfer", "--mode", "open-loop", "--align", "middle"]) == 2
    assert "align" in capsys.readouterr().err


def test_extraction_time_step_is_the_scenarios_control_period():
    """Regression: `extract` hard-coded period=0.04 s for the averaged trajectory; with a
    scenario whose control period is 0.08 s its poses are 0.08 s apart."""
    import dataclasses as dc

    from drake_tooluse.experiments.trajectory_extraction import extract
    from drake_tooluse.paths import SHIPPED_POLICY
    from drake_tooluse.world.scenario import Scenario, validate_scenario

    s = Scenario()
    slow = validate_scenario(dc.replace(s, control=dc.replace(s.control, control_period=0.08)))
    ex = extract(
        SHIPPED_POLICY,
        episodes=1,
        seed=0,
        window=3,
        tool_length=slow.tool.length,
        env_kwargs={"scenario": slow},
    )
    steps = ex.tip_positions.shape[1]
    assert steps >= 3
    np.testing.assert_allclose(ex.mean.times, np.arange(steps) * 0.08)
    np.testing.assert_array_equal(ex.smoothed.times, ex.mean.times)
    kept = ex.reachability.kept.times
    assert ex.reachability.reachable >= 1
    np.testing.assert_allclose(kept, ex.mean.times[np.searchsorted(ex.mean.times, kept)])


def test_the_commanded_trajectory_replays_the_push_the_achieved_one_lags():
    """Open loop replays a recorded trajectory through the IK. The arm lags its command by
    ~2 cm at full speed, so replaying where the tip got (the paper's recording) commands a
    slower push that trails the closed-loop tip; replaying what each step commanded follows
    it within millimetres (the nominal start, one deterministic episode)."""
    from drake_tooluse.experiments.trajectory_extraction import average_episodes, record_episodes
    from drake_tooluse.paths import DEFAULT_SCENARIO, TRANSFER_POLICY
    from drake_tooluse.robot.model import RobotBelief
    from drake_tooluse.tasks.push.diagram import run_open_loop
    from drake_tooluse.world.scenario import load_scenario

    scenario = load_scenario(DEFAULT_SCENARIO)
    nominal = {"randomize": False}
    achieved = record_episodes(TRANSFER_POLICY, 1, 0, nominal, record="achieved")
    commanded = record_episodes(TRANSFER_POLICY, 1, 0, nominal, record="commanded")
    tip_path = achieved[0][0]  # where the closed-loop tip was at each step
    assert not np.allclose(commanded[0], achieved[0], atol=0.01)  # the command leads
    errors = {}
    for name, (tips, quats, *_, period) in (("achieved", achieved), ("commanded", commanded)):
        run = run_open_loop(
            scenario, average_episodes(tips, quats, period), RobotBelief(scenario.tool.length)
        )
        n = len(tip_path)
        errors[name] = np.linalg.norm(run.tool_path[:n] - tip_path, axis=1).max()
    assert errors["commanded"] < 0.008 < 0.015 < errors["achieved"], errors


def test_box_frame_recording_moves_each_episode_by_where_its_box_started():
    """With `box_frame` each episode is the push of the nominal box: every row of an episode is
    moved across the table by one offset, its box's from the nominal start (within the
    scenario's randomization), and nothing else changes."""
    from drake_tooluse.experiments.trajectory_extraction import record_episodes
    from drake_tooluse.paths import DEFAULT_SCENARIO, TRANSFER_POLICY
    from drake_tooluse.world.scenario import load_scenario

    world = record_episodes(TRANSFER_POLICY, 2, 5)
    box = record_episodes(TRANSFER_POLICY, 2, 5, box_frame=True)
    np.testing.assert_array_equal(world[1], box[1])  # orientations are not moved
    np.testing.assert_array_equal(world[0][:, :, 2], box[0][:, :, 2])  # nor heights
    moved = (world[0] - box[0])[:, :, :2]
    np.testing.assert_allclose(moved, np.broadcast_to(moved[:, :1], moved.shape), atol=1e-12)
    np.testing.assert_allclose((world[2] - box[2])[:, :, :2], moved, atol=1e-12)  # gripper too
    offsets = moved[:, 0]
    assert not np.allclose(offsets[0], offsets[1])  # each episode its own box
    box_xy = load_scenario(DEFAULT_SCENARIO).randomization.box_xy
    assert 1e-3 < np.abs(offsets).max() <= box_xy + 1e-9
