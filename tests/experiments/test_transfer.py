"""The perturbed "reality", the open-loop trajectory source and `drake-tooluse transfer`."""

import dataclasses as dc
import json
import re
from pathlib import Path

import numpy as np
import pytest

from drake_tooluse.cli import main
from drake_tooluse.experiments.line_contact import CALIBRATION_OFFSETS
from drake_tooluse.experiments.transfer import run_transfer, run_worlds
from drake_tooluse.paths import SCENARIOS_DIR, SHIPPED_POLICY, TRANSFER_POLICY
from drake_tooluse.systems.tip_trajectory import TipTrajectory, tip_trajectory_source
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import Scenario, load_scenario, validate_scenario


def test_reality_is_perturbed_and_the_nominal_world_is_not():
    nominal = load_scenario(SCENARIOS_DIR / "push.yaml")
    reality = load_scenario(SCENARIOS_DIR / "reality.yaml")
    assert reality.control.actuation_delay > 0 and reality.robot.conservative_limits
    assert reality.camera.noise_sigma > 0
    n, r, draw = run_worlds(nominal, reality, 0.15, seed=3)
    assert n.tool.length == r.tool.length == 0.15
    # The same box start in both worlds; the rest of the draw only in reality.
    assert n.box.position == r.box.position and n.box.yaw == r.box.yaw
    assert n.box.position != nominal.box.position
    assert (n.box.mass, n.box.friction) == (nominal.box.mass, nominal.box.friction)
    assert r.box.mass == pytest.approx(nominal.box.mass * draw.box_mass_scale)
    assert r.tool.grasp_offset_along == pytest.approx(draw.grasp_along)
    assert abs(draw.grasp_along) <= 0.01 and abs(draw.grasp_across) <= 0.005
    assert 0.7 <= draw.box_mass_scale <= 1.3 and 0.7 <= draw.box_friction_scale <= 1.3
    assert n.control.actuation_delay == 0.0 and not n.robot.conservative_limits
    # Seeded: the same draw again.
    assert run_worlds(nominal, reality, 0.15, seed=3)[2] == draw


def test_draws_cover_the_ranges():
    s = Scenario()
    rng = np.random.default_rng(0)
    draws = [draw_randomization(s, rng) for _ in range(300)]
    along = np.array([d.grasp_along for d in draws])
    assert along.min() < -0.009 and along.max() > 0.009
    assert apply_draw(s, draws[0], box_pose_only=True).tool == s.tool


@pytest.mark.parametrize(
    "delay, match",
    [(0.03, "multiple of plant.time_step"), (0.5, r"control.actuation_delay=0.5.*\[0, 0.2\]")],
)
def test_bad_actuation_delay_is_refused(delay, match):
    s = Scenario()
    with pytest.raises(ValueError, match=match):
        validate_scenario(dc.replace(s, control=dc.replace(s.control, actuation_delay=delay)))


def test_delayed_arm_holds_still_at_the_start():
    """The delay's buffer starts at the home target, not zeros (which would fling the arm)."""
    import gymnasium as gym

    import drake_tooluse  # noqa: F401

    env = gym.make(
        "drake_tooluse/ToolPush-v1", scenario=SCENARIOS_DIR / "reality.yaml", action_mode="position"
    )
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        obs2, *_ = env.step(np.zeros(3))
    assert np.linalg.norm(obs2[6:9] - obs[6:9]) < 0.01


def test_a_saved_trajectory_loads_bit_for_bit(tmp_path):
    """Its quaternions are normalised once (not again on load, nor the caller's array)."""
    quaternions = np.random.default_rng(0).normal(size=(20, 4))
    given = quaternions.copy()
    traj = TipTrajectory(np.arange(20.0), np.zeros((20, 3)), quaternions)
    assert np.array_equal(quaternions, given)
    np.testing.assert_allclose(np.linalg.norm(traj.quaternions, axis=1), 1.0, atol=1e-15)
    loaded = TipTrajectory.load(traj.save(tmp_path / "t.npz"))
    assert np.array_equal(loaded.quaternions, traj.quaternions)


