"""The hand camera finds where the box starts (builders.box_measurement, perception.box)."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.sensors import CameraInfo

from drake_tooluse.builders.box_measurement import measure_box_start
from drake_tooluse.paths import REALITY_SCENARIO
from drake_tooluse.perception.box import measure_box
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.world.scenario import load_scenario, with_tool_length
from drake_tooluse.world.scene import initial_box_pose


def _moved(scenario, dx, dy, yaw):
    x, y, z = scenario.box.position
    return dc.replace(scenario, box=dc.replace(scenario.box, position=(x + dx, y + dy, z), yaw=yaw))


@pytest.mark.parametrize("tool", [0.125, 0.3])
def test_the_box_start_is_measured_within_two_millimetres(tool):
    reality = with_tool_length(load_scenario(REALITY_SCENARIO), tool)
    belief = RobotBelief(tool, (0.0, 0.0))
    for dx, dy, yaw in [(0.02, -0.02, 0.2), (-0.02, 0.02, -0.2), (0.0, 0.0, 0.0)]:
        scenario = _moved(reality, dx, dy, yaw)
        measured = measure_box_start(scenario, belief)
        truth = initial_box_pose(scenario).translation()
        assert np.linalg.norm(measured.p_WB_xy - truth[:2]) < 0.002
        assert measured.top_z == pytest.approx(truth[2] + scenario.box.size[2] / 2, abs=0.002)


def test_a_box_out_of_view_is_a_one_line_error():
    scenario = _moved(load_scenario(REALITY_SCENARIO), 0.3, 0.4, 0.0)
    with pytest.raises(ValueError, match="no box in the camera's view") as error:
        measure_box_start(scenario)
    assert "\n" not in str(error.value)


def _looking_down(box_xy, yaw, size, box_height, camera_height=0.4):
    """Depth image of a camera `camera_height` above the table (z = 0) looking straight down at
    a box's top face (sides `size`, turned by `yaw`), and X_WC."""
    info = CameraInfo(200, 160, 150.0, 150.0, 99.5, 79.5)  # w, h, fx, fy, cx, cy (pixels)
    X_WC = RigidTransform(RotationMatrix(np.diag([1.0, -1.0, -1.0])), [0.0, 0.0, camera_height])
    v, u = np.mgrid[0 : info.height(), 0 : info.width()]
    top = camera_height - box_height
    x = (u - info.center_x()) / info.focal_x() * top
    y = -(v - info.center_y()) / info.focal_y() * top
    c, s = np.cos(yaw), np.sin(yaw)
    dx, dy = x - box_xy[0], y - box_xy[1]
    inside = (np.abs(c * dx + s * dy) <= size[0] / 2) & (np.abs(-s * dx + c * dy) <= size[1] / 2)
    depth = np.where(inside, top, camera_height).astype(np.float32)
    return depth, info, X_WC


def test_the_top_face_rectangle_gives_the_centre_on_a_synthetic_image():
    depth, info, X_WC = _looking_down((0.03, -0.02), 0.3, (0.04, 0.04), 0.04)
    m = measure_box(depth, info, X_WC, 0.0, max_height=0.08, box_size_xy=(0.04, 0.04))
    np.testing.assert_allclose(m.p_WB_xy, [0.03, -0.02], atol=0.002)
    assert m.top_z == pytest.approx(0.04)


def test_a_box_taller_than_the_look_or_of_another_size_is_an_error():
    depth, info, X_WC = _looking_down((0.0, 0.0), 0.0, (0.04, 0.04), 0.10)
    with pytest.raises(ValueError, match="no box in the camera's view"):
        measure_box(depth, info, X_WC, 0.0, max_height=0.08, box_size_xy=(0.04, 0.04))
    depth, info, X_WC = _looking_down((0.0, 0.0), 0.0, (0.06, 0.04), 0.04)
    with pytest.raises(ValueError, match="the top face found is .* the box.s is 0.040 x 0.040 m"):
        measure_box(depth, info, X_WC, 0.0, max_height=0.08, box_size_xy=(0.04, 0.04))
