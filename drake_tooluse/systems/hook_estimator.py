"""The hook estimator: the head camera's views of a held hook measured with
`perception.hook`, one view per capture (the hook's counterpart of
`systems.camera.ToolLengthEstimator`, with the same capture schedule). The handle length and
the grasp come from the views' points with the arm's kinematics
(`builders.hook_measurement.combine_views`), so this system gives the views' results."""

from __future__ import annotations

import copy
import math

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import CameraInfo, ImageDepth32F, ImageRgba8U

from drake_tooluse.perception.hook import HookMeasurement, measure_view_of_kind
from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.validation import check_in_range


class HookEstimator(LeafSystem):
    """Measures a held hook from the head camera's images, one view per capture.

    At the capture times t_k = first_capture + k * capture_period (k = 0 .. len(views) - 1,
    when the arm holds view k still) it measures view k from the current images
    (`measure_hook_view` or `measure_grip_view`, by the view's kind) and keeps the result in
    its abstract state; later times do nothing. The outputs are computed from that state, so
    they hold between captures.

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
        self._info = info
        self._views = list(views)
        if not self._views:
            raise ValueError("views is empty; give at least one HookViewSpec")
        check_in_range(first_capture, 0.0, math.inf, "first_capture", unit="s")
        check_in_range(capture_period, 1e-3, math.inf, "capture_period", unit="s")
        w, h = info.width(), info.height()
        self._color = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U(w, h))
        )
        self._depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(w, h))
        )
        self._state = self.DeclareAbstractState(AbstractValue.Make(HookMeasurement()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            capture_period, first_capture, weak_method(self._capture)
        )
        state = {self.abstract_state_ticket(self._state)}
        self.DeclareVectorOutputPort(
            "hook", 2, weak_method(self._calc_hook), prerequisites_of_calc=state
        )
        self.DeclareAbstractOutputPort(
            "measurement",
            lambda: AbstractValue.Make(HookMeasurement()),
            weak_method(self._calc_measurement),
            prerequisites_of_calc=state,
        )

    def _capture(self, context, state):
        measurement = context.get_abstract_state(self._state).get_value()
        k = len(measurement.views)
        if k >= len(self._views):
            return
        color = self._color.Eval(context).data
        depth = self._depth.Eval(context).data
        result = measure_view_of_kind(color, depth, self._info, self._views[k])
        updated = copy.copy(measurement)
        updated.views = measurement.views + [result]
        state.get_mutable_abstract_state(self._state).set_value(updated)

    def _calc_hook(self, context, output):
        measurement = context.get_abstract_state(self._state).get_value()
        output.SetFromVector([measurement.mean("hook_length"), measurement.mean("angle")])

    def _calc_measurement(self, context, output):
        output.set_value(context.get_abstract_state(self._state).get_value())
