"""The push task wired into a diagram: world at home → tool-tip control → observation →
outcome; and the push's runs of a diagram that drives the tip another way (a tip trajectory
replayed open loop).

`add_push_task` is the one wiring of the task; the Gymnasium env (`tasks.push.env`) exports its
`action` input and `observation` output, `tasks.deploy.build_policy_diagram` connects a policy
between them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from drake_tooluse.builders.control import (
    TipControl,
    add_tip_control,
    add_world_at_home,
    nominal_belief,
)
from drake_tooluse.builders.trajectory_diagram import SETTLE_TIME, build_trajectory_diagram
from drake_tooluse.robot.model import TIP_FRAME, RobotBelief
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.tasks.contract import GoalTaskParts
from drake_tooluse.tasks.push.metrics import PushMetricsReader, PushOutcome
from drake_tooluse.tasks.push.observation import ToolPushObservation
from drake_tooluse.tasks.rollout import Rollout, roll_out
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
    visuals: bool = True,
    frame: str = TIP_FRAME,
) -> PushTask:
    """The world at the home pose the robot computes for `belief` (default: `nominal_belief`),
    tool-tip control (`action_mode`), the task's observation of the world and its outcome
    (metrics, the reward of `reward_type`, success), the goal the scenario's. The tip target's
    `action` input is left unconnected. `visuals`: as `world.scene.add_world`'s;
    `frame`: the believed tool's frame the IK places (the tip of the control and the
    observation)."""
    belief = nominal_belief(scenario) if belief is None else belief
    if frame not in belief.tool.frame_names():
        raise ValueError(
            f"working frame {frame!r} is not a frame of the tool the robot holds "
            f"({', '.join(belief.tool.frame_names())})"
        )
    world, ik, q0 = add_world_at_home(builder, scenario, belief, frame, visuals=visuals)
    control = add_tip_control(builder, world, ik, q0, action_mode)
    goal = goal_position(scenario)
    return PushTask.wire(
        builder,
        world,
        ik,
        control,
        ToolPushObservation(
            world,
            ik.plant,
            goal,
            include_tool_length,
            belief.tool_length,
            observation_mode,
            belief.tool,
            frame,
        ),
        PushOutcome(world, goal, initial_box_pose(scenario).translation(), reward_type),
    )


def run_push(
    diagram,
    world: World,
    control: TipControl,
    max_steps: int,
    visualizer=None,
    on_step=None,
) -> Rollout:
    """Simulates a push diagram from its default state one control period at a time for
    `max_steps`: the task's one deployed rollout (`tasks.rollout.roll_out`), judged as its env
    judges. With a `visualizer`, the run is recorded. `on_step(step)` is called after
    each control step (progress displays). A simulation failure (Drake raises, the state is no
    longer finite, or the box flies off) ends the run flagged `sim_error`, with the figures of
    the last sound state."""
    return roll_out(
        diagram,
        world,
        control,
        PushMetricsReader(world),
        max_steps,
        visualizer=visualizer,
        on_step=on_step,
    )


def run_open_loop(scenario: Scenario, trajectory: TipTrajectory, belief: RobotBelief) -> Rollout:
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
        )
    finally:
        release_diagram(built.diagram)  # its Python systems would keep it alive
