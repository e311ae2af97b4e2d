"""Where the box stands on the table, from one depth image: pure functions, no Drake.

depth image → each pixel back-projected to the world W (the camera pose X_WC is the robot's own
forward kinematics) → the points above the table and below the tool's tip → the highest flat
layer of them, the box's top face → OpenCV's minimum-area rectangle around it, whose centre is
the box's centre in x, y (the rectangle, not the mean of the points: a camera looking at the face
at a slant samples its near half more densely than its far half).

Frames: C = the camera's optical frame (+z out of the lens, +x right, +y down); pixel (u, v), u
to the right, v down. SI units. `info` has Drake's `CameraInfo` interface.
"""

from __future__ import annotations

import dataclasses as dc

import cv2
import numpy as np

# Points this far above the table and up to this height belong to objects on it, not to the
# table or to the tool held above it (m): the box is 4 cm tall, the tool's tip starts 10 cm up.
OBJECT_BAND = (0.01, 0.08)
# Points within this of the highest point of the band are on the top face (m).
TOP_FACE_TOLERANCE = 0.004
MIN_TOP_FACE_POINTS = 50


@dc.dataclass
class BoxMeasurement:
    """The box's centre in x, y (m, in W), its top face's height (m) and the top face's
    rectangle (centre x, y, sides (m), angle (deg), as cv2.minAreaRect gives it)."""

    p_WB_xy: np.ndarray
    top_z: float
    points: int
    rectangle: tuple


def back_project(depth: np.ndarray, info, X_WC) -> np.ndarray:
    """p_WP of every pixel with a finite, positive depth, (N, 3)."""
    z = np.asarray(depth, float).reshape(info.height(), info.width())
    v, u = np.nonzero(np.isfinite(z) & (z > 0))
    z = z[v, u]
    p_CP = np.column_stack(
        [(u - info.center_x()) * z / info.focal_x(), (v - info.center_y()) * z / info.focal_y(), z]
    )
    R, p = X_WC.rotation().matrix(), X_WC.translation()
    return p_CP @ R.T + p


def measure_box(depth: np.ndarray, info, X_WC, table_top_z: float) -> BoxMeasurement:
    """The box on the table in a depth image taken from X_WC; a ValueError naming what is
    missing if no box's top face is in view."""
    p_WP = back_project(depth, info, X_WC)
    height = p_WP[:, 2] - table_top_z
    on_table = p_WP[(height > OBJECT_BAND[0]) & (height < OBJECT_BAND[1])]
    if len(on_table) < MIN_TOP_FACE_POINTS:
        raise ValueError(
            f"no box in the camera's view: {len(on_table)} points between "
            f"{OBJECT_BAND[0]} and {OBJECT_BAND[1]} m above the table (need "
            f"{MIN_TOP_FACE_POINTS})"
        )
    top_z = float(on_table[:, 2].max())
    top = on_table[on_table[:, 2] >= top_z - TOP_FACE_TOLERANCE]
    if len(top) < MIN_TOP_FACE_POINTS:
        raise ValueError(
            f"the box's top face is not in the camera's view: {len(top)} points on it (need "
            f"{MIN_TOP_FACE_POINTS})"
        )
    rectangle = cv2.minAreaRect(top[:, :2].astype(np.float32))
    return BoxMeasurement(np.array(rectangle[0], float), top_z, len(top), rectangle)
