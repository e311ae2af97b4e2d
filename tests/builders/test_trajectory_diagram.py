"""Tool-tip trajectories through the IK to the plant: waypoints, beliefs, the actuation delay,
Meshcat recordings."""

import base64
import re

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator

from drake_tooluse.builders.trajectory_diagram import build_trajectory_diagram, simulate_waypoints
from drake_tooluse.robot.model import TOOL_DOWN_RPY, RobotBelief
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.world.scenario import Scenario, with_tool_length
from drake_tooluse.world.scene import home_tip_pose

DOWN = RollPitchYaw(*TOOL_DOWN_RPY)


def _recorded_scene_paths(html: str) -> bytes:
    """Meshcat's standalone HTML embeds its commands as base64 msgpack payloads."""
    payloads = re.findall(r'base64,([A-Za-z0-9+/=]+)"', html)
    return b"".join(base64.b64decode(p) for p in payloads)


def test_waypoints_with_recording(tmp_path):
    waypoints = [
        RigidTransform(DOWN, [0.66, -0.2, -0.12]),
        RigidTransform(DOWN, [0.6, -0.35, -0.1]),
    ]
    out = tmp_path / "run.html"
    run = simulate_waypoints(Scenario(), waypoints, move_time=0.6, dwell=0.8, record=out)
    assert [r.ik_success for r in run.results] == [True, True]
    assert max(r.position_error for r in run.results) < 1e-3
    html = out.read_text()
    assert html.lstrip().lower().startswith("<!doctype html") or "<html" in html[:200].lower()
    blob = _recorded_scene_paths(html)
    for name in (b"right_upper_shoulder", b"tool", b"box", b"table", b"animation"):
        assert name in blob, name


def test_believed_length_error_shows_up_at_the_tip():
    # The robot believes 0.165 m but holds 0.175 m, pointing down: the true tip ends 1 cm low.
    target = RigidTransform(DOWN, [0.64, -0.25, -0.12])
    run = simulate_waypoints(
        Scenario(), [target], move_time=0.6, dwell=0.8, belief=RobotBelief(0.165)
    )
    result = run.results[0]
    assert result.reached[2] == pytest.approx(target.translation()[2] - 0.01, abs=1e-3)


def test_believed_grasp_reaches_the_ik():
    """A grasp shifted 5 mm along the tool: the tip misses by 5 mm when the robot believes the
    nominal grasp, and lands when its model holds the shift (the belief's grasp)."""
    import dataclasses as dc

    from pydrake.math import RigidTransform, RollPitchYaw

    from drake_tooluse.builders.trajectory_diagram import simulate_waypoints
    from drake_tooluse.robot.model import TOOL_DOWN_RPY
    from drake_tooluse.world.scenario import Scenario, validate_scenario

    s = Scenario()
    s = validate_scenario(dc.replace(s, tool=dc.replace(s.tool, grasp_offset_along=0.005)))
    target = [RigidTransform(RollPitchYaw(*TOOL_DOWN_RPY), [0.66, -0.2, -0.12])]
    naive = simulate_waypoints(s, target, move_time=0.5, dwell=0.5, belief=RobotBelief(0.175))
    told = simulate_waypoints(
        s, target, move_time=0.5, dwell=0.5, belief=RobotBelief(0.175, (0.0, 0.005))
    )
    assert abs(naive.results[0].position_error - 0.005) < 2e-4
    assert told.results[0].position_error < 2e-4


def _with_actuation_delay(scenario, delay):
    import dataclasses as dc

    from drake_tooluse.world.scenario import validate_scenario

    return validate_scenario(
        dc.replace(scenario, control=dc.replace(scenario.control, actuation_delay=delay))
    )


def _true_tip_path(scenario, target, move_time, duration):
    """The trajectory diagram moving the tip from home to `target` in `move_time` (no dwell);
    returns it and the true tip's position at every plant tick up to `duration`."""
    from drake_tooluse.builders.trajectory_diagram import build_trajectory_diagram
    from drake_tooluse.systems.tip_trajectory import waypoint_trajectory
    from drake_tooluse.world.scene import home_tip_pose

    trajectory = waypoint_trajectory(home_tip_pose(scenario), [target], move_time, 0.0)
    built = build_trajectory_diagram(scenario, trajectory)
    simulator = Simulator(built.diagram)
    root = simulator.get_mutable_context()
    built.control.reset(root)
    simulator.Initialize()
    plant_context = built.world.plant.GetMyContextFromRoot(root)
    dt = scenario.plant.time_step
    path = []
    for k in range(round(duration / dt) + 1):
        simulator.AdvanceTo(k * dt)
        path.append(built.world.tip_frame.CalcPoseInWorld(plant_context).translation().copy())
    return built, np.array(path)


