"""A held tool's points from depth images (`perception.tool_shape`): the tool's blob within the
depth window, specks and the background dropped; views fused in G, the hand dropped, thinned."""

import numpy as np

from drake_tooluse.perception.tool_shape import VOXEL, Z_MIN_G, fuse, thin, view_points

INTRINSICS = (200.0, 200.0, 32.0, 24.0)


def test_view_points_keep_the_tool_and_drop_specks_and_the_background():
    depth = np.full((48, 64), np.inf, np.float32)
    depth[:, :10] = 2.0  # the room, beyond the window
    depth[20:30, 20:40] = 0.6  # the tool: 200 pixels
    depth[2:4, 50:52] = 0.6  # a speck: 4 pixels
    P = view_points(depth, INTRINSICS)
    assert len(P) == 200
    np.testing.assert_allclose(P[:, 2], 0.6)
    u, v = 20, 20  # the first pixel back-projects through the pinhole
    np.testing.assert_allclose(P[0], [(u - 32) * 0.6 / 200, (v - 24) * 0.6 / 200, 0.6])


def test_fuse_moves_each_view_into_g_drops_the_hand_and_thins():
    X_GC = np.eye(4)
    X_GC[:3, 3] = [0.0, 0.0, -0.5]  # the camera 0.5 m behind G's origin
    z = np.linspace(0.4, 0.7, 301)  # 1 mm apart along the optical axis
    points_C = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
    P = fuse([points_C, points_C], [X_GC, X_GC])
    assert P[:, 2].min() > Z_MIN_G and P[:, 2].max() <= 0.2 + 1e-9
    assert len(P) == len(thin(P, VOXEL)) and 0.18 / VOXEL <= len(P) <= 0.2 / VOXEL + 1
    assert len(fuse([], [])) == 0
