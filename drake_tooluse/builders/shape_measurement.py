"""Measuring a held tool the robot was not told about: its family, its shape and the grasp,
and so its working frames in the gripper frame G, from the head camera's depth views.

The hook's measurement diagram (`builders.hook_measurement`: the same five views, the hook
views square to the gripper's x–z plane, where every generated tool bends) with a
`ShapeEstimator` in place of the `HookEstimator`, and an optional depth noise:

```
TrajectorySource ─[q*, v*]─► plant (PD) ─► SceneGraph ─► RgbdSensor (head_camera)
 hold view 0, move to 1, …   true tool                    │color       │depth
                                                [ColorImageNoise]  [DepthImageNoise]
                                                          └─► ShapeEstimator
                                                               ├─► points
                                                               └─► measurement
```

Each view's points go into G with the arm's joint angles and the head camera's calibration at
the capture (as the hook's), are fused, and every family of `robot.tool_generator` is fitted
to the cloud (`robot.tool_fit.measure_shape_from_points`). No marker band is used: the
tool may carry none. Where the family is known and has bands (a straight rod, a hook), the
marker measurements (`measure_tool`, `measure_hook`) are the reference this is compared with.
"""

from __future__ import annotations

import dataclasses as dc
import math
import time

import numpy as np

from drake_tooluse.builders.hook_measurement import HOOK_VIEWS
from drake_tooluse.builders.measurement import (
    MeasurementDiagram,
    MeasurementPlan,
    build_camera_measurement,
    capture_views,
    plan_measurement,
)
from drake_tooluse.perception.tool_shape import ANNOTATION_COLORS, annotate_shape_view, fuse
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import GRASP
from drake_tooluse.robot.tool_fit import OTHER, ShapeFit, measure_shape_from_points
from drake_tooluse.systems.camera import camera_info
from drake_tooluse.systems.shape_estimator import ShapeEstimator, ShapeViews
from drake_tooluse.world.scenario import Scenario

SHAPE_VIEWS = HOOK_VIEWS


def plan_shape_measurement(scenario: Scenario) -> MeasurementPlan:
    """The gripper IK of the views and of the moves between them: it depends on the robot
    and the camera, not on the tool, so one plan serves every tool."""
    return plan_measurement(scenario, SHAPE_VIEWS)


def build_shape_measurement_diagram(
    scenario: Scenario, plan: MeasurementPlan | None = None, **options
) -> MeasurementDiagram:
    """World (the true tool) + joint schedule through the views + head camera [+ colour and
    depth noise] + ShapeEstimator. Exported outputs: `points`, `measurement`, `color_image`,
    `depth_image`. `options`: `noise_sigma`, `depth_noise_sigma`, `lighting`,
    `scene_objects`, `seed`, `move_time`, `settle_time`, as `build_camera_measurement`'s."""
    if not scenario.tool.attached:
        raise ValueError("the shape measurement needs a tool in the hand; the scenario has none")

    def estimator(planned, first_capture, capture_period):
        names = [pv.view.name for pv in planned]
        return ShapeEstimator(camera_info(scenario.camera), names, first_capture, capture_period)

    return build_camera_measurement(
        scenario,
        plan,
        estimator,
        name="shape_measurement",
        estimator_name="shape_estimator",
        views=SHAPE_VIEWS,
        **options,
    )


def true_frames_G(scenario: Scenario) -> dict:
    """The scenario's tool's named frames' origins in G (m), the grasp point left out (a
    handle held deeper and one held less deep look the same; module `perception.tool_shape`):
    what the measurement is judged on, never read by the robot."""
    tool = scenario.tool
    offset = np.array([tool.grasp_offset_across, 0.0, tool.grasp_offset_along])
    return {
        name: np.array(X.translation) + offset
        for name, X in tool.description().frames().items()
        if name != GRASP
    }


def true_family(scenario: Scenario) -> str:
    """The family of the scenario's tool (a generated tool's, or "hook" / "straight")."""
    tool = scenario.tool
    return tool.family if tool.kind == "generated" else tool.kind


