"""A scripted pull in hook-corner space: a reference policy for tests and benchmarks.

It reads only the observation (`tasks.pull.observation`), the believed hook's geometry
included: it carries the corner over the cube, high enough that the hook's end clears it, to
behind the cube's far face (the hook's slant back towards the robot added), lowers it there
until the hook's end is just above the table (and the handle, rising towards the hand, clears
the cube's top), then draws the corner towards the goal, pressing the hook up to 2 cm into the
cube (less as the cube nears the goal), the corner kept on the cube's centre line. Should the
cube slip out of the hook, it lifts the hook and starts again. Actions are the env's (3-d position changes in [-1, 1]).
"""

from __future__ import annotations

import math

import numpy as np

from drake_tooluse.systems.tip_target import MAX_TRANSLATION_STEP
from drake_tooluse.tasks.pull.hook import PULL_TILT, slant_and_drop
from drake_tooluse.tasks.pull.observation import CORNER, GOAL, HOOK, OBJECT

RISE, OVER, PULL = range(3)


class ScriptedPull:
    """Call with an observation, get a 3-d action in [-1, 1]."""

    def __init__(
        self,
        table_top_z: float,
        cube_size: float = 0.04,
        hook_radius: float = 0.006,
        clearance: float = 0.03,
        gap: float = 0.012,
        tolerance: float = 0.006,
        max_press: float = 0.02,
        steer: float = 0.008,
        gain: float = 1.5,
    ):
        self.top = table_top_z
        self.size = cube_size
        self.radius = hook_radius
        self.clearance = clearance
        self.gap = gap
        self.tolerance = tolerance
        self.max_press = max_press
        self.steer = steer
        # The action per metre of the waypoint's error, in units of the largest step: the arm
        # lags its target (which moves from the observed state), so a gain over
        # 1 keeps the action saturated nearer the waypoint. Measured on ToolPull-v1 (40
        # episodes, seeds 100-139) and in the perturbed reality (30 instances of
        # benchmarks/pull_policy.py, seeds 1000-1029): gain 1: 16/20 in simulation, 10/30 in
        # reality (too slow to finish); 2: 40/40, 11/30 (overshoots reality's 40 ms delay);
        # 1.5: 37/40, 21/30.
        self.gain = gain
        self.phase = OVER

    def reset(self) -> None:
        self.phase = OVER

    def _heights(self, hook) -> tuple[float, float, float]:
        """(slant, corner height to pass over the cube, corner height to pull at), m."""
        _, hook_length, angle = hook
        slant, drop = slant_and_drop(hook_length, math.degrees(angle))
        over = self.top + self.size + drop + self.clearance
        r = self.radius
        # The hook's end just above the table, and the handle clear of the cube's top edge
        # where it passes over it (it rises at the tilt from the corner towards the hand).
        handle_clear = self.size + r / math.cos(PULL_TILT) - (slant + r) * math.tan(PULL_TILT)
        pull = self.top + max(drop + r + 0.006, handle_clear + 0.003)
        return slant, over, pull

    def __call__(self, observation) -> np.ndarray:
        goal, cube, corner = observation[GOAL], observation[OBJECT], observation[CORNER]
        slant, z_over, z_pull = self._heights(observation[HOOK])
        # The corner's place when the hook's end touches the cube's far face.
        engaged_x = cube[0] + self.size / 2 + self.radius + slant
        behind_x = engaged_x + self.gap
        if self.phase == RISE:
            waypoint = np.array([corner[0], corner[1], z_over])
        elif self.phase == OVER:
            # Lowering may start once the hook's end has passed the cube's far face.
            z = z_pull if corner[0] > behind_x - self.gap / 2 else z_over
            waypoint = np.array([behind_x, cube[1], z])
        else:
            # The hook rode over the cube (the corner passed its centre) or slid off its side:
            # over it again.
            if corner[0] < cube[0] or abs(corner[1] - cube[1]) > self.size / 2:
                self.phase = RISE
                return self(observation)
            to_go = cube[0] - goal[0]
            if to_go > 0.0:  # press the hook into the cube, less as it nears the goal
                x = engaged_x - min(self.max_press, 0.5 * to_go)
            else:  # the cube is there: let go of it
                x = goal[0] + (engaged_x - cube[0]) + self.gap
            # Along the cube's centre line, up to `steer` off it on the side away from the
            # goal's line: a point pull off the centre turns the cube, and it then walks
            # towards the other side (as a pushed block turns away from the pushing finger).
            y = cube[1] - np.clip(goal[1] - cube[1], -self.steer, self.steer)
            waypoint = np.array([x, y, z_pull])
        error = waypoint - corner
        if self.phase < PULL and np.linalg.norm(error) < self.tolerance:
            self.phase += 1
        return np.clip(self.gain * error / MAX_TRANSLATION_STEP, -1.0, 1.0)
