"""Any task's policy deployed in a world: the task's one builder (its env class's `add_task`,
the builder its Gym env is made of) with a policy closed-loop inside the diagram, and runs of it.

```
plant ──state──► observation ──► PolicySystem ──action──► tip target ──► IK ──► plant
```

The Gym env exports the task's `action` input and `observation` output; `build_policy_diagram`
connects a loaded policy between them, as the env that trained it wired its task (the env
class's `add_task` with the policy's env kwargs). `run_controller` feeds a Python controller
(a scripted reference) on the same wiring through the `action` input instead. Both run through
the one rollout (`tasks.rollout.roll_out`), judged as the env judges its steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.visualization import (
    add_meshcat_visualizer,
    save_recording,
    start_meshcat,
)
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.camera import CLOSE_UP_CAMERA, add_scene_camera, scene_camera_view
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.systems.policy import PolicySystem
from drake_tooluse.tasks.contract import env_class
from drake_tooluse.tasks.rollout import Rollout, roll_out
from drake_tooluse.world.scenario import Scenario

MAX_STEPS = 100  # the push and pull envs' step limit: a deployed run's protocol


def step_limit(env_id: str) -> int:
    """The step limit `env_id` is registered with (its episodes' protocol, which a deployed
    run of its policy keeps); MAX_STEPS where it has none."""
    return gym.spec(env_id).max_episode_steps or MAX_STEPS


@dataclass
class PolicyDiagram:
    """A task's diagram with a loaded policy inside it (`build_policy_diagram`)."""

    diagram: object
    task: object  # the task's parts (`tasks.contract.GoalTaskParts`)
    policy_system: PolicySystem
    visualizer: object = None

    @property
    def world(self):
        return self.task.world

    @property
    def control(self):
        return self.task.control

    @property
    def observation(self):
        return self.task.observation


def _add_views(builder, task, scenario, meshcat, scene_camera):
    """A Meshcat visualizer (with `meshcat`) and the close-up scene camera exporting
    `color_image` (with `scene_camera`) added to `builder`; returns the visualizer or None."""
    visualizer = None
    if meshcat is not None:
        visualizer = add_meshcat_visualizer(builder, task.world.scene_graph, meshcat, scenario)
    if scene_camera:
        add_scene_camera(builder, task.world, **CLOSE_UP_CAMERA)
    return visualizer


def build_policy_diagram(
    scenario: Scenario,
    policy,
    belief: RobotBelief | None = None,
    meshcat=None,
    scene_camera: bool = False,
) -> PolicyDiagram:
    """World (truth) + a loaded policy (`learning.policy_dir.load_policy`) closed-loop through
    its task's wiring as its env wired it (its env class's `add_task` with the policy's env
    kwargs), on the robot model of `belief` (default: the scenario's tool, nominal grasp).
    With `scene_camera`, the diagram exports the `color_image` of a camera looking at the work
    area close up (`systems.camera.CLOSE_UP_CAMERA`). A policy whose observation or action
    does not fit its task's ports is a ValueError naming both."""
    env = env_class(policy.meta.env_id)
    kwargs = policy.meta.env_kwargs
    builder = DiagramBuilder()
    task = env.add_task(builder, scenario, belief, kwargs)
    action_input = task.control.target.GetInputPort("action")
    sizes = (task.observation_port.size(), action_input.size())
    wanted = (policy.meta.observation_shape[0], policy.meta.action_shape[0])
    if sizes != wanted:
        raise ValueError(
            f"the policy observes {wanted[0]} values and acts with {wanted[1]}; its task "
            f"({policy.meta.env_id}, env kwargs {kwargs}) gives {sizes[0]} and takes {sizes[1]}"
        )
    policy_system = builder.AddNamedSystem("policy", PolicySystem(policy))
    builder.Connect(task.observation_port, policy_system.get_input_port())
    builder.Connect(policy_system.get_output_port(), action_input)
    visualizer = _add_views(builder, task, scenario, meshcat, scene_camera)
    diagram = builder.Build()
    diagram.set_name("policy_control")
    return PolicyDiagram(diagram, task, policy_system, visualizer)


