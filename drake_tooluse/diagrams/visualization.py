"""Meshcat: a server on loopback, a visualizer in a diagram, recordings saved as standalone
HTML."""

from __future__ import annotations

from pathlib import Path

from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer, MeshcatVisualizerParams

from drake_tooluse.files import atomic_write_text


def start_meshcat() -> Meshcat:
    """A Meshcat server on a free loopback port (no browser needed)."""
    return Meshcat(MeshcatParams(host="localhost", port=0, show_stats_plot=False))


def add_meshcat_visualizer(builder, scene_graph, meshcat: Meshcat) -> MeshcatVisualizer:
    return MeshcatVisualizer.AddToBuilder(
        builder, scene_graph, meshcat, MeshcatVisualizerParams(publish_period=1 / 32)
    )


def save_recording(meshcat: Meshcat, visualizer: MeshcatVisualizer, path: str | Path) -> Path:
    """Stops the visualizer's recording and writes scene + playback as one HTML file."""
    visualizer.StopRecording()
    visualizer.PublishRecording()
    return atomic_write_text(path, meshcat.StaticHtml())
