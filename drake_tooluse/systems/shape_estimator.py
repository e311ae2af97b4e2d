"""The shape estimator: the head camera's depth views of a held tool of unknown shape, each
turned into the tool's points in the camera frame (`perception.tool_shape.view_points`), one
view per capture (a `systems.view_estimator.ViewByViewEstimator`, as the straight tool's and
the hook's estimators). The views are fused in the gripper frame with the arm's kinematics at
each capture and the families fitted to the cloud by `builders.shape_measurement`, so this
system gives the views' points."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import CameraInfo

from drake_tooluse.perception.tool_shape import MIN_BLOB_PIXELS, view_points
from drake_tooluse.systems.view_estimator import ViewByViewEstimator


@dc.dataclass
class ShapeView:
    """One view's points within the depth window (the tool, and the hand that `fuse` drops),
    (n, 3) in the camera frame C (m), and their pixels (n, 2: u, v)."""

    view: str
    points_C: np.ndarray
    pixels: np.ndarray

    def pixel_points(self) -> list:
        """The corners of the pixels' bounding box (none where no point was seen)."""
        if len(self.pixels) == 0:
            return []
        return [self.pixels.min(axis=0).tolist(), self.pixels.max(axis=0).tolist()]

    @property
    def accepted(self) -> bool:
        return len(self.points_C) >= MIN_BLOB_PIXELS

    @property
    def reason(self) -> str:
        return "" if self.accepted else f"{len(self.points_C)} points in the depth window"


@dc.dataclass
class ShapeViews:
    """Every captured view's points, in capture order."""

    views: list = dc.field(default_factory=list)

    def count(self) -> int:
        return sum(len(v.points_C) for v in self.views)


def _measure_view(color, depth, info: CameraInfo, view: str) -> ShapeView:
    fx, fy, cx, cy = info.focal_x(), info.focal_y(), info.center_x(), info.center_y()
    P = view_points(depth, (fx, fy, cx, cy))
    pixels = np.stack([fx * P[:, 0] / P[:, 2] + cx, fy * P[:, 1] / P[:, 2] + cy], axis=1)
    return ShapeView(view, P, pixels)


class ShapeEstimator(ViewByViewEstimator, LeafSystem):
    """Takes the held tool's points from the head camera's depth image, one view per capture,
    on the schedule of `ViewByViewEstimator` (the colour image is not used: the shape is
    measured from depth alone, so neither colour noise nor the light changes it).

    .. pydrake_system::

        name: ShapeEstimator
        input_ports:
        - color_image
        - depth_image
        output_ports:
        - points
        - measurement

    - color_image: ImageRgba8U from the RgbdSensor (or ColorImageNoise); not read.
    - depth_image: ImageDepth32F (m) from the RgbdSensor's `depth_image_32f` (or
      DepthImageNoise).
    - points: [the number of points in the depth window in the views captured so far].
    - measurement: AbstractValue[ShapeViews], every captured view's points.

    Args:
        info: the camera's intrinsics (`camera_info(scenario.camera)`).
        views: the views' names in capture order.
        first_capture, capture_period: capture schedule (s).
    """

    def __init__(self, info: CameraInfo, views, first_capture: float, capture_period: float):
        super().__init__()
        self._set_views(info, views, "view name")
        self._declare_captures(
            first_capture,
            capture_period,
            empty=ShapeViews,
            measure_view=_measure_view,
            summary=("points", 1, lambda m: [m.count()]),
        )