def _run(built: PolicyDiagram, max_steps: int, record: bool, on_step, act=None) -> Rollout:
    """The one rollout of a deployed diagram (`act` fed each step, or its policy inside), to
    its step limit; recorded where `record` and it has a visualizer."""
    task = built.task
    run = roll_out(
        built.diagram,
        task.world,
        task.control,
        task.outcome.reader,
        max_steps,
        act=act,
        visualizer=built.visualizer if record else None,
        on_step=on_step,
    )
    if run.final_image is not None:
        run.scene_view = scene_camera_view(built.diagram, task.world.plant)
    return run


def run_policy(
    built: PolicyDiagram, max_steps: int = MAX_STEPS, record: bool = False, on_step=None
) -> Rollout:
    """Runs the policy diagram from its default state for `max_steps`, judged where the object
    ends (the envs' protocol); recorded if `record` and the diagram has a visualizer. `on_step(step)` is called
    after each control step (progress displays)."""
    return _run(built, max_steps, record, on_step)


def _finish_recording(meshcat, visualizer, recording_path) -> None:
    if recording_path is not None:
        save_recording(meshcat, visualizer, recording_path)
    else:  # published in the live Meshcat, to play again there
        visualizer.StopRecording()
        visualizer.PublishRecording()


def _run_and_release(built: PolicyDiagram, meshcat, recording_path, max_steps, act, on_step):
    """Runs a deployed diagram (`run_policy`, or `act` fed each step), publishes or writes its
    recording where it has a visualizer, and releases the diagram."""
    try:
        run = _run(built, max_steps, True, on_step, act)
        if built.visualizer is not None:
            _finish_recording(meshcat, built.visualizer, recording_path)
        return run
    finally:
        release_diagram(built.diagram)  # its Python systems would keep it alive


def deploy(
    scenario: Scenario,
    policy,
    belief: RobotBelief | None = None,
    max_steps: int = MAX_STEPS,
    recording_path=None,
    meshcat=None,
    scene_camera: bool = False,
    on_step=None,
) -> Rollout:
    """A loaded policy of any task deployed in `scenario` (`build_policy_diagram`, `run_policy`).
    Recorded in `meshcat` (a new one where only `recording_path` is given) and, with
    `recording_path`, written there as a standalone HTML file."""
    if meshcat is None and recording_path is not None:
        meshcat = start_meshcat()
    built = build_policy_diagram(scenario, policy, belief, meshcat, scene_camera)
    return _run_and_release(built, meshcat, recording_path, max_steps, None, on_step)


def run_controller(
    env_id: str,
    scenario: Scenario,
    controller,
    belief: RobotBelief | None = None,
    max_steps: int = MAX_STEPS,
    recording_path=None,
    meshcat=None,
    scene_camera: bool = False,
    on_step=None,
    env_kwargs: dict | None = None,
) -> Rollout:
    """`controller` (observation → action, a scripted reference; its `reset()` is called first
    if it has one) driving `env_id`'s task in `scenario`, wired as that env with `env_kwargs`
    wires it, its action fed each step through the task's `action` input; recorded as
    `deploy` records."""
    if meshcat is None and recording_path is not None:
        meshcat = start_meshcat()
    builder = DiagramBuilder()
    task = env_class(env_id).add_task(builder, scenario, belief, env_kwargs or {})
    task.export(builder)
    visualizer = _add_views(builder, task, scenario, meshcat, scene_camera)
    built = PolicyDiagram(builder.Build(), task, None, visualizer)
    if hasattr(controller, "reset"):
        controller.reset()
    return _run_and_release(built, meshcat, recording_path, max_steps, controller, on_step)
