"""The demo's figures: the goal drawn where the scene camera sees it, the camera panel cropped
to the tool, the annotation's legend and words."""

from types import SimpleNamespace

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.experiments.demo import GOAL_RGB, mark_goal, tool_crop
from drake_tooluse.perception.markers import (
    ANNOTATION_COLORS,
    ViewMeasurement,
    annotate_view,
    measurement_text,
)
from drake_tooluse.systems.camera import add_scene_camera, scene_camera_view
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import add_world, goal_position, initial_box_pose


@pytest.fixture(scope="module")
def scene():
    scenario = Scenario()
    builder = DiagramBuilder()
    world = add_world(builder, scenario)
    add_scene_camera(builder, world)
    diagram = builder.Build()
    image = diagram.GetOutputPort("color_image").Eval(diagram.CreateDefaultContext()).data
    return scenario, scene_camera_view(diagram, world.plant), np.array(image[:, :, :3])


def test_the_scene_camera_projection_lands_on_what_it_renders(scene):
    scenario, view, image = scene
    (box_uv,), front = view.project([initial_box_pose(scenario).translation()])
    assert front.all()
    u, v = np.rint(box_uv).astype(int)
    # The box's centre lands on the box: lit wood, brighter than the dark table around it.
    box = image[v - 2 : v + 3, u - 2 : u + 3].reshape(-1, 3).astype(float)
    table = image[v + 20 : v + 25, u - 2 : u + 3].reshape(-1, 3).astype(float)
    assert (box[:, 0] > box[:, 2] + 30).all()  # brown-orange, not the sky or the robot
    assert box.mean() > table.mean() + 40


def test_the_goal_is_drawn_at_its_projection(scene):
    scenario, view, image = scene
    marked = mark_goal(image, view, scenario)
    goal = goal_position(scenario)
    (uv,), _ = view.project([[goal[0], goal[1], scenario.table.top_z]])
    u, v = np.rint(uv).astype(int)
    changed = np.abs(marked.astype(int) - image.astype(int)).sum(axis=2) > 30
    assert changed[v - 3 : v + 4, u - 3 : u + 4].all()  # the cross and the disc at x*
    rows, cols = np.nonzero(changed)
    assert abs(np.median(cols) - u) < 25 and abs(np.median(rows) - v) < 25  # nowhere else
    assert marked[v, u, 1] > marked[v, u, 0] and marked[v, u, 1] > marked[v, u, 2]  # green
    assert np.allclose(marked[v - 1 : v + 2, u - 1 : u + 2], GOAL_RGB, atol=40)  # the cross


def _view(corners_a, corners_b):
    return ViewMeasurement(
        view="grip_right",
        accepted=True,
        length_depth=0.1249,
        length_pixel=0.1093,
        ends_px=[corners_a[0], corners_b[2]],
        ends_C=[],
        boxes=[corners_a, corners_b],
    )


def test_the_camera_panel_is_cropped_to_the_tool():
    a = [(300, 400), (300, 410), (312, 410), (312, 400)]
    b = [(700, 402), (700, 412), (712, 412), (712, 402)]
    rows, cols = tool_crop((800, 1280, 3), _view(a, b))
    width, height = cols.stop - cols.start, rows.stop - rows.start
    assert width / height == pytest.approx(4 / 3, rel=0.02)
    assert cols.start <= 300 and cols.stop >= 712 and rows.start <= 400 and rows.stop >= 412
    assert width < 0.6 * 1280  # the tool fills most of the panel, not a sliver
    assert 0 <= cols.start and cols.stop <= 1280 and 0 <= rows.start and rows.stop <= 800
    near_edge = _view(
        [(5, 5), (5, 15), (15, 15), (15, 5)], [(300, 8), (300, 18), (310, 18), (310, 8)]
    )
    rows, cols = tool_crop((800, 1280, 3), near_edge)
    assert rows.start == 0 and cols.start == 0 and rows.stop <= 800


def test_the_annotation_says_which_estimate_the_robot_uses_and_shows_its_legend():
    text = " ".join(measurement_text(_view([(0, 0)] * 4, [(9, 9)] * 4)))
    assert "depth variant 124.9 mm (what the robot uses)" in text
    assert "pixel variant 109.3 mm (the paper's fixed m/px" in text and "tilted" in text
    dropped = ViewMeasurement(view="grip_left", accepted=False, reason="tip marker missing")
    assert measurement_text(dropped) == ["grip_left: dropped - tip marker missing"]
    for width in (640, 1280):
        image = np.full((width * 5 // 8, width, 3), 200, np.uint8)
        a = [(width * 0.3, width * 0.3), (width * 0.3, width * 0.31)] * 2
        out = annotate_view(image, _view(a, a))
        legend = out[: out.shape[0] // 3, : out.shape[1] // 2]
        for color, _ in ANNOTATION_COLORS.values():  # every colour's swatch, BGR
            assert (legend == np.array(color, np.uint8)).all(axis=2).sum() >= (width // 160) ** 2


# A 1280 x 800 pinhole camera's intrinsics (what annotate_view reads of Drake's CameraInfo).
PINHOLE = SimpleNamespace(
    **{
        k: (lambda v=v: v)
        for k, v in dict(focal_x=1e3, focal_y=1e3, center_x=640, center_y=400).items()
    }
)


def test_what_the_cropped_panel_shows_matches_its_legend():
    """Every colour of the legend is drawn inside the camera panel's crop, in its swatch's
    colour exactly: the mask painted (not blended), the depth variant's ends as dots on the
    image (not only in the corner insets, which the crop cuts off)."""
    image = np.full((800, 1280, 3), 60, np.uint8)
    a = [(500, 395), (500, 405), (520, 405), (520, 395)]
    b = [(760, 395), (760, 405), (780, 405), (780, 395)]
    for box in (a, b):
        image[395:406, box[0][0] : box[2][0] + 1] = (255, 120, 0)  # orange marker bands
    view = _view(a, b)
    depth_px = [(497.0, 400.0), (783.0, 401.0)]  # where the 3-D ends project
    view.ends_C = [[(u - 640) / 1000 * 0.8, (v - 400) / 1000 * 0.8, 0.8] for u, v in depth_px]
    out = annotate_view(image, view, PINHOLE)
    rows, cols = tool_crop(out.shape, view)
    panel = out[rows, cols]
    colors = {k: np.array(c, np.uint8) for k, (c, _) in ANNOTATION_COLORS.items()}
    for name, color in colors.items():
        assert (panel == color).all(axis=2).sum() >= 4, name
    # The mask's pixels that no line or dot covers are the swatch's green exactly.
    assert (out[398:403, 503:518] == colors["mask"]).all()
    for u, v in depth_px:
        assert (out[round(v), round(u)] == colors["depth"]).all()
