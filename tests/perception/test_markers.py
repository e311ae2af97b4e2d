"""The OpenCV marker pipeline on synthetic images: outer ends, small blobs, dropped views."""

import math

import numpy as np
import pytest
from pydrake.systems.sensors import CameraInfo

from drake_tooluse.perception.markers import ViewSpec, measure_view


def _synthetic_view(width=640, height=400, depth=0.5):
    """Two orange bands 20 px long on a grey background at one depth: columns 100-119 and
    400-419, rows 190-209."""
    color = np.full((height, width, 4), 128, np.uint8)
    for u0 in (100, 400):
        color[190:210, u0 : u0 + 20, :3] = (255, 115, 0)
    return color, np.full((height, width), depth, np.float32)


def test_synthetic_bands_measure_their_outer_ends():
    info = CameraInfo(640, 400, 1.0)
    color, depth = _synthetic_view()
    view = ViewSpec("synthetic", grip_pixel=(110.0, 200.0), grip_depth=0.5)
    m = measure_view(color, depth, info, view)
    assert m.accepted, m.reason
    # The outer edges are at u = 99.5 and 419.5 (pixel centres at integers): 320 px.
    expected = 320 * 0.5 / info.focal_x()
    assert m.length_pixel == pytest.approx(expected, abs=1e-9)
    assert m.length_depth == pytest.approx(expected, abs=1e-9)
    assert np.allclose(m.ends_px, [[99.5, 199.5], [419.5, 199.5]])


def test_a_small_blob_beside_the_bands_is_not_a_marker():
    info = CameraInfo(640, 400, 1.0)
    color, depth = _synthetic_view()
    color[50:55, 300:305, :3] = (255, 115, 0)  # 25 px: a distractor smaller than a band
    m = measure_view(color, depth, info, ViewSpec("s", (110.0, 200.0), 0.5))
    assert m.accepted and m.blob_count == 3
    assert m.length_depth == pytest.approx(320 * 0.5 / info.focal_x(), abs=1e-9)


@pytest.mark.parametrize(
    "edit, reason",
    [
        (lambda c: c[190:210, 400:420, :3].__setitem__(..., 128), "the tip marker is missing"),
        (lambda c: c[190:210, 100:120, :3].__setitem__(..., 128), "the grip marker is missing"),
        (lambda c: c[:, :, :3].__setitem__(..., 128), "no orange marker found"),
        (lambda c: c[190:210, 620:640, :3].__setitem__(..., (255, 115, 0)), "right border"),
        (lambda c: c[190:204, 400:420, :3].__setitem__(..., 128), "tip marker looks partly hidden"),
    ],
)
def test_a_view_without_both_whole_markers_is_dropped_with_the_reason(edit, reason):
    info = CameraInfo(640, 400, 1.0)
    color, depth = _synthetic_view()
    if "border" in reason:  # move the tip band to the image's right edge
        color[190:210, 400:420, :3] = 128
    edit(color)
    m = measure_view(color, depth, info, ViewSpec("s", (110.0, 200.0), 0.5))
    assert not m.accepted
    assert reason in m.reason
    assert math.isnan(m.length_depth)
