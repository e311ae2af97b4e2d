"""A tool-tip trajectory through the IK to the plant, open loop: the waypoint simulation; a
task replays it (the push task: `tasks.push.diagram.run_open_loop`).

```
TrajectorySource ──tip_pose_desired──► ToolTipIKSystem ──q*──► [q*, 0] ──► (delay) ──► plant (in-plant PD)
 (X_WT* over time)                     (robot model: believed tool)                      │
                                                                                          └──► SceneGraph ──► Meshcat
```
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.control import TipControl, add_trajectory_control, add_world_at_home
from drake_tooluse.builders.visualization import (
    add_meshcat_visualizer,
    save_recording,
    start_meshcat,
)
from drake_tooluse.robot.ik import rotation_angle_between
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.tip_trajectory import (
    TipTrajectory,
    tip_trajectory_source,
    waypoint_trajectory,
)
from drake_tooluse.systems.tool_tip_ik import ToolTipIKSystem
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import World, home_tip_pose

SETTLE_TIME = 1.0  # s after an open-loop trajectory ends


@dataclass
class TrajectoryDiagram:
    diagram: object
    world: World
    control: TipControl
    visualizer: object = None

    @property
    def ik_system(self) -> ToolTipIKSystem:
        return self.control.ik_system


def build_trajectory_diagram(
    scenario: Scenario,
    trajectory: TipTrajectory,
    belief: RobotBelief | None = None,
    meshcat=None,
    lead: float = 0.0,
) -> TrajectoryDiagram:
    """World (truth) + a TrajectorySource of `trajectory` (leading by `lead` s, see
    `tip_trajectory_source`) through the tool-tip IK on the robot model of `belief` (default:
    the scenario's true length, nominal grasp) and the joint command (with the scenario's
    actuation delay) to the plant; Meshcat if given, framed on the task
    (`visualization.show_task`). The arm starts at the scenario's home, solved from the
    trajectory's `arm_start` where it has one (the IK branch it was planned on)."""
    if trajectory.arm_start is not None:
        robot = replace(scenario.robot, posture_seed=trajectory.arm_start.tolist())
        scenario = replace(scenario, robot=robot)
    builder = DiagramBuilder()
    world, ik, q0 = add_world_at_home(builder, scenario, belief)
    source = builder.AddNamedSystem("tip_trajectory", tip_trajectory_source(trajectory, lead))
    control = add_trajectory_control(builder, world, ik, q0, source)
    visualizer = None
    if meshcat is not None:
        visualizer = add_meshcat_visualizer(builder, world.scene_graph, meshcat, scenario)
    diagram = builder.Build()
    diagram.set_name("trajectory_control")
    return TrajectoryDiagram(diagram, world, control, visualizer)


@dataclass
class WaypointResult:
    target: np.ndarray  # [x y z] m
    reached: np.ndarray  # true tip position at the end of the dwell, m
    position_error: float  # m
    orientation_error: float  # rad
    ik_success: bool

    def as_dict(self) -> dict:
        return {
            "target_m": self.target.tolist(),
            "reached_m": self.reached.tolist(),
            "position_error_m": self.position_error,
            "orientation_error_rad": self.orientation_error,
            "ik_success": self.ik_success,
        }


@dataclass
class WaypointRun:
    results: list[WaypointResult] = field(default_factory=list)
    sim_time: float = 0.0
    recording: Path | None = None


def simulate_waypoints(
    scenario: Scenario,
    waypoints,
    *,
    move_time: float = 1.0,
    dwell: float = 1.5,
    belief: RobotBelief | None = None,
    record: str | Path | None = None,
    meshcat=None,
) -> WaypointRun:
    """Moves the tool tip from home through `waypoints` (RigidTransforms X_WT*) in the dynamic
    simulation, the robot believing `belief` (default: the true length, nominal grasp), and
    measures the true tip's error at the end of each dwell. With `record`, a Meshcat
    recording is written there (standalone HTML). With `meshcat`, the run is shown in it, then
    its recording published there to play again."""
    trajectory = waypoint_trajectory(home_tip_pose(scenario), waypoints, move_time, dwell)
    live = meshcat is not None  # the caller's Meshcat is watched: it draws while recording
    if meshcat is None and record is not None:
        meshcat = start_meshcat()
    built = build_trajectory_diagram(scenario, trajectory, belief, meshcat)
    simulator = Simulator(built.diagram)
    root = simulator.get_mutable_context()
    built.control.reset(root)
    if built.visualizer is not None:
        built.visualizer.StartRecording(live)
    simulator.Initialize()
    plant_context = built.world.plant.GetMyContextFromRoot(root)
    ik_context = built.ik_system.GetMyContextFromRoot(root)
    run = WaypointRun()
    t = 0.0
    for X in waypoints:
        t += move_time + dwell
        simulator.AdvanceTo(t)
        X_true = built.world.tip_frame.CalcPoseInWorld(plant_context)
        status = built.ik_system.GetOutputPort("status").Eval(ik_context)
        run.results.append(
            WaypointResult(
                target=X.translation().copy(),
                reached=X_true.translation().copy(),
                position_error=float(np.linalg.norm(X_true.translation() - X.translation())),
                orientation_error=rotation_angle_between(X_true.rotation(), X.rotation()),
                ik_success=bool(status[0] > 0.5),
            )
        )
    run.sim_time = t
    if record is not None:
        run.recording = save_recording(meshcat, built.visualizer, record)
    elif built.visualizer is not None:
        built.visualizer.StopRecording()
        built.visualizer.PublishRecording()
    return run
