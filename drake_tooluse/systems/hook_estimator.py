"""The hook estimator: the head camera's views of a held hook measured with
`perception.hook`, one view per capture (the hook's counterpart of
`systems.camera.ToolLengthEstimator`, with the same capture schedule: both are
`systems.view_estimator.ViewByViewEstimator`s). The handle length and the grasp come from the
views' points with the arm's kinematics (`builders.hook_measurement.combine_views`), so this
system gives the views' results."""

from __future__ import annotations

from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import CameraInfo

from drake_tooluse.perception.hook import HookMeasurement, measure_view_of_kind
from drake_tooluse.systems.view_estimator import ViewByViewEstimator


class HookEstimator(ViewByViewEstimator, LeafSystem):
    """Measures a held hook from the head camera's images, one view per capture
    (`measure_hook_view` or `measure_grip_view`, by the view's kind), on the schedule of
    `ViewByViewEstimator`.

    .. pydrake_system::

        name: HookEstimator
        input_ports:
        - color_image
        - depth_image
        output_ports:
        - hook
        - measurement

    - color_image: ImageRgba8U from the RgbdSensor (or ColorImageNoise).
    - depth_image: ImageDepth32F (m) from the RgbdSensor's `depth_image_32f`.
    - hook: [hook length (m), angle (deg)], each the mean over the accepted hook views
      captured so far; NaN until one is accepted.
    - measurement: AbstractValue[HookMeasurement], every captured view's result.

    Args:
        info: the camera's intrinsics (`camera_info(scenario.camera)`).
        views: the HookViewSpecs in capture order (each says its kind).
        first_capture, capture_period: capture schedule (s).
    """

    def __init__(self, info: CameraInfo, views, first_capture: float, capture_period: float):
        super().__init__()
        self._set_views(info, views, "HookViewSpec")
        self._declare_captures(
            first_capture,
            capture_period,
            empty=HookMeasurement,
            measure_view=measure_view_of_kind,
            summary=("hook", 2, lambda m: [m.mean("hook_length"), m.mean("angle")]),
        )