def test_actuation_delay_makes_the_tip_follow_the_same_path_later():
    """Regression: the waypoint diagram wired the IK straight to the plant, so the scenario's
    `control.actuation_delay` was ignored. The IK runs open loop on the trajectory, so with a
    0.08 s delay the true tip follows the undelayed path exactly 0.08 s (4 plant ticks) later."""
    s = Scenario()
    target = RigidTransform(DOWN, [0.66, -0.2, -0.12])
    prompt, prompt_path = _true_tip_path(_with_actuation_delay(s, 0.0), target, 0.3, 0.6)
    late, late_path = _true_tip_path(_with_actuation_delay(s, 0.08), target, 0.3, 0.6)
    assert prompt.control.delay is None and late.control.delay is not None
    lag = round(0.08 / s.plant.time_step)
    assert np.linalg.norm(prompt_path[-1] - prompt_path[0]) > 0.1  # the arm did move ~11 cm
    assert np.abs(late_path - prompt_path).max() > 0.01  # ... and the delay shows
    np.testing.assert_allclose(
        late_path[:lag], np.repeat(prompt_path[:1], lag, axis=0), atol=1e-6
    )  # still at home while the first command is in flight
    np.testing.assert_allclose(late_path[lag:], prompt_path[:-lag], atol=1e-6)


def test_simulate_cli_honours_the_reality_scenarios_actuation_delay(tmp_path, capsys):
    """`drake-tooluse simulate --scenario diagrams/reality.yaml` (joint targets 40 ms late):
    halfway through a short move the tip lags further behind the target than in the same
    scenario without the delay (it used to be the same)."""
    import json

    from drake_tooluse.cli import main
    from drake_tooluse.paths import SCENARIOS_DIR

    reality = SCENARIOS_DIR / "reality.yaml"
    prompt = tmp_path / "prompt.yaml"
    prompt.write_text(f"base: {reality}\ncontrol:\n  actuation_delay: 0.0\n")
    errors = []
    for path in (reality, prompt):
        assert (
            main(
                [
                    "simulate",
                    "--scenario",
                    str(path),
                    "--tip-waypoints",
                    "0.66,-0.2,-0.12",
                    "--move-time",
                    "0.3",
                    "--dwell",
                    "0.0",
                    "--json",
                ]
            )
            == 0
        )
        waypoint = json.loads(capsys.readouterr().out)["waypoints"][0]
        assert waypoint["ik_success"]
        errors.append(waypoint["position_error_m"])
    late, on_time = errors
    assert late > on_time + 0.005, errors  # measured: 62 mm vs 47 mm


def test_a_trajectory_with_an_arm_start_starts_the_arm_on_that_branch():
    """The home pose is the same tip pose either way; a trajectory's `arm_start` seeds the IK
    that solves it, so the arm starts on the branch the trajectory was planned on (here the
    elbow-out one a 0.25 m tool's line contact takes) instead of the scenario's posture."""
    scenario = with_tool_length(Scenario(), 0.25)
    X = home_tip_pose(scenario)
    p, q = X.translation(), X.rotation().ToQuaternion().wxyz()
    elbow_out = np.array([-0.15, -0.74, 1.28, 1.73, 2.3, -1.25, -1.02])
    plain = TipTrajectory([0.0], [p], [q])
    planned = TipTrajectory([0.0], [p], [q], elbow_out)
    q_seed = build_trajectory_diagram(scenario, plain).control.q0
    q_planned = build_trajectory_diagram(scenario, planned).control.q0
    assert np.abs(q_planned - elbow_out).max() < 0.3
    assert np.abs(q_seed - np.array(scenario.robot.posture_seed)).max() < 0.3
    assert np.abs(q_planned - q_seed).max() > 1.0
