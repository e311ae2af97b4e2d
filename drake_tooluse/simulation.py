"""The tool-tip control diagram: world + tool-tip IK system + a trajectory source, simulated.

```
TrajectorySource ──tip_pose_desired──► ToolTipIKSystem ──desired_state──► plant (in-plant PD)
 (X_WT* waypoints)                     (robot model: believed length)      │
                                                                            └──► SceneGraph ──► Meshcat
```
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_tooluse.control import add_world_at_home
from drake_tooluse.ik import ToolTipIKSystem, pose_to_vector, rotation_angle_between
from drake_tooluse.scenario import Scenario, check_tool_length, tool_length_or_none
from drake_tooluse.scene import World, home_tip_pose
from drake_tooluse.validation import check_in_range


def tip_pose_trajectory(start: RigidTransform, waypoints, move_time: float,
                        dwell: float) -> PiecewisePolynomial:
    """[p_WT, quaternion wxyz] over time: from `start`, move to each waypoint in `move_time` s
    (linear in position and quaternion components; the IK normalizes) and hold it `dwell` s."""
    times, values = [0.0], [pose_to_vector(start)]
    t = 0.0
    for X in waypoints:
        v = pose_to_vector(X)
        if np.dot(v[3:], values[-1][3:]) < 0:  # the shorter way round
            v[3:] = -v[3:]
        t += move_time
        times.append(t)
        values.append(v)
        if dwell > 0:
            t += dwell
            times.append(t)
            values.append(v)
    return PiecewisePolynomial.FirstOrderHold(times, np.array(values).T)


@dataclass
class TipControlDiagram:
    diagram: object
    world: World
    ik_system: ToolTipIKSystem
    q0: np.ndarray
    visualizer: object = None


def build_tip_control_diagram(scenario: Scenario, trajectory: PiecewisePolynomial,
                              believed_tool_length: float | None = None,
                              meshcat=None, believed_grasp=(0.0, 0.0)) -> TipControlDiagram:
    """World (true tool) + IK system (robot model with `believed_tool_length`, default the true
    length, held at `believed_grasp` (across, along) m) + a TrajectorySource of desired tip
    poses; Meshcat if given."""
    from drake_tooluse.viz import add_meshcat_visualizer

    believed = tool_length_or_none(scenario) if believed_tool_length is None else (
        check_tool_length(believed_tool_length, "believed tool length"))
    builder = DiagramBuilder()
    world, ik, q0 = add_world_at_home(builder, scenario, believed, ik_attempts=16,
                                      believed_grasp=believed_grasp)
    ik_system = builder.AddNamedSystem(
        "tool_tip_ik", ToolTipIKSystem(ik, q0, scenario.control.control_period))
    source = builder.AddNamedSystem("tip_trajectory", TrajectorySource(trajectory))
    builder.Connect(source.get_output_port(), ik_system.GetInputPort("tip_pose_desired"))
    builder.Connect(ik_system.GetOutputPort("desired_state"),
                    world.plant.get_desired_state_input_port(world.baxter))
    visualizer = None
    if meshcat is not None:
        visualizer = add_meshcat_visualizer(builder, world.scene_graph, meshcat)
    diagram = builder.Build()
    diagram.set_name("tip_control")
    return TipControlDiagram(diagram, world, ik_system, q0, visualizer)


@dataclass
class WaypointResult:
    target: np.ndarray  # [x y z] m
    reached: np.ndarray  # true tip position at the end of the dwell, m
    position_error: float  # m
    orientation_error: float  # rad
    ik_success: bool

    def as_dict(self) -> dict:
        return {"target_m": self.target.tolist(), "reached_m": self.reached.tolist(),
                "position_error_m": self.position_error,
                "orientation_error_rad": self.orientation_error, "ik_success": self.ik_success}


@dataclass
class WaypointRun:
    results: list[WaypointResult] = field(default_factory=list)
    sim_time: float = 0.0
    recording: Path | None = None


def simulate_waypoints(scenario: Scenario, waypoints, *, move_time: float = 1.0,
                       dwell: float = 1.5, believed_tool_length: float | None = None,
                       record: str | Path | None = None,
                       believed_grasp=(0.0, 0.0)) -> WaypointRun:
    """Moves the tool tip through `waypoints` (RigidTransforms X_WT*) in the dynamic
    simulation and measures the true tip's error at the end of each dwell."""
    from drake_tooluse.viz import save_recording, start_meshcat

    if not waypoints:
        raise ValueError("waypoints is empty; give at least one tool-tip pose")
    move_time = check_in_range(move_time, 0.05, 60.0, "move_time", unit="s")
    dwell = check_in_range(dwell, 0.0, 60.0, "dwell", unit="s")
    meshcat = start_meshcat() if record is not None else None
    traj = tip_pose_trajectory(home_tip_pose(scenario), waypoints, move_time, dwell)
    built = build_tip_control_diagram(scenario, traj, believed_tool_length, meshcat,
                                      believed_grasp)
    simulator = Simulator(built.diagram)
    if built.visualizer is not None:
        built.visualizer.StartRecording(False)
    simulator.Initialize()
    plant = built.world.plant
    plant_context = plant.GetMyContextFromRoot(simulator.get_context())
    ik_context = built.ik_system.GetMyContextFromRoot(simulator.get_context())
    run = WaypointRun()
    t = 0.0
    for X in waypoints:
        t += move_time + dwell
        simulator.AdvanceTo(t)
        X_true = built.world.tip_frame.CalcPoseInWorld(plant_context)
        status = built.ik_system.GetOutputPort("status").Eval(ik_context)
        run.results.append(WaypointResult(
            target=X.translation().copy(), reached=X_true.translation().copy(),
            position_error=float(np.linalg.norm(X_true.translation() - X.translation())),
            orientation_error=rotation_angle_between(X_true.rotation(), X.rotation()),
            ik_success=bool(status[0] > 0.5)))
    run.sim_time = t
    if record is not None:
        run.recording = save_recording(meshcat, built.visualizer, record)
    return run
