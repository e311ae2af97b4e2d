"""The pull task's truth: success, distances and contacts, read from the world plant, its
reward, and the `PullOutcome` system that exports them as ports.

x is the cube's centre, x* the goal, x₀ where the cube started, c the true hook's inner corner.
The tool point is where the corner belongs when the hook holds the cube: just behind the
cube's far face, p_b = x + (w/2 + r) ê, with w the cube's side, r the hook's radius and ê the
horizontal unit vector from the goal to the cube's start (away from the robot).

- Success: d(x, x*) ≤ SUCCESS_RADIUS and d_xy(x, x₀) ≥ MIN_TRAVEL. Every start lies farther than
  SUCCESS_RADIUS from its goal (0.20 m away), so no episode succeeds without moving the cube.
- Reward (dense, the push task's form with the hook's corner as the tool point):
  r = −(d(x, x*) + d(c, p_b)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.tool import HOOK_CORNER, TOOL_TIP
from drake_tooluse.systems.task_outcome import BoxAndToolPointReader, TaskOutcome
from drake_tooluse.tasks.contract import EpisodeMetric
from drake_tooluse.world.scene import World

SUCCESS_RADIUS = 0.05  # m: the cube's centre this near the goal ...
MIN_TRAVEL = 0.10  # m: ... and this far (horizontally) from where it started

PULL_EPISODE_METRICS = (
    EpisodeMetric("final_object_to_goal_m", "object_to_goal"),
    EpisodeMetric("object_travel_m", "object_travel", mean_only=True),
    EpisodeMetric("tool_touched", "tool_touched_object_in_episode", flag=True),
    EpisodeMetric("gripper_touched", "gripper_touched_object_in_episode", flag=True),
)


@dataclass
class PullMetrics:
    object_to_goal: float  # d(x, x*), m
    object_travel: float  # horizontal distance of the cube from its start, m
    corner_to_behind: float  # d(c, p_b), m (the true corner)
    tool_touches_object: bool
    gripper_touches_object: bool

    @property
    def is_success(self) -> bool:
        return is_success(self.object_to_goal, self.object_travel)


def is_success(object_to_goal: float, object_travel: float) -> bool:
    """The success criterion of a cube `object_to_goal` m from its goal and `object_travel` m
    from its start."""
    return object_to_goal <= SUCCESS_RADIUS and object_travel >= MIN_TRAVEL


def reward(metrics: PullMetrics) -> float:
    """−(d(x, x*) + d(c, p_b)), m."""
    return -float(metrics.object_to_goal + metrics.corner_to_behind)


def behind_direction(goal, start) -> np.ndarray:
    """ê: the horizontal unit vector from the goal to the cube's start."""
    e = np.asarray(start, float) - np.asarray(goal, float)
    e[2] = 0.0
    return e / np.linalg.norm(e)


class PullMetricsReader(BoxAndToolPointReader):
    """Reads the truth from the world plant: the cube, the true hook's corner, the contacts."""

    def __init__(self, world: World):
        plant = world.plant
        # A straight tool (the hook policy tried on one) has no corner: its tip, where a
        # hook's would be.
        corner = HOOK_CORNER if plant.HasFrameNamed(HOOK_CORNER) else TOOL_TIP
        super().__init__(world, plant.GetFrameByName(corner))
        self._standoff = world.scenario.box.size[0] / 2 + world.scenario.tool.radius

    def _metrics(self, p_box, p_corner, contacts, goal, start) -> PullMetrics:
        goal, start = np.asarray(goal, float), np.asarray(start, float)
        behind = p_box + self._standoff * behind_direction(goal, start)
        tool_touch, gripper_touch = self._touches(contacts)
        return PullMetrics(
            object_to_goal=math.dist(p_box, goal),
            object_travel=math.dist(p_box[:2], start[:2]),
            corner_to_behind=math.dist(p_corner, behind),
            tool_touches_object=tool_touch,
            gripper_touches_object=gripper_touch,
        )


class PullOutcome(TaskOutcome, LeafSystem):
    """The pull task's truth as ports: the step's metrics, its reward and success.

    .. pydrake_system::

        name: PullOutcome
        input_ports:
        - body_poses
        - contact_results
        output_ports:
        - metrics
        - reward
        - success

    Input ports:
        body_poses: the world plant's X_WB of every body (its `body_poses` port).
        contact_results: the world plant's contact results.
    Output ports:
        metrics: `PullMetrics` (distances in m, which bodies touch the cube).
        reward: [r] = [−(d(x, x*) + d(c, p_b))] (m).
        success: [1.0] when d(x, x*) ≤ SUCCESS_RADIUS and the cube moved ≥ MIN_TRAVEL.
    Parameters: the goal x* (3, m) and the cube's start x₀ (3, m), set per episode
    (`set_episode`).
    """

    def __init__(self, world: World, goal, start):
        super().__init__(
            world,
            PullMetricsReader(world),
            reward,
            lambda: PullMetrics(0.0, 0.0, 0.0, False, False),
            goal,
            start,
        )
