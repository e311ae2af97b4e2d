"""Meshcat recordings saved as standalone HTML, and block diagrams rendered for `diagrams/`."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer, MeshcatVisualizerParams

from drake_tooluse.io import atomic_write_text


def start_meshcat() -> Meshcat:
    """A Meshcat server on a free loopback port (no browser needed)."""
    return Meshcat(MeshcatParams(host="localhost", port=0, show_stats_plot=False))


def add_meshcat_visualizer(builder, scene_graph, meshcat: Meshcat) -> MeshcatVisualizer:
    return MeshcatVisualizer.AddToBuilder(
        builder, scene_graph, meshcat, MeshcatVisualizerParams(publish_period=1 / 32))


def look_at(eye, target):
    """X_WC of a camera at `eye` looking at `target` (Drake camera frame: +z along the view,
    +x right, +y down), with the world's +z up in the image."""
    from pydrake.math import RigidTransform, RotationMatrix

    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return RigidTransform(RotationMatrix(np.column_stack([x, y, z])), np.asarray(eye, float))


def add_render_camera(builder, world, width: int = 480, height: int = 360):
    """A fixed colour camera looking at the table from the robot's front right, for
    `render_mode="rgb_array"`; exports its `color_image` port. Returns the RgbdSensor."""
    from pydrake.geometry import (
        ClippingRange,
        ColorRenderCamera,
        DepthRange,
        DepthRenderCamera,
        MakeRenderEngineVtk,
        RenderCameraCore,
        RenderEngineVtkParams,
    )
    from pydrake.math import RigidTransform
    from pydrake.systems.sensors import CameraInfo, RgbdSensor

    renderer = "render_camera"
    if not world.scene_graph.HasRenderer(renderer):
        world.scene_graph.AddRenderer(renderer, MakeRenderEngineVtk(RenderEngineVtkParams()))
    core = RenderCameraCore(renderer, CameraInfo(width, height, 0.9), ClippingRange(0.05, 10.0),
                            RigidTransform())
    # In front of the robot, to its right, looking at the work area of the table.
    X_WC = look_at([1.35, -0.85, 0.35], [0.55, -0.15, -0.12])
    sensor = builder.AddNamedSystem("render_camera", RgbdSensor(
        world.scene_graph.world_frame_id() if hasattr(world.scene_graph, "world_frame_id")
        else world.plant.GetBodyFrameIdOrThrow(world.plant.world_body().index()),
        X_WC, ColorRenderCamera(core, False), DepthRenderCamera(core, DepthRange(0.05, 10.0))))
    builder.Connect(world.scene_graph.get_query_output_port(), sensor.query_object_input_port())
    builder.ExportOutput(sensor.color_image_output_port(), "color_image")
    return sensor


def save_recording(meshcat: Meshcat, visualizer: MeshcatVisualizer, path: str | Path) -> Path:
    """Stops the visualizer's recording and writes scene + playback as one HTML file."""
    visualizer.StopRecording()
    visualizer.PublishRecording()
    return atomic_write_text(path, meshcat.StaticHtml())


def graphviz_dot(diagram, max_depth: int = 1) -> str:
    """The diagram's Graphviz text with Drake's run-dependent system ids renumbered, so the
    same diagram always gives the same text."""
    text = diagram.GetGraphvizString(max_depth=max_depth)
    ids: dict[str, str] = {}

    def renumber(match):
        return ids.setdefault(match.group(0), str(len(ids)))

    # Ids appear as `digraph _N`, `clusterN...` and node names `sN`.
    lines = re.sub(r"(?<=digraph _)\d+|(?<=cluster)\d+|(?<=\bs)\d+\b", renumber,
                   text).split("\n")
    # Drake lists the edges in id order, which depends on the run: sort them.
    edge_rows = [i for i, line in enumerate(lines) if " -> " in line]
    for i, line in zip(edge_rows, sorted(lines[i] for i in edge_rows)):
        lines[i] = line
    return "\n".join(lines)


def render_svg(dot_text: str, svg_path: str | Path) -> Path:
    """Renders Graphviz text to SVG with the `dot` program (Debian package `graphviz`)."""
    dot = shutil.which("dot")
    if dot is None:
        raise RuntimeError("rendering a block diagram needs Graphviz's `dot` "
                           "(apt-get install graphviz)")
    svg = subprocess.run([dot, "-Tsvg"], input=dot_text, capture_output=True, text=True,
                         check=True).stdout
    return atomic_write_text(svg_path, svg)