@dc.dataclass
class ShapeMeasurementResult:
    """A tool measured over the views: the fit (`shape`: family, parameters, grasp, every
    family's cost), the fused cloud's size, and for comparison the truth: its family and each
    working frame's position error (m), for the frames that the truth and the fit both name.
    Every frame keeps the handle's orientation in both, so no orientation error is possible:
    the grasp holds the handle along G's z (`robot.model.tool_grasp_pose`)."""

    shape: ShapeFit
    views: list  # ShapeView per view, in capture order
    truth_family: str
    frame_errors: dict  # frame -> m
    capture_time: float  # s, wall: plan (if not given), build, simulate
    fit_time: float  # s, wall
    images: list | None = None  # [(color RGBA, depth)] per view when asked for
    image_files: list = dc.field(default_factory=list)

    # What the annotated views' colours mean (the demo's legend).
    annotation_colors = ANNOTATION_COLORS

    @property
    def family(self) -> str:
        return self.shape.family

    @property
    def family_right(self) -> bool:
        return self.shape.family == self.truth_family

    @property
    def max_frame_error(self) -> float:
        return max(self.frame_errors.values(), default=math.nan)

    @property
    def dropped(self) -> list[dict]:
        return [{"view": v.view, "reason": v.reason} for v in self.views if not v.accepted]

    def summary_lines(self) -> list[str]:
        """The measurement in words (a figure's caption)."""
        accepted = [v.view for v in self.views if v.accepted]
        best = self.shape.best
        lines = [
            f"views: {', '.join(accepted)};",
            f"family: {self.family} (true, unknown to the robot: {self.truth_family});",
            f"{self.shape.points} points, {best.rms * 1e3:.2f} mm RMS from the fitted {best.family};",
        ]
        lines += [
            f"{n}: {e * 1e3:.2f} mm from the true frame" for n, e in self.frame_errors.items()
        ]
        return lines

    def as_dict(self) -> dict:
        return {
            **self.shape.as_dict(),
            "truth_family": self.truth_family,
            "family_right": self.family_right,
            "frame_errors_m": self.frame_errors,
            "max_frame_error_m": self.max_frame_error,
            "dropped": self.dropped,
            "capture_time_s": self.capture_time,
            "fit_time_s": self.fit_time,
            "image_files": [str(p) for p in self.image_files],
        }


def measure_shape(
    scenario: Scenario,
    *,
    keep_images: bool = False,
    save_images_dir=None,
    seed: int = 0,
    families=None,
    **options,
) -> ShapeMeasurementResult:
    """Moves the held tool through the views in the dynamic simulation and measures its shape.

    Args:
        scenario: the world; its tool (any kind) is the truth the camera sees (the robot
            never reads it). `scenario.camera` sets the intrinsics.
        keep_images: keep each view's (colour, depth) images in the result.
        save_images_dir: if given, each view is written there, the tool's pixels tinted
            (`annotate_shape_view`), as `measure_<view>.png`, all of them as one set
            (`check_images_dir`).
        seed: the noises' and the fit's.
        families: the families fitted (default every one; a tool whose family is known
            from an earlier measurement is fitted as that family alone: its fit took 1 s
            where every family's took 7-15 s, on two busy cores).
        options: `plan` (from `plan_shape_measurement`, to reuse), `noise_sigma`,
            `depth_noise_sigma`, `lighting`, `scene_objects`, `move_time`, `settle_time`, as
            `build_camera_measurement`'s.

    Raises ValueError if the scenario holds no tool or the views hold too few of its points.
    """
    run = capture_views(
        lambda: build_shape_measurement_diagram(scenario, seed=seed, **options),
        lambda color, view: annotate_shape_view(color, view.pixels, view.view),
        keep_images=keep_images,
        save_images_dir=save_images_dir,
    )
    views: ShapeViews = run.measurement
    cloud = fuse([v.points_C for v in views.views], [X.GetAsMatrix4() for X in run.X_GC])
    start = time.perf_counter()
    shape = measure_shape_from_points(cloud, families, seed=seed)
    fit_time = time.perf_counter() - start
    truth = true_frames_G(scenario)
    fitted = shape.best.frames_G()
    errors = {n: float(np.linalg.norm(fitted[n] - p)) for n, p in truth.items() if n in fitted}
    return ShapeMeasurementResult(
        shape,
        list(views.views),
        true_family(scenario),
        errors,
        run.wall_time,
        fit_time,
        run.images if keep_images else None,
        run.image_files,
    )


def shape_belief(result: ShapeMeasurementResult) -> RobotBelief:
    """What the robot believes after a measurement: the fitted tool held at the fitted grasp.
    Raises ValueError where the tool is of no family (OTHER), naming its fit."""
    best = result.shape.best
    if result.family == OTHER:
        raise ValueError(
            f"the tool in the hand fits no family: the best, {best.family}, leaves "
            f"{best.rms * 1000:.1f} mm RMS between the views' points and its surface"
        )
    return RobotBelief(best.tool, (best.grasp_across, best.grasp_along))


def measure_shape_belief(scenario: Scenario, **measure_kwargs):
    """Measures the scenario's (true) tool (`measure_shape`): (the belief, `shape_belief`;
    the result)."""
    result = measure_shape(scenario, **measure_kwargs)
    return shape_belief(result), result
