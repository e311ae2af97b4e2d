"""The push task's truth: success, distances and contacts, read from the world plant.

x is the box centre, x* the goal, y the true tool tip. Success is d(x, x*) + d(x, y) <= 0.05 m
(the paper's). What the robot observes is `tasks.push.observation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from drake_tooluse.tasks.contract import EpisodeMetric
from drake_tooluse.world.paper import SUCCESS_DISTANCE
from drake_tooluse.world.scene import World

# The paper's rewards: Env1 and Env3 -(d(x, x*) + d(x, y)), Env2 -d(x, x*).
REWARD_TYPES = ("tool_and_box", "box")

# What an evaluation reports of each episode (`info` keys of the env's last step).
PUSH_EPISODE_METRICS = (
    EpisodeMetric("final_box_to_goal_m", "box_to_goal"),
    EpisodeMetric("box_travel_m", "box_travel", mean_only=True),
    EpisodeMetric("tool_touched", "tool_touched_box_in_episode", flag=True),
    EpisodeMetric("gripper_touched", "gripper_touched_box_in_episode", flag=True),
)


@dataclass
class PushMetrics:
    box_to_goal: float  # d(x, x*), m
    tip_to_box: float  # d(x, y), m (true tip)
    box_travel: float  # distance of the box centre from where it started, m
    tool_touches_box: bool
    gripper_touches_box: bool

    @property
    def is_success(self) -> bool:
        return self.box_to_goal + self.tip_to_box <= SUCCESS_DISTANCE


class PushMetricsReader:
    """Reads the truth from the world plant: distances and which bodies touch the box."""

    def __init__(self, world: World):
        plant = world.plant
        self._plant = plant
        self._box = world.box
        self._tip_frame = world.tip_frame
        # Body indices as ints: comparing ints is cheaper than comparing pydrake's BodyIndex
        # objects, and this runs every control step.
        self._box_index = int(world.box.index())
        self._tool_index = int(world.tool.index()) if world.tool is not None else None
        self._robot_bodies = {int(i) for i in plant.GetBodyIndices(world.baxter)}
        self._robot_bodies.discard(self._tool_index)

    def read(self, plant_context, goal, box_start) -> PushMetrics:
        p_box = self._box.EvalPoseInWorld(plant_context).translation()
        p_tip = self._tip_frame.CalcPoseInWorld(plant_context).translation()
        tool_touch = gripper_touch = False
        contacts = self._plant.get_contact_results_output_port().Eval(plant_context)
        box = self._box_index
        for i in range(contacts.num_point_pair_contacts()):
            info = contacts.point_pair_contact_info(i)
            a, b = int(info.bodyA_index()), int(info.bodyB_index())
            if a == box:
                other = b
            elif b == box:
                other = a
            else:
                continue
            tool_touch |= other == self._tool_index
            gripper_touch |= other in self._robot_bodies
        return PushMetrics(
            box_to_goal=math.dist(p_box, goal),
            tip_to_box=math.dist(p_tip, p_box),
            box_travel=math.dist(p_box[:2], box_start[:2]),
            tool_touches_box=bool(tool_touch),
            gripper_touches_box=bool(gripper_touch),
        )


def reward(metrics: PushMetrics, reward_type: str) -> float:
    """The paper's reward of one step (see REWARD_TYPES)."""
    if reward_type == "box":
        return -float(metrics.box_to_goal)
    return -float(metrics.box_to_goal + metrics.tip_to_box)
