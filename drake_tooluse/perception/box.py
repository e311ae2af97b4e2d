"""Where the box stands on the table, from one depth image: pure functions, no Drake.

depth image → each pixel back-projected to the world W (the camera pose X_WC is the robot's own
forward kinematics) → the points above the table and below `max_height` (the caller's: under
the tool's tip) → the highest flat layer of them, the box's top face → OpenCV's minimum-area
rectangle around it, whose centre is the box's centre in x, y (the rectangle, not the mean of
the points: a camera looking at the face at a slant samples its near half more densely than its
far half), its sides checked against the box's.

Frames: C = the camera's optical frame (+z out of the lens, +x right, +y down); pixel (u, v), u
to the right, v down. SI units. `info` has Drake's `CameraInfo` interface (`CameraIntrinsics`).
"""

from __future__ import annotations

import dataclasses as dc

import cv2
import numpy as np

from drake_tooluse.perception.markers import CameraIntrinsics, back_project_pixels

# Points at least this far above the table belong to objects on it, not to the table (m).
MIN_HEIGHT = 0.01
# Points within this of the highest point of the band are on the top face (m).
TOP_FACE_TOLERANCE = 0.004
MIN_TOP_FACE_POINTS = 50
# The top face's rectangle may differ from the box's sides by this much (m): more is not the
# box's whole top face (a taller object cut by `max_height`, the face partly hidden).
SIDE_TOLERANCE = 0.004


@dc.dataclass
class BoxMeasurement:
    """The box's centre in x, y (m, in W), its top face's height (m), the number of points on
    the top face and its rectangle (centre x, y, sides (m), angle (deg), as cv2.minAreaRect
    gives it)."""

    p_WB_xy: np.ndarray
    top_z: float
    points: int
    rectangle: tuple


def back_project(depth: np.ndarray, info: CameraIntrinsics, X_WC) -> np.ndarray:
    """p_WP of every pixel with a finite, positive depth, (N, 3)."""
    z = np.asarray(depth, float).reshape(info.height(), info.width())
    v, u = np.nonzero(np.isfinite(z) & (z > 0))
    p_CP = back_project_pixels(u, v, z[v, u], info)
    return p_CP @ X_WC.rotation().matrix().T + X_WC.translation()


def measure_box(
    depth: np.ndarray,
    info: CameraIntrinsics,
    X_WC,
    table_top_z: float,
    max_height: float,
    box_size_xy,
) -> BoxMeasurement:
    """The box (sides `box_size_xy`, m) on the table in a depth image taken from X_WC, looking
    at points up to `max_height` above the table; a ValueError naming what is wrong if no whole
    top face of that size is in view."""
    p_WP = back_project(depth, info, X_WC)
    height = p_WP[:, 2] - table_top_z
    on_table = p_WP[(height > MIN_HEIGHT) & (height < max_height)]
    if len(on_table) < MIN_TOP_FACE_POINTS:
        raise ValueError(
            f"no box in the camera's view: {len(on_table)} points between {MIN_HEIGHT} and "
            f"{max_height:.3f} m above the table (need {MIN_TOP_FACE_POINTS})"
        )
    top_z = float(on_table[:, 2].max())
    top = on_table[on_table[:, 2] >= top_z - TOP_FACE_TOLERANCE]
    if len(top) < MIN_TOP_FACE_POINTS:
        raise ValueError(
            f"the box's top face is not in the camera's view: {len(top)} points on it (need "
            f"{MIN_TOP_FACE_POINTS})"
        )
    rectangle = cv2.minAreaRect(top[:, :2].astype(np.float32))
    sides, expected = np.sort(rectangle[1]), np.sort(np.asarray(box_size_xy, float))
    if np.any(np.abs(sides - expected) > SIDE_TOLERANCE):
        raise ValueError(
            f"the top face found is {sides[0]:.3f} x {sides[1]:.3f} m, the box's is "
            f"{expected[0]:.3f} x {expected[1]:.3f} m (allowed ±{SIDE_TOLERANCE} m): not the "
            "whole box in view"
        )
    return BoxMeasurement(np.array(rectangle[0], float), top_z, len(top), rectangle)
