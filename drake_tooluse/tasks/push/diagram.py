"""The push task wired into a diagram: world at home → tool-tip control → observation; with a
trained policy closed-loop inside the diagram (not through the Gym wrapper), and runs of it.

```
plant ──state──► ToolPushObservation ──► PolicySystem ──action──► TipTargetSystem ──► IK ──► plant
```

`add_push_task` is the one wiring of the task; the Gymnasium env (`tasks.push.env`) exports its
`action` input and `observation` output, `build_policy_diagram` connects a policy between them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.control import (
    BEHAVIOUR_V1,
    ControlBehaviour,
    TipControl,
    add_tip_control,
    add_world_at_home,
    nominal_belief,
)
from drake_tooluse.builders.trajectory_diagram import SETTLE_TIME, build_trajectory_diagram
from drake_tooluse.builders.visualization import (
    add_meshcat_visualizer,
    save_recording,
    start_meshcat,
)
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.camera import CLOSE_UP_CAMERA, add_scene_camera
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.systems.policy import PolicySystem
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.tasks.contract import GoalTaskParts, env_class
from drake_tooluse.tasks.push.metrics import PushMetricsReader, PushOutcome
from drake_tooluse.tasks.push.observation import OBSERVATION_SIZES, ToolPushObservation
from drake_tooluse.tasks.push.registration import MAX_EPISODE_STEPS
from drake_tooluse.tasks.rollout import roll_out
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import World, goal_position, initial_box_pose


@dataclass
class PushTask(GoalTaskParts):
    """The parts `add_push_task` added: the contract's, and the two systems that hold the
    episode's goal and the box's start (`observation`, `outcome`: `set_episode` sets both)."""

    observation: ToolPushObservation = None
    outcome: PushOutcome = None


def add_push_task(
    builder,
    scenario: Scenario,
    belief: RobotBelief | None,
    action_mode: str,
    observation_mode: str,
    include_tool_length: bool,
    reward_type: str = "tool_and_box",
    behaviour: ControlBehaviour = BEHAVIOUR_V1,
) -> PushTask:
    """The world at the home pose the robot computes for `belief` (default: `nominal_belief`),
    tool-tip control (`action_mode`), the task's observation of the world and its outcome
    (metrics, the reward of `reward_type`, success), the goal the scenario's. The tip target's
    `action` input is left unconnected. `behaviour`: how the action reaches the joints
    (`ControlBehaviour`; default the `-v1` envs')."""
    belief = nominal_belief(scenario) if belief is None else belief
    world, ik, q0 = add_world_at_home(builder, scenario, belief)
    control = add_tip_control(
        builder,
        world,
        ik,
        q0,
        action_mode,
        behaviour=behaviour,
    )
    goal = goal_position(scenario)
    return PushTask.wire(
        builder,
        world,
        ik,
        control,
        ToolPushObservation(
            world, ik.plant, goal, include_tool_length, belief.tool_length, observation_mode
        ),
        PushOutcome(world, goal, initial_box_pose(scenario).translation(), reward_type),
    )


@dataclass
class PolicyDiagram:
    diagram: object
    world: World
    control: TipControl
    observation: ToolPushObservation
    policy_system: PolicySystem
    visualizer: object = None
    # The policy's env ends its episodes at success (the -v0 ids' `end_at_success`): its runs
    # end there too; else they run to their step limit.
    end_at_success: bool = False


def policy_observation(policy) -> tuple[str, bool]:
    """(observation_mode, include_tool_length) of a loaded policy, from its metadata and its
    observation size; an observation the push task cannot give is an error."""
    n_obs = policy.meta.observation_shape[0]
    mode = policy.meta.env_kwargs.get("observation_mode", "gripper_joints")
    size = OBSERVATION_SIZES.get(mode)
    if size is None or n_obs not in (size, size + 1):
        raise ValueError(
            f"the policy observes {n_obs} values with observation_mode={mode!r}; "
            f"the push task gives {OBSERVATION_SIZES} (one more with the tool "
            "length)"
        )
    return mode, n_obs == size + 1


def build_policy_diagram(
    scenario: Scenario,
    policy,
    belief: RobotBelief | None = None,
    meshcat=None,
    scene_camera: bool = False,
) -> PolicyDiagram:
    """World (truth) + a loaded policy (`learning.policy_dir.load_policy`) closed-loop through
    tool-tip control on the robot model of `belief` (default: the scenario's true length,
    nominal grasp). With `scene_camera`, the diagram exports the `color_image` of a camera
    looking at the work area close up (`systems.camera.CLOSE_UP_CAMERA`)."""
    mode, include_length = policy_observation(policy)
    action_mode = policy.meta.env_kwargs.get("action_mode", "position_quaternion")
    builder = DiagramBuilder()
    env = env_class(policy.meta.env_id)  # the control it learned with, as its env built it
    kwargs = policy.meta.env_kwargs
    task = add_push_task(
        builder,
        scenario,
        belief,
        action_mode,
        mode,
        include_length,
        behaviour=env.control_behaviour(kwargs),
    )
    action_input = task.control.target.GetInputPort("action")
    if action_input.size() != policy.meta.action_shape[0]:
        raise ValueError(
            f"the policy's actions {policy.meta.action_shape} do not fit the "
            f"action mode {action_mode!r}"
        )
    policy_system = builder.AddNamedSystem("policy", PolicySystem(policy))
    builder.Connect(task.observation.get_output_port(), policy_system.get_input_port())
    builder.Connect(policy_system.get_output_port(), action_input)
    visualizer = None
    if meshcat is not None:
        visualizer = add_meshcat_visualizer(builder, task.world.scene_graph, meshcat, scenario)
    if scene_camera:
        add_scene_camera(builder, task.world, **CLOSE_UP_CAMERA)
    diagram = builder.Build()
    diagram.set_name("policy_control")
    return PolicyDiagram(
        diagram,
        task.world,
        task.control,
        task.observation,
        policy_system,
        visualizer,
        end_at_success=env.ends_at_success(kwargs),
    )


@dataclass
class PushRun:
    """What happened in one push, from the world's truth."""

    steps: int  # control steps simulated
    success: bool  # the box ended at the goal (within the env's threshold)
    final_object_to_goal: float  # m
    object_travel: float  # m, from its start to where it ended
    tool_touched: bool
    gripper_touched: bool
    tip_path: np.ndarray  # (steps + 1, 3) true tool-tip positions at each control step
    object_path: np.ndarray  # (steps + 1, 3) box centre
    final_image: np.ndarray | None = None  # RGBA at the end, if the diagram has a scene camera
    # The simulation failed (a RuntimeError from Drake, or a non-finite state) at `steps`; the
    # figures are those of the last finite state.
    sim_error: bool = False
    error: str | None = None
    # The control step the box first reached the goal (None: never): with `success` at the
    # end, the push arrived then and held the box there.
    first_success_step: int | None = None
    flagged: set = field(default_factory=set)  # the physical-sanity flags of any step

    def as_dict(self) -> dict:
        return {
            "steps": self.steps,
            "success": self.success,
            "first_success_step": self.first_success_step,
            "final_object_to_goal_m": self.final_object_to_goal,
            "object_travel_m": self.object_travel,
            "tool_touched": self.tool_touched,
            "gripper_touched": self.gripper_touched,
            "sim_error": self.sim_error,
            **({"error": self.error} if self.error else {}),
        }


def run_push(
    diagram,
    world: World,
    control: TipControl,
    max_steps: int,
    stop_at_success: bool = True,
    visualizer=None,
    on_step=None,
) -> PushRun:
    """Simulates a push diagram from its default state one control period at a time, for
    `max_steps` or until the box reaches the goal (as the env terminates) if
    `stop_at_success`: the task's one deployed rollout (`tasks.rollout.roll_out`), judged as
    its env judges. With a `visualizer`, the run is recorded. `on_step(step)` is called after
    each control step (progress displays). A simulation failure (Drake raises, the state is no
    longer finite, or the box flies off) ends the run flagged `sim_error`, with the figures of
    the last sound state."""
    s = world.scenario
    run = roll_out(
        diagram,
        world,
        control,
        PushMetricsReader(world),
        goal_position(s),
        initial_box_pose(s).translation(),
        max_steps,
        stop_at_success=stop_at_success,
        visualizer=visualizer,
        on_step=on_step,
    )
    m = run.metrics
    return PushRun(
        run.steps,
        run.success,
        float(m.object_to_goal),
        float(m.object_travel),
        bool(run.tool_touched),
        bool(run.gripper_touched),
        run.tool_path,
        run.object_path,
        run.final_image,
        sim_error=run.error is not None,
        error=run.error,
        first_success_step=run.first_success_step,
        flagged=run.flagged,
    )


def run_policy(
    built: PolicyDiagram, max_steps: int = 100, record: bool = False, on_step=None
) -> PushRun:
    """Runs the policy diagram from its default state for `max_steps`, judged where the box
    ends (the envs' protocol), or until its first success for a policy trained with the early
    end (`end_at_success` in its env kwargs); recorded if `record` and the diagram has a
    visualizer."""
    return run_push(
        built.diagram,
        built.world,
        built.control,
        max_steps,
        stop_at_success=built.end_at_success,
        visualizer=built.visualizer if record else None,
        on_step=on_step,
    )


def run_deployed(
    scenario: Scenario,
    policy,
    belief: RobotBelief | None = None,
    recording_path=None,
    max_steps: int = MAX_EPISODE_STEPS,
) -> PushRun:
    """A loaded policy deployed in `scenario`: inside the task's diagram (`build_policy_diagram`)
    for `max_steps` (the env's protocol); with `recording_path`, recorded in a new Meshcat and
    written there as a standalone HTML file."""
    meshcat = None if recording_path is None else start_meshcat()
    built = build_policy_diagram(scenario, policy, belief, meshcat=meshcat)
    try:
        push = run_policy(built, max_steps=max_steps, record=meshcat is not None)
        if meshcat is not None:
            save_recording(meshcat, built.visualizer, recording_path)
        return push
    finally:
        release_diagram(built.diagram)  # its Python systems would keep it alive


def run_open_loop(scenario: Scenario, trajectory: TipTrajectory, belief: RobotBelief) -> PushRun:
    """Replays the whole trajectory, a control period ahead (it holds where the tip was at each
    step), then lets the world settle for SETTLE_TIME."""
    period = scenario.control.control_period
    built = build_trajectory_diagram(scenario, trajectory, belief, lead=period)
    duration = max(trajectory.times[-1], 0.0) + SETTLE_TIME
    try:
        return run_push(
            built.diagram,
            built.world,
            built.control,
            math.ceil(duration / period),
            stop_at_success=False,
        )
    finally:
        release_diagram(built.diagram)  # its Python systems would keep it alive
