"""One closed-loop pull: a controller (an observation → action callable, a learned policy or
`scripted.ScriptedPull`) drives the hook corner in the pull task's diagram, built on any
scenario (nominal or perturbed) and any belief of the hook (the truth, or what the camera
measured), for a number of control steps; judged where the cube ends (the env's protocol).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.control import BEHAVIOUR_V1, ControlBehaviour
from drake_tooluse.builders.visualization import (
    add_meshcat_visualizer,
    save_recording,
    start_meshcat,
)
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.camera import CLOSE_UP_CAMERA, add_scene_camera, scene_camera_view
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.tasks.contract import env_class
from drake_tooluse.tasks.pull.diagram import add_pull_task
from drake_tooluse.tasks.pull.metrics import PullMetricsReader
from drake_tooluse.tasks.pull.registration import MAX_EPISODE_STEPS
from drake_tooluse.tasks.rollout import roll_out
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import goal_position, initial_box_pose


@dataclass
class PullRun:
    """What happened in one pull, from the world's truth."""

    steps: int  # control steps simulated
    success: bool  # the cube ended at the goal, moved (`metrics.is_success`)
    final_object_to_goal: float  # m
    object_travel: float  # m, horizontal
    sim_error: bool = False
    error: str | None = None
    first_success_step: int | None = None  # the first step the cube was at the goal
    final_image: np.ndarray | None = None  # the scene camera's RGBA at the end, if asked for
    scene_view: object = None  # that camera (`systems.camera.SceneView`), to draw on its image
    tool_path: np.ndarray | None = None  # (steps + 1, 3) the true tool's tip frame, W, m
    object_path: np.ndarray | None = None  # (steps + 1, 3) the cube's centre, W, m
    flagged: set = field(default_factory=set)  # the physical-sanity flags of any step

    def as_dict(self) -> dict:
        return {
            "steps": self.steps,
            "success": self.success,
            "final_object_to_goal_m": self.final_object_to_goal,
            "object_travel_m": self.object_travel,
            "sim_error": self.sim_error,
            "first_success_step": self.first_success_step,
            **({"error": self.error} if self.error else {}),
        }


def run_pull(
    scenario: Scenario,
    controller,
    belief: RobotBelief | None = None,
    max_steps: int = MAX_EPISODE_STEPS,
    meshcat=None,
    recording_path=None,
    scene_camera: bool = False,
    behaviour: ControlBehaviour = BEHAVIOUR_V1,
) -> PullRun:
    """Runs `controller` (called with each observation, giving a 3-d action in [-1, 1]; its
    `reset()` is called first if it has one) on the scenario's world from its default state,
    the robot's IK holding `belief` (default: the scenario's hook). A simulation failure ends
    the run flagged `sim_error`, judged at the last finite state. With `meshcat`, the run is
    recorded there and, with `recording_path`, written as a standalone HTML file. With `scene_camera`, the run keeps the scene camera's
    image at the end (`final_image`, unless the simulation failed). `behaviour`: how the
    action reaches the joints (a policy's: its env's `control_behaviour`)."""
    builder = DiagramBuilder()
    task = add_pull_task(builder, scenario, belief, behaviour)
    task.export(builder)
    visualizer = None
    if meshcat is not None:
        visualizer = add_meshcat_visualizer(builder, task.world.scene_graph, meshcat, scenario)
    if scene_camera:
        add_scene_camera(builder, task.world, **CLOSE_UP_CAMERA)
    diagram = builder.Build()
    try:
        if hasattr(controller, "reset"):
            controller.reset()
        run = roll_out(
            diagram,
            task.world,
            task.control,
            PullMetricsReader(task.world),
            goal_position(scenario),
            initial_box_pose(scenario).translation(),
            max_steps,
            act=controller,
            visualizer=visualizer,
        )
        if visualizer is not None:
            if recording_path is not None:
                save_recording(meshcat, visualizer, recording_path)
            else:
                visualizer.StopRecording()
                visualizer.PublishRecording()
        view = None
        if run.final_image is not None:
            view = scene_camera_view(diagram, task.world.plant)
        return PullRun(
            run.steps,
            run.success,
            float(run.metrics.object_to_goal),
            float(run.metrics.object_travel),
            sim_error=run.error is not None,
            error=run.error,
            first_success_step=run.first_success_step,
            final_image=run.final_image,
            scene_view=view,
            tool_path=run.tool_path,
            object_path=run.object_path,
            flagged=run.flagged,
        )
    finally:
        release_diagram(diagram)  # its Python systems would keep it alive


def run_deployed(
    scenario: Scenario,
    policy,
    belief: RobotBelief | None = None,
    recording_path=None,
    max_steps: int = MAX_EPISODE_STEPS,
) -> PullRun:
    """A loaded policy deployed in `scenario` (`run_pull`), its action reaching the joints as
    in the env it learned in; with `recording_path`, recorded in a new Meshcat and written
    there as a standalone HTML file."""
    behaviour = env_class(policy.meta.env_id).control_behaviour(policy.meta.env_kwargs)
    meshcat = None if recording_path is None else start_meshcat()
    return run_pull(
        scenario,
        policy.act,
        belief,
        max_steps,
        meshcat=meshcat,
        recording_path=recording_path,
        behaviour=behaviour,
    )