def test_tip_trajectory_source_interpolates_holds_and_leads():
    q = np.array([0.0, 1.0, 0.0, 0.0])
    traj = TipTrajectory([0.0, 0.1, 0.2], [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]], [q, -q, q])
    source = tip_trajectory_source(traj, lead=0.1)
    context = source.CreateDefaultContext()

    def at(t):
        context.SetTime(t)
        return source.get_output_port().Eval(context)

    np.testing.assert_allclose(at(0.0)[:3], [0.1, 0, 0], atol=1e-12)  # led by 0.1 s
    np.testing.assert_allclose(at(0.05)[:3], [0.15, 0, 0], atol=1e-12)
    np.testing.assert_allclose(at(5.0)[:3], [0.2, 0, 0], atol=1e-12)  # held after the end
    np.testing.assert_allclose(np.abs(at(0.05)[3:]), q, atol=1e-12)  # no flip through zero


@pytest.mark.slow  # ~1.2-2.4 s: with the slow tests CI runs
def test_transfer_closed_loop_json(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["transfer", "--runs", "1", "--tools", "0.15", "--out", "t", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mode"] == "closed-loop" and out["runs"] == 1
    (tool,) = out["tools"]
    assert tool["tool_length_m"] == 0.15
    assert abs(tool["measured_length_mean_m"] - 0.15) < 0.002  # the camera, with noise
    for world in ("nominal", "reality"):
        (run,) = tool[world]["per_run"]
        assert run["world"] == world and run["seed"] == 0
        assert 0.0 <= run["object_travel_m"] < 0.5 and run["final_object_to_goal_m"] >= 0.0
        assert tool[world]["object_travel_mean_m"] == run["object_travel_m"]
    assert tool["nominal"]["per_run"][0]["believed_length_m"] == 0.15
    assert tool["reality"]["per_run"][0]["believed_length_m"] == tool["measured_length_mean_m"]
    # The camera's grasp estimate is in the robot's model, within a millimetre of the truth.
    assert out["use_grasp_estimate"] and tool["grasp_along_error_max_m"] < 0.001
    assert tool["nominal"]["per_run"][0]["believed_grasp_along_m"] == 0.0
    reality_run = tool["reality"]["per_run"][0]
    assert reality_run["believed_grasp_along_m"] == pytest.approx(
        reality_run["perturbation"]["grasp_along"], abs=0.001
    )
    assert out["goals"]["tool_travel_difference_m"] is None  # one tool
    assert json.loads((tmp_path / "t" / "transfer.json").read_text())["tools"] == out["tools"]
    assert (tmp_path / "t" / "transfer_boxplot.png").stat().st_size > 1000
    # One rule for the paths it records: absolute (a relative --out too).
    for key in ("policy", "nominal_scenario", "reality_scenario", "figure", "json"):
        assert Path(out[key]).is_absolute() and Path(out[key]).exists(), key


def test_transfer_open_loop_replays_a_trajectory_file(tmp_path):
    from drake_tooluse.world.scene import home_tip_pose

    X = home_tip_pose(Scenario())
    p0 = X.translation()
    quat = X.rotation().ToQuaternion().wxyz()
    # Down to the table beside the box, then along +y through it.
    times = np.arange(0, 2.0, 0.04)
    path = np.array(
        [
            p0 + [0.08, 0.0, -0.08 * min(1, t)] if t < 1 else p0 + [0.08, 0.25 * (t - 1), -0.08]
            for t in times
        ]
    )
    traj = TipTrajectory(times, path, np.tile(quat, (len(times), 1)))
    result = run_transfer(
        SHIPPED_POLICY,
        tools=[0.175],
        runs=1,
        mode="open-loop",
        trajectory=traj,
        log=lambda text: None,
    )
    (tool,) = result["tools"]
    for world in ("nominal", "reality"):
        assert tool[world]["per_run"][0]["steps"] == int(np.ceil((1.96 + 1.0) / 0.04))
    assert tool["nominal"]["object_travel_mean_m"] > 0.02  # the scripted sweep hit the box


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--mode", "sideways"], r"--mode: unknown mode 'sideways'; choose one of \['closed-loop'"),
        (["--tools", "0.7"], r"0.7.*\(0, 0.6\]"),
        (["--runs", "0"], r"--runs=0 is outside the allowed range \[1, 10000\]"),
        (
            ["--mode", "open-loop", "--extraction", "median"],
            r"--extraction: unknown extraction 'median'; choose one of \['line-contact', 'mean-achieved'\]",
        ),
    ],
)
def test_transfer_bad_input(argv, match, capsys, tmp_path):
    assert main(["transfer", "--out", str(tmp_path / "t"), *argv]) == 2
    err = capsys.readouterr().err
    assert re.search(match, err), err
    assert not (tmp_path / "t").exists()


def test_open_loop_needs_a_trajectory():
    with pytest.raises(ValueError, match="open-loop transfer needs a trajectory"):
        run_transfer(SHIPPED_POLICY, tools=[0.15], runs=1, mode="open-loop")


def test_malformed_trajectory_file_is_refused(tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    np.savez(bad, times=[0.0, 1.0], positions=[[0, 0, 0]])
    assert (
        main(
            [
                "transfer",
                "--mode",
                "open-loop",
                "--trajectory",
                str(bad),
                "--out",
                str(tmp_path / "t"),
            ]
        )
        == 2
    )
    assert "malformed trajectory file" in capsys.readouterr().err
    assert not (tmp_path / "t").exists()


@pytest.mark.parametrize("delay", [0.02, 0.04])
def test_actuation_delay_is_the_configured_time(delay):
    """A step in the joint target moves the arm exactly `delay` later than without a delay."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    from drake_tooluse.builders.control import TipControl, add_joint_command, add_world_at_home

    def first_motion(actuation_delay):
        s = Scenario()
        s = dc.replace(s, control=dc.replace(s.control, actuation_delay=actuation_delay))
        builder = DiagramBuilder()
        world, ik, q0 = add_world_at_home(builder, s)
        q1 = q0.copy()
        q1[0] += 0.1
        step = builder.AddSystem(
            TrajectorySource(
                PiecewisePolynomial.ZeroOrderHold([0.0, 0.21, 5.0], np.array([q0, q1, q1]).T)
            )
        )
        control = TipControl(None, ik, q0)
        add_joint_command(builder, world, step.get_output_port(), control)
        simulator = Simulator(builder.Build())
        control.reset(simulator.get_mutable_context())
        simulator.Initialize()
        plant_context = world.plant.GetMyContextFromRoot(simulator.get_context())
        for k in range(1, 40):
            simulator.AdvanceTo(k * s.plant.time_step)
            if abs(world.arm_joints()[0].get_angular_rate(plant_context)) > 1e-4:
                return k * s.plant.time_step
        raise AssertionError("the arm never moved")

    assert first_motion(delay) - first_motion(0.0) == pytest.approx(delay)


def test_worlds_posing_different_tasks_are_refused():
    nominal = load_scenario(SCENARIOS_DIR / "push.yaml")
    reality = load_scenario(SCENARIOS_DIR / "reality.yaml")
    moved = dc.replace(reality, box=dc.replace(reality.box, position=[0.65, -0.25, 0.0]))
    with pytest.raises(ValueError, match=r"different tasks: box.position: nominal \[0.7"):
        run_transfer(
            SHIPPED_POLICY, tools=[0.15], runs=1, nominal_scenario=nominal, reality_scenario=moved
        )


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_transfer_length_only_is_the_papers_measurement(tmp_path):
    result = run_transfer(
        SHIPPED_POLICY, tools=[0.15], runs=1, log=lambda text: None, use_grasp_estimate=False
    )
    (run,) = result["tools"][0]["reality"]["per_run"]
    assert not result["use_grasp_estimate"] and run["believed_grasp_along_m"] == 0.0


def _fake_result(runs: int, tools=(0.15, 0.3)) -> dict:
    rng = np.random.default_rng(1)

    def world(travel):
        per_run = [
            {"object_travel_m": travel + 0.002 * rng.standard_normal(), "failed": False}
            for _ in range(runs)
        ]
        values = [r["object_travel_m"] for r in per_run]
        return {
            "per_run": per_run,
            "object_travel_mean_m": float(np.mean(values)),
            "object_travel_std_m": float(np.std(values)),
            "final_object_to_goal_mean_m": 0.05,
            "success_rate": 0.0,
            "failed_runs": 0,
        }

    return {
        "mode": "closed-loop",
        "runs": runs,
        "use_grasp_estimate": True,
        "tools": [
            {
                "tool_length_m": t,
                "measured_length_mean_m": t + 0.0002,
                "measured_length_std_m": 0.0 if runs == 1 else 0.0004,
                "nominal": world(0.18),
                "reality": world(0.181),
                "travel_ratio": 1.005,
            }
            for t in tools
        ],
        "goals": {
            "travel_ratio_min": 1.005,
            "travel_ratio_goal": 0.9,
            "travel_ratio_met": True,
            "tool_travel_difference_m": 0.003 if len(tools) > 1 else None,
            "tool_travel_difference_goal_m": 0.01,
            "tool_difference_met": len(tools) > 1,
        },
        "json": "t/transfer.json",
        "figure": "t/transfer_boxplot.png",
        "wall_time_s": 12.0,
    }


def test_transfer_text_speaks_mm_runs_and_keeps_the_two_goals_apart():
    from drake_tooluse.experiments.transfer import format_transfer

    one = format_transfer(_fake_result(1))
    assert "1 run per tool" in one and "1 runs" not in one
    assert "tool 150 mm (camera measured 150.2 mm)" in one  # no spread of one run
    assert "±" not in one and "0.1502" not in one
    assert "box at the goal (the env's success) in 0 % of nominal and 0 % of reality runs" in one
    assert "the experiment's criteria (the skill transfers; not the box at the goal)" in one
    assert "keeps >= 90 % of the nominal box travel for every tool: met (lowest 100 %)" in one
    assert "goal >=" not in one and "goal <=" not in one  # the old, ambiguous words
    many = format_transfer(_fake_result(10))
    assert "10 runs per tool" in many and "measured 150.2 mm ± 0.40 mm" in many
    assert "the tools' mean reality travel within 1 cm of each other: met" in many


@pytest.mark.parametrize("runs", [1, 4, 10])
def test_transfer_plot_draws_points_for_few_runs_and_tells_the_tools_apart(runs):
    from matplotlib.collections import PathCollection
    from matplotlib.patches import PathPatch

    from drake_tooluse.experiments.transfer import MIN_RUNS_FOR_BOXES, transfer_figure

    (ax,) = transfer_figure(_fake_result(runs)).axes
    boxes = [p for p in ax.patches if isinstance(p, PathPatch)]
    points = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(points) == 4 and all(len(c.get_offsets()) == runs for c in points)
    assert len(boxes) == (4 if runs >= MIN_RUNS_FOR_BOXES else 0)  # no box pretends a spread
    # Colour is the world, the same for both tools; the marker (and hatching) is the tool.
    colors = [tuple(c.get_facecolor()[0]) for c in points]
    assert colors[0] == colors[2] and colors[1] == colors[3] and colors[0] != colors[1]
    paths = [c.get_paths()[0].vertices.tobytes() for c in points]
    assert paths[0] == paths[1] and paths[0] != paths[2]
    if boxes:
        assert boxes[0].get_hatch() != boxes[2].get_hatch()
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels == ["tool 15.0 cm ●", "tool 30.0 cm ■"]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["nominal simulation", "reality"]
    assert ("1 run per tool" if runs == 1 else f"{runs} runs per tool") in ax.get_title()


@pytest.mark.slow  # ~8 s: an extraction and a calibration; .ci/run runs it
def test_open_loop_transfer_by_default_replays_a_line_contact_trajectory_per_tool(tmp_path):
    """The default open-loop transfer: the trajectory made of the episodes in their boxes'
    frame, one per tool (tilted as `experiments.line_contact` chose), each run's replay moved
    to its box's start: in reality as the hand camera measured it, in the nominal world the
    truth. Two episodes and one run per tool stand in for the experiment."""
    from drake_tooluse.experiments.transfer import format_transfer, transfer_experiment

    out = tmp_path / "t"
    result = transfer_experiment(
        out, TRANSFER_POLICY, tools=[0.15], runs=1,
        mode="open-loop", episodes=2, log=lambda text: None, calibration_draws=1,
    )  # fmt: skip
    assert result["box_frame"]
    made = result["trajectory"]
    assert made["extraction"] == "line-contact" and made["record"] == "commanded"
    for tool in result["tools"]:
        chosen = made["by_tool"][f"{tool['tool_length_m']:g}"]
        assert chosen["followed"] and chosen["tilt_deg"] > 0
        assert len(chosen["calibration"]) == len(CALIBRATION_OFFSETS)  # one nominal draw each
        replayed = TipTrajectory.load(chosen["file"])
        assert len(replayed) == chosen["kept"] == chosen["poses"]
        reality, nominal = tool["reality"]["per_run"][0], tool["nominal"]["per_run"][0]
        assert reality["box_xy_error_m"] < 0.002  # the hand camera's estimate
        assert nominal["box_xy_error_m"] == 0.0  # the nominal robot knows its box
        assert not reality["failed"] and not nominal["failed"]
    assert "line contact" in format_transfer(result) and "tool tilted" in format_transfer(result)
    # The same trajectory as a file (as `drake-tooluse trajectory` writes it) replays the same:
    # moved to each run's box start.
    from_file = transfer_experiment(
        tmp_path / "f", TRANSFER_POLICY, tools=[0.15], runs=1, mode="open-loop",
        trajectory_path=made["by_tool"]["0.15"]["file"], log=lambda text: None,
    )  # fmt: skip
    assert from_file["box_frame"] and from_file["trajectory"]["extraction"] == "line-contact"
    assert "made for the nominal box start, replayed at each run's box start" in format_transfer(
        from_file
    )
    for world in ("nominal", "reality"):
        again, first = from_file["tools"][0][world], result["tools"][0][world]
        assert again["per_run"][0]["believed_box_xy_m"] == first["per_run"][0]["believed_box_xy_m"]
        assert again["object_travel_mean_m"] == pytest.approx(
            first["object_travel_mean_m"], abs=1e-9
        )
    # The paper's own: one trajectory for every tool, replayed as it is, of where the tip got.
    paper = transfer_experiment(
        tmp_path / "p", TRANSFER_POLICY, tools=[0.15], runs=1, mode="open-loop", episodes=1,
        extraction="mean-achieved", log=lambda text: None,
    )  # fmt: skip
    assert not paper["box_frame"] and paper["trajectory"]["record"] == "achieved"
    assert "box_xy_error_m" not in paper["tools"][0]["reality"]["per_run"][0]
    assert (tmp_path / "p" / "trajectory.npz").is_file()


@pytest.mark.slow  # ~8 s: a hook measured twice by the head camera; .ci/run runs it
def test_length_only_holds_a_hook_at_the_nominal_grasp_too():
    """`--length-only` (the paper's measurement: the tool's size only) for either kind of tool:
    the hook's measured grasp along its handle is not used either."""
    from drake_tooluse.experiments.task_worlds import measure, task_scenarios
    from drake_tooluse.robot.tool import parse_tool

    nominal, reality = task_scenarios("pull")
    hook = parse_tool("hook:0.25,0.05,90")
    _, held, _ = run_worlds(nominal, reality, hook, seed=3)
    assert abs(held.tool.grasp_offset_along) > 0.001  # the draw moved the grasp
    estimated, measurement = measure(held, hook, 3)
    assert estimated.grasp_offset[1] == measurement.grasp_along
    assert abs(measurement.grasp_along - held.tool.grasp_offset_along) < 0.001
    length_only, _ = measure(held, hook, 3, use_grasp_estimate=False)
    assert length_only.grasp_offset == (0.0, 0.0)
