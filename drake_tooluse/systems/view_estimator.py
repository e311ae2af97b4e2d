"""What the head camera's estimators share: one view measured per capture, on a fixed schedule.

`systems.camera.ToolLengthEstimator` (a straight tool) and `systems.hook_estimator.HookEstimator`
(a hook) differ only in how they measure a view and what they sum up; `ViewByViewEstimator`
holds the rest: the colour and depth image inputs, the capture schedule, the measurement so
far in the abstract state, and the outputs computed from it.
"""

from __future__ import annotations

import copy
import math

from pydrake.common.value import AbstractValue
from pydrake.systems.sensors import CameraInfo, ImageDepth32F, ImageRgba8U

from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.validation import check_in_range


class ViewByViewEstimator:
    """A LeafSystem mixin: measures one camera view per capture.

    At the capture times t_k = first_capture + k * capture_period (k = 0 .. len(views) - 1,
    when the arm holds view k still) it measures view k from the current images and appends
    the result to the measurement in its abstract state (a copy with a `views` list); later
    times do nothing. The outputs are computed from that state, so they hold between captures.

    A system using it (`class Estimator(ViewByViewEstimator, LeafSystem)`) documents its own
    ports and declares them with `_set_views` then `_declare_captures`: the inputs
    `color_image` (ImageRgba8U) and `depth_image` (ImageDepth32F, m), then its summary
    output and `measurement` (the state's value).
    """

    def _set_views(self, info: CameraInfo, views, spec_name: str) -> None:
        """The camera's intrinsics and the views in capture order (`spec_name`: what each
        view is, for the error when there is none)."""
        self._info = info
        self._views = list(views)
        if not self._views:
            raise ValueError(f"views is empty; give at least one {spec_name}")

    def _declare_captures(
        self,
        first_capture: float,
        capture_period: float,
        *,
        empty,
        measure_view,
        summary: tuple,
    ) -> None:
        """Declares the image inputs, the state (`empty()`: the measurement before any
        capture), the captures (`measure_view(color, depth, info, view)` gives a view's result)
        and the outputs: `summary` = (name, size, a function of the measurement giving that
        many values), then `measurement`. Neither function may hold the system (see
        `systems.lifetime`)."""
        check_in_range(first_capture, 0.0, math.inf, "first_capture", unit="s")
        check_in_range(capture_period, 1e-3, math.inf, "capture_period", unit="s")
        w, h = self._info.width(), self._info.height()
        self._color = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U(w, h))
        )
        self._depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(w, h))
        )
        self._measure_view = measure_view
        self._state = self.DeclareAbstractState(AbstractValue.Make(empty()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            capture_period, first_capture, weak_method(self._capture)
        )
        state = {self.abstract_state_ticket(self._state)}
        name, size, self._summarize = summary
        self.DeclareVectorOutputPort(
            name, size, weak_method(self._calc_summary), prerequisites_of_calc=state
        )
        self.DeclareAbstractOutputPort(
            "measurement",
            lambda: AbstractValue.Make(empty()),
            weak_method(self._calc_measurement),
            prerequisites_of_calc=state,
        )

    @property
    def views(self) -> list:
        return list(self._views)

    def _capture(self, context, state):
        measurement = context.get_abstract_state(self._state).get_value()
        k = len(measurement.views)
        if k >= len(self._views):
            return
        color = self._color.Eval(context).data
        depth = self._depth.Eval(context).data
        result = self._measure_view(color, depth, self._info, self._views[k])
        updated = copy.copy(measurement)
        updated.views = measurement.views + [result]
        state.get_mutable_abstract_state(self._state).set_value(updated)

    def _calc_summary(self, context, output):
        output.SetFromVector(self._summarize(context.get_abstract_state(self._state).get_value()))

    def _calc_measurement(self, context, output):
        output.set_value(context.get_abstract_state(self._state).get_value())
