"""One closed-loop pull: a controller (an observation → action callable, a learned policy or
`scripted.ScriptedPull`) drives the hook corner in the pull task's diagram, built on any
scenario (nominal or perturbed) and any belief of the hook (the truth, or what the camera
measured), for a number of control steps; judged where the cube ends (the env's protocol).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.control import BEHAVIOUR_V1, ControlBehaviour
from drake_tooluse.builders.failures import advance, finite_state_vector
from drake_tooluse.builders.visualization import add_meshcat_visualizer, save_recording
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.camera import CLOSE_UP_CAMERA, add_scene_camera, scene_camera_view
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.tasks.pull.diagram import add_pull_task
from drake_tooluse.tasks.pull.metrics import PullMetricsReader
from drake_tooluse.tasks.pull.registration import MAX_EPISODE_STEPS
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
        simulator = Simulator(diagram)
        root = simulator.get_mutable_context()
        task.control.reset(root)
        if visualizer is not None:
            visualizer.StartRecording(False)
        simulator.Initialize()
        if hasattr(controller, "reset"):
            controller.reset()
        plant_context = task.world.plant.GetMyContextFromRoot(root)
        reader = PullMetricsReader(task.world)
        goal = goal_position(scenario)
        start = initial_box_pose(scenario).translation()
        action_port = diagram.GetInputPort("action")
        observation_port = diagram.GetOutputPort("observation")
        period = scenario.control.control_period
        metrics = reader.read(plant_context, goal, start)
        step, error, first = 0, None, None
        for step in range(1, max_steps + 1):
            observation = np.asarray(observation_port.Eval(root), float)
            action_port.FixValue(root, np.asarray(controller(observation), float))
            failure = advance(simulator, step * period)
            if failure is not None:
                error = f"simulation failed at step {step}: {failure}"
                break
            if finite_state_vector(task.world.plant, plant_context) is None:
                error = f"the state is no longer finite at step {step}"
                break
            metrics = reader.read(plant_context, goal, start)
            if first is None and metrics.is_success:
                first = step
        if visualizer is not None:
            if recording_path is not None:
                save_recording(meshcat, visualizer, recording_path)
            else:
                visualizer.StopRecording()
                visualizer.PublishRecording()
        image = view = None
        if diagram.HasOutputPort("color_image") and error is None:
            image = diagram.GetOutputPort("color_image").Eval(root).data.copy()
            view = scene_camera_view(diagram, task.world.plant)
        return PullRun(
            step,
            bool(metrics.is_success) and error is None,
            float(metrics.object_to_goal),
            float(metrics.object_travel),
            sim_error=error is not None,
            error=error,
            first_success_step=first,
            final_image=image,
            scene_view=view,
        )
    finally:
        release_diagram(diagram)  # its Python systems would keep it alive
