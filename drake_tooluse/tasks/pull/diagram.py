"""The pull task wired into a diagram: the world at home → the hook corner's position control →
observation and outcome.

```
action ──► TipTargetSystem ──X_WC*──► ToolTipIKSystem ──q*──► plant ──state──► ToolPullObservation
           (hook-corner space)        (frame hook_corner)            └──poses──► PullOutcome
```

`add_pull_task` is the one wiring of the task; the Gymnasium env (`tasks.pull.env`) exports
its `action` input and its `observation`, `reward` and `success` outputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drake_tooluse.builders.control import (
    add_tip_control,
    add_world_at_home,
    nominal_belief,
)
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import HOOK_CORNER, HookTool
from drake_tooluse.systems.tip_target import Workspace
from drake_tooluse.tasks.contract import GoalTaskParts
from drake_tooluse.tasks.pull.hook import hook_geometry, pull_pose, slant_and_drop
from drake_tooluse.tasks.pull.metrics import PullOutcome
from drake_tooluse.tasks.pull.observation import ToolPullObservation
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import goal_position, initial_box_pose

# The hook's end is kept at least this far above the table top (m): the corner's target never
# drives it into the table.
TABLE_CLEARANCE = 0.004
# Where the corner's target may go in x and y (m, W): over the table, out to the far edge.
CORNER_XY_LOWER = (0.50, -0.70)
CORNER_XY_UPPER = (1.40, 0.35)
CORNER_MAX_HEIGHT = 0.40  # m above the table top


def home_corner_pose(scenario: Scenario):
    """X_WC of the home pose: the corner at the scenario's home point (`robot.home_tip_xy`,
    `home_tip_height` above the table), the hook held as it pulls (`hook.pull_orientation`)."""
    x, y = scenario.robot.home_tip_xy
    return pull_pose([x, y, scenario.table.top_z + scenario.robot.home_tip_height])


def corner_workspace(scenario: Scenario, hook: HookTool) -> Workspace:
    """The box the corner's target is kept in: over the table, low enough to reach under the
    cube's top, never so low that the believed hook's end (its drop below the corner and its
    radius) meets the table."""
    _, drop = slant_and_drop(hook.hook_length, hook.angle)
    top = scenario.table.top_z
    return Workspace(
        np.array([*CORNER_XY_LOWER, top + drop + hook.radius + TABLE_CLEARANCE]),
        np.array([*CORNER_XY_UPPER, top + CORNER_MAX_HEIGHT]),
    )


@dataclass
class PullTask(GoalTaskParts):
    """The parts `add_pull_task` added: the contract's, the two systems that hold the
    episode's goal and the cube's start (`observation`, `outcome`: `set_episode` sets both)
    and the robot's belief."""

    observation: ToolPullObservation = None
    outcome: PullOutcome = None
    belief: RobotBelief = None


def add_pull_task(
    builder,
    scenario: Scenario,
    belief: RobotBelief | None = None,
    visuals: bool = True,
) -> PullTask:
    """The world holding the scenario's hook, at the home pose the robot computes for `belief`
    (default: `nominal_belief`, the scenario's hook), position control of the believed hook's
    inner corner, the task's observation and outcome (goal: the scenario's). The target's
    `action` input is left unconnected. `visuals`: as `world.scene.add_world`'s."""
    belief = nominal_belief(scenario) if belief is None else belief
    if not isinstance(belief.tool, HookTool):
        raise ValueError(
            f"the pull task needs a hook in the hand; the robot believes {belief.tool}"
        )
    home = home_corner_pose(scenario)
    world, ik, q0 = add_world_at_home(builder, scenario, belief, HOOK_CORNER, home, visuals=visuals)
    control = add_tip_control(
        builder,
        world,
        ik,
        q0,
        "position",
        home,
        corner_workspace(scenario, belief.tool),
    )
    goal = goal_position(scenario)
    return PullTask.wire(
        builder,
        world,
        ik,
        control,
        ToolPullObservation(world, ik.chain, goal, hook_geometry(belief.tool)),
        PullOutcome(world, goal, initial_box_pose(scenario).translation()),
        belief=belief,
    )
