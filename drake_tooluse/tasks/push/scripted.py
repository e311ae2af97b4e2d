"""A scripted push in tool-tip space: a reference policy for tests and benchmarks.

It reads only the observation (see `tasks.push.observation`): goes above a point behind the box, lowers the
tip to push height, and pushes the box along the box-to-goal direction until the box is on the
goal. Works with `action_mode="position"` (3-d actions).
"""

from __future__ import annotations

import numpy as np

from drake_tooluse.systems.tip_target import MAX_TRANSLATION_STEP


class ScriptedPush:
    """Call with an observation, get a 3-d action in [-1, 1]."""

    def __init__(
        self,
        table_top_z: float,
        box_half: float = 0.02,
        tool_radius: float = 0.006,
        push_height: float = 0.015,
        tolerance: float = 0.004,
    ):
        self.z_push = table_top_z + push_height
        self.z_above = table_top_z + 0.09
        self.standoff = box_half + tool_radius + 0.012
        self.contact = box_half + tool_radius + 0.002
        self.tolerance = tolerance
        self.phase = 0

    def reset(self) -> None:
        self.phase = 0

    def __call__(self, observation) -> np.ndarray:
        goal, box, tip = observation[0:3], observation[3:6], observation[6:9]
        direction = goal[:2] - box[:2]
        distance = np.linalg.norm(direction)
        u = direction / distance if distance > 1e-6 else np.array([0.0, 1.0])
        behind = box[:2] - self.standoff * u
        if self.phase == 0:
            waypoint = np.array([*behind, self.z_above])
        elif self.phase == 1:
            waypoint = np.array([*behind, self.z_push])
        else:
            # Keep the tip on the goal-box line behind the box, pressing up to 3 cm in; less
            # as the box nears the goal. Off the line (the box slid sideways): start again.
            offset = tip[:2] - box[:2]
            lateral = abs(offset[0] * u[1] - offset[1] * u[0])
            if lateral > 0.6 * self.contact:
                self.phase = 0
            press = min(0.03, distance)
            waypoint = np.array([*(box[:2] - (self.contact - press) * u), self.z_push])
        error = waypoint - tip
        if self.phase < 2 and np.linalg.norm(error) < self.tolerance:
            self.phase += 1
        return np.clip(error / MAX_TRANSLATION_STEP, -1.0, 1.0)
