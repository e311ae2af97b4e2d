"""Meshcat: a server on loopback, a visualizer in a diagram, recordings saved as standalone
HTML that open framed on the task.

`show_task(meshcat, scenario)` sets what a recording opens on: the camera on the work (robot,
tool, box and goal in view), the goal as a translucent green disc on the table, and Meshcat's
ground grid at the floor under Baxter's pedestal (`world.scene.FLOOR_Z`; Meshcat draws it at
W's origin, Baxter's base, otherwise). These are scene-tree commands, so `Meshcat.StaticHtml`
carries them into the saved file.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from pydrake.geometry import (
    Cylinder,
    Meshcat,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
)
from pydrake.math import RigidTransform

from drake_tooluse.files import atomic_write_text
from drake_tooluse.world.paper import SUCCESS_DISTANCE
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import FLOOR_Z, goal_position

# The recordings' camera (W, m): in front of the robot and to its right, above the table,
# looking at the work area so that Baxter, the table, the box and the goal are all in view.
CAMERA_IN_WORLD = (1.6, -0.8, 0.55)
CAMERA_TARGET = (0.45, -0.15, -0.1)
GOAL_PATH = "/task/goal"  # outside /drake, which the visualizer clears on initialization
GRID_PATH = "/Grid"
# The goal disc: radius SUCCESS_DISTANCE / 2, about where the box centre counts as arrived
# (success is d(box, goal) + d(tip, box) <= SUCCESS_DISTANCE, and a tip touching the box's
# side is ~2.6 cm from its centre); a thin disc just above the table top, translucent green.
GOAL_RADIUS = SUCCESS_DISTANCE / 2
GOAL_THICKNESS = 0.002
GOAL_RGBA = (0.1, 0.8, 0.2, 0.45)


def start_meshcat(announce: bool = False) -> Meshcat:
    """A Meshcat server on a free loopback port (no browser needed). Drake logs its URL
    ("Meshcat listening for connections at …") only with `announce`: a server that only
    records (a run written as an HTML file) has no view to open, and its URL dies with the
    process."""
    drake_log = logging.getLogger("drake")
    level = drake_log.level
    if not announce:
        drake_log.setLevel(max(level, logging.WARNING))
    try:
        return Meshcat(MeshcatParams(host="localhost", port=0, show_stats_plot=False))
    finally:
        drake_log.setLevel(level)


def show_task(meshcat: Meshcat, scenario: Scenario) -> None:
    """Frames `meshcat` on the scenario's task: the camera on robot, table, box and goal,
    the goal marked (a translucent green disc of radius GOAL_RADIUS on the table at
    `world.scene.goal_position`), the ground grid moved down to the floor (FLOOR_Z)."""
    meshcat.SetCameraPose(np.array(CAMERA_IN_WORLD, float), np.array(CAMERA_TARGET, float))
    goal = goal_position(scenario)
    z = scenario.table.top_z + GOAL_THICKNESS / 2 + 1e-4  # on the table, not in it
    meshcat.SetObject(GOAL_PATH, Cylinder(GOAL_RADIUS, GOAL_THICKNESS), Rgba(*GOAL_RGBA))
    meshcat.SetTransform(GOAL_PATH, RigidTransform([goal[0], goal[1], z]))
    meshcat.SetTransform(GRID_PATH, RigidTransform([0.0, 0.0, FLOOR_Z]))


def add_meshcat_visualizer(
    builder, scene_graph, meshcat: Meshcat, scenario: Scenario | None = None
) -> MeshcatVisualizer:
    """A MeshcatVisualizer of `scene_graph` in `builder` (32 Hz); with `scenario`, `meshcat`
    is framed on its task (`show_task`)."""
    if scenario is not None:
        show_task(meshcat, scenario)
    return MeshcatVisualizer.AddToBuilder(
        builder, scene_graph, meshcat, MeshcatVisualizerParams(publish_period=1 / 32)
    )


def save_recording(meshcat: Meshcat, visualizer: MeshcatVisualizer, path: str | Path) -> Path:
    """Stops the visualizer's recording and writes scene + playback as one HTML file."""
    visualizer.StopRecording()
    visualizer.PublishRecording()
    return atomic_write_text(path, meshcat.StaticHtml())
