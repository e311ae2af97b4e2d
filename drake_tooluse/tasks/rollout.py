"""One deployed rollout for every task: a task's diagram (its world, its control, a policy
inside it or an action input fed each step) simulated one control period at a time and judged
after each as the task's Gym env judges its steps.

Both advance to exactly k · period (k counted in integers, docs/CLOCK.md), end an episode as a
simulation failure where Drake raises, the state is no longer finite or the object flew off
(`builders.failures`), read the task's metrics from the plant with the task's reader, and
report the physical-sanity flags of every step (`tasks.sanity`). `tests/test_one_rollout.py`
holds the two to the same trajectory, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydrake.systems.analysis import Simulator

from drake_tooluse.builders.failures import advance, finite_state_vector, object_diverged
from drake_tooluse.tasks.sanity import PhysicalSanityReader, past_limits
from drake_tooluse.world.scene import goal_position, initial_box_pose


def step_info(metrics, episode: dict, ik_ok: bool, sim_error: bool, sanity: dict) -> dict:
    """What every task's env step puts in `info`, its task's own figures aside: success, the
    touches now and so far in the episode (`episode`'s "tool_touched", "gripper_touched"),
    the IK's and the simulation's state, and the physical sanity of the last finite state
    (`tasks.sanity`: figures and flags)."""
    return {
        "is_success": bool(metrics.is_success),
        "tool_touches_object": metrics.tool_touches_object,
        "gripper_touches_object": metrics.gripper_touches_object,
        "tool_touched_object_in_episode": episode["tool_touched"],
        "gripper_touched_object_in_episode": episode["gripper_touched"],
        "ik_ok": ik_ok and not sim_error,
        "sim_error": sim_error,
        **sanity,
        **past_limits(sanity),
    }


@dataclass
class Rollout:
    """What happened in one deployed episode of any task, from the world's truth."""

    steps: int  # control steps simulated (the failed one included)
    metrics: object  # the task's metrics of the last sound state
    tool_path: np.ndarray  # (steps + 1, 3) the true tool point (the world's tip frame), W, m
    object_path: np.ndarray  # (steps + 1, 3) the object's centre, W, m
    tool_touched: bool = False
    gripper_touched: bool = False
    error: str | None = None  # the simulation failed at `steps` (the figures: the last sound)
    first_success_step: int | None = None  # the first step the task succeeded (None: never)
    flagged: set = field(default_factory=set)  # the physical-sanity flags of any step
    final_image: np.ndarray | None = None  # the scene camera's RGBA at the end, if any
    scene_view: object = None  # that camera (`systems.camera.SceneView`), to draw on its image

    @property
    def success(self) -> bool:
        """The task succeeded where the episode ended (and the simulation did not fail)."""
        return bool(self.metrics.is_success) and self.error is None

    @property
    def sim_error(self) -> bool:
        return self.error is not None

    @property
    def final_object_to_goal(self) -> float:
        """m, the object from its goal where the episode ended."""
        return float(self.metrics.object_to_goal)

    @property
    def object_travel(self) -> float:
        """m, the object from its start where the episode ended."""
        return float(self.metrics.object_travel)

    def as_dict(self) -> dict:
        return {
            "steps": self.steps,
            "success": self.success,
            "first_success_step": self.first_success_step,
            "final_object_to_goal_m": self.final_object_to_goal,
            "object_travel_m": self.object_travel,
            "tool_touched": bool(self.tool_touched),
            "gripper_touched": bool(self.gripper_touched),
            "sim_error": self.sim_error,
            **({"error": self.error} if self.error else {}),
        }


def roll_out(
    diagram,
    world,
    control,
    reader,
    max_steps: int,
    act=None,
    visualizer=None,
    on_step=None,
) -> Rollout:
    """Simulates `diagram` (holding `world` and its `control`) from its default state for
    `max_steps` control periods (the envs' protocol: judged where the object ends). With
    `act` (observation → action), each step's action is `act` of the diagram's `observation`
    output, fixed on its `action` input; without, the diagram holds its policy. `reader` reads
    the task's metrics (`read(plant_context, goal, start)`) against the world scenario's goal
    and the object's start. Recorded with `visualizer`;
    `on_step(step)` is called after each step."""
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    control.reset(root)
    if visualizer is not None:
        visualizer.StartRecording(False)
    simulator.Initialize()
    plant_context = world.plant.GetMyContextFromRoot(root)
    sanity = PhysicalSanityReader(world)
    period = world.scenario.control.control_period
    goal = goal_position(world.scenario)
    start = initial_box_pose(world.scenario).translation()
    if act is not None:
        action_port = diagram.GetInputPort("action")
        observation_port = diagram.GetOutputPort("observation")
    metrics = reader.read(plant_context, goal, start)

    def positions():
        return (
            world.tip_frame.CalcPoseInWorld(plant_context).translation(),
            world.box.EvalPoseInWorld(plant_context).translation(),
        )

    tool, thing = positions()
    run = Rollout(0, metrics, None, None)
    tools, objects = [tool], [thing]
    for step in range(1, max_steps + 1):
        if act is not None:
            observation = np.asarray(observation_port.Eval(root), float)
            action_port.FixValue(root, np.asarray(act(observation), float))
        failure = advance(simulator, step * period)
        x = None if failure is not None else finite_state_vector(world.plant, plant_context)
        if failure is None and x is None:
            failure = "the state is no longer finite"
        if failure is None:
            moved_tool, moved = positions()
            failure = object_diverged(thing.tolist(), moved.tolist(), period, step)
        run.steps = step
        if failure is not None:  # the figures stay the last sound state's
            run.error = f"simulation failed at step {step}: {failure}"
            tools.append(tool)
            objects.append(thing)
            break
        tool, thing = moved_tool, moved
        tools.append(tool)
        objects.append(thing)
        run.metrics = metrics = reader.read(plant_context, goal, start)
        run.tool_touched |= metrics.tool_touches_object
        run.gripper_touched |= metrics.gripper_touches_object
        flags = past_limits(sanity.read(plant_context, x))
        run.flagged |= {flag for flag, on in flags.items() if on}
        if on_step is not None:
            on_step(step)
        if metrics.is_success and run.first_success_step is None:
            run.first_success_step = step
    run.tool_path, run.object_path = np.array(tools), np.array(objects)
    if diagram.HasOutputPort("color_image") and run.error is None:
        run.final_image = diagram.GetOutputPort("color_image").Eval(root).data.copy()
    return run
