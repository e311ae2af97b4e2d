"""The push task's truth: success, distances and contacts, read from the world plant, and
the `PushOutcome` system that exports them with the reward and success as ports.

x is the box centre, x* the goal, y the true tool tip (a generated tool's push point: its
front where it meets the box). Success is d(x, x*) + d(x, y) <= 0.05 m (the paper's). What the
robot observes is `tasks.push.observation`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.tool_generator import PUSH_POINT
from drake_tooluse.systems.task_outcome import BoxAndToolPointReader, TaskOutcome
from drake_tooluse.tasks.contract import EpisodeMetric
from drake_tooluse.validation import check_one_of
from drake_tooluse.world.paper import SUCCESS_DISTANCE
from drake_tooluse.world.scene import World

# The paper's rewards: Env1 and Env3 -(d(x, x*) + d(x, y)), Env2 -d(x, x*).
REWARD_TYPES = ("tool_and_box", "box")

# What an evaluation reports of each episode (`info` keys of the env's last step).
PUSH_EPISODE_METRICS = (
    EpisodeMetric("final_object_to_goal_m", "object_to_goal"),
    EpisodeMetric("object_travel_m", "object_travel", mean_only=True),
    EpisodeMetric("tool_touched", "tool_touched_object_in_episode", flag=True),
    EpisodeMetric("gripper_touched", "gripper_touched_object_in_episode", flag=True),
)


@dataclass
class PushMetrics:
    object_to_goal: float  # d(x, x*), m
    tip_to_object: float  # d(x, y), m (the true tool's tip or push point)
    object_travel: float  # distance of the box centre from where it started, m
    tool_touches_object: bool
    gripper_touches_object: bool

    @property
    def is_success(self) -> bool:
        return self.object_to_goal + self.tip_to_object <= SUCCESS_DISTANCE


class PushMetricsReader(BoxAndToolPointReader):
    """Reads the truth from the world plant: distances and which bodies touch the box."""

    def __init__(self, world: World):
        # The paper's d(x, y) is from the tool's point that meets the box: its tip, or a
        # generated tool's push point (`robot.tool_generator`), a property of the tool and not
        # of the policy. (A rake's tip may be in the air between its tines; a curled arc's is
        # up in its curl.)
        plant = world.plant
        has_push_point = plant.HasFrameNamed(PUSH_POINT)
        point = plant.GetFrameByName(PUSH_POINT) if has_push_point else world.tip_frame
        super().__init__(world, point)

    def _metrics(self, p_box, p_tip, contacts, goal, box_start) -> PushMetrics:
        # Lists: math.dist reads them faster than arrays (the same floats, so the same result).
        p_box, p_tip = p_box.tolist(), p_tip.tolist()
        tool_touch, gripper_touch = self._touches(contacts)
        return PushMetrics(
            object_to_goal=math.dist(p_box, _floats(goal)),
            tip_to_object=math.dist(p_tip, p_box),
            object_travel=math.dist(p_box[:2], _floats(box_start)[:2]),
            tool_touches_object=tool_touch,
            gripper_touches_object=gripper_touch,
        )


def _floats(values) -> list:
    """A point as a list of floats (an array's `tolist`, cheaper than math.dist's iteration)."""
    return values.tolist() if isinstance(values, np.ndarray) else list(values)


class PushOutcome(TaskOutcome, LeafSystem):
    """The push task's truth as ports: the step's metrics, the paper's reward and success.

    .. pydrake_system::

        name: PushOutcome
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
        metrics: `PushMetrics` (distances in m, which bodies touch the box).
        reward: [r], the paper's reward of `reward_type` (see REWARD_TYPES).
        success: [1.0] when d(x, x*) + d(x, y) <= SUCCESS_DISTANCE, else [0.0] (y: the true
            tool's tip, or a generated tool's push point: `PushMetricsReader`).
    Parameters: the goal x* (3, m) and the box's start (3, m), set per episode
    (`set_episode`).
    """

    def __init__(self, world: World, goal, box_start, reward_type: str):
        check_one_of(reward_type, REWARD_TYPES, "reward_type")
        super().__init__(
            world,
            PushMetricsReader(world),
            functools.partial(reward, reward_type=reward_type),
            lambda: PushMetrics(0.0, 0.0, 0.0, False, False),
            goal,
            box_start,
        )


def reward(metrics: PushMetrics, reward_type: str) -> float:
    """The paper's reward of one step (see REWARD_TYPES)."""
    if reward_type == "box":
        return -float(metrics.object_to_goal)
    return -float(metrics.object_to_goal + metrics.tip_to_object)
