"""Measuring a held hook with the head camera: handle length, hook length and angle, and where
the hand holds it along the handle.

The same diagram as the straight tool's (`builders.measurement`): the world with the true hook,
a joint schedule through the views, the head camera [+ colour noise], and a `HookEstimator`
in place of the `ToolLengthEstimator`:

```
TrajectorySource ─[q*, v*]─► plant (PD) ─► SceneGraph ─► RgbdSensor (head_camera)
 hold view 0, move to 1,     true hook                    │color       │depth
 hold, move to 2, hold                          [ColorImageNoise]      │
                                                          └─► HookEstimator
                                                               ├─► hook
                                                               └─► measurement
```

Two kinds of view. The straight tool's views close the fingers across the tool in the image,
which turns the hook's plane (the gripper's x–z plane) edge-on to the camera: the hook then
points at the camera and hides the corner band. So the hook views close the fingers along the
optical axis: the hook lies in a plane square to it and its angle is seen whole. There,
though, the near finger hides the grip band once the hand holds the hook deeper than the
nominal grasp; the grip views (the straight tool's first two, fingers across) see the grip
band between the fingers at any grasp. Each view's points go into the gripper frame G with
the arm's joint angles and the head camera's calibration at the capture (as the straight
tool's grasp estimate): the grasp is the grip band's outer end's z in G (the grip views),
the handle length the corner's z in G minus the grasp (every hook view), the hook
length and angle the hook views' means.

| view | kind | grip p_CG (m) | tool axis in C | the hook |
| --- | --- | --- | --- | --- |
| grip_right | grip | (0.15, 0.20, 0.65) | -x | towards or away from the camera |
| grip_bottom | grip | (0.15, 0.30, 0.65) | -y | towards or away from the camera |
| hook_bottom | hook | (0.15, 0.30, 0.65) | -y | right |
| hook_up_left | hook | (0.15, 0.25, 0.65) | (-0.87, -0.5, 0) | up and right |
| hook_right | hook | (0.15, 0.20, 0.65) | -x | up the image |

Each hook view holds the longest handle (0.35 m) with the longest hook (0.08 m) at any angle
in view.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from drake_tooluse.builders.measurement import (
    MEASUREMENT_VIEWS,
    MeasurementDiagram,
    MeasurementPlan,
    MeasurementView,
    build_camera_measurement,
    capture_views,
    plan_measurement,
)
from drake_tooluse.perception.hook import HookMeasurement, HookViewSpec, annotate_hook_view
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import (
    HOOK_ANGLE_RANGE,
    HOOK_HANDLE_RANGE,
    HOOK_LENGTH_RANGE,
    HookTool,
)
from drake_tooluse.systems.camera import camera_info
from drake_tooluse.systems.hook_estimator import HookEstimator
from drake_tooluse.validation import check_one_of
from drake_tooluse.world.scenario import Scenario

QUANTITIES = ("handle_length", "hook_length", "angle", "grasp_along")


@dc.dataclass(frozen=True)
class HookView(MeasurementView):
    """A measurement pose for the hook: as `MeasurementView`, but the fingers close along the
    optical axis (away from the camera first, then towards it), so the gripper's x–z plane,
    where the hook lies, is square to it."""

    def finger_axes_C(self) -> list[np.ndarray]:
        z = np.asarray(self.tool_axis_C, float)
        z = z / np.linalg.norm(z)
        toward = np.array([0.0, 0.0, 1.0]) - z[2] * z
        toward /= np.linalg.norm(toward)
        return [toward, -toward]


HOOK_VIEWS = (
    MEASUREMENT_VIEWS[0],
    MEASUREMENT_VIEWS[1],
    HookView("hook_bottom", (0.15, 0.30, 0.65), (0.0, -1.0, 0.0)),
    HookView("hook_up_left", (0.15, 0.25, 0.65), (-math.sqrt(3) / 2, -0.5, 0.0)),
    HookView("hook_right", (0.15, 0.20, 0.65), (-1.0, 0.0, 0.0)),
)


def hook_view_spec(scenario: Scenario, view: MeasurementView) -> HookViewSpec:
    """What the estimator is told of a view: the grip's pixel and depth, the commanded tool
    axis in C and its image direction at the grip, and the view's kind (a `HookView`: "hook";
    any other: "grip")."""
    info = camera_info(scenario.camera)

    def pixel(p_C):
        return np.array(
            [
                info.center_x() + info.focal_x() * p_C[0] / p_C[2],
                info.center_y() + info.focal_y() * p_C[1] / p_C[2],
            ]
        )

    p_CG = np.asarray(view.p_CG, float)
    grip = pixel(p_CG)
    axis = pixel(p_CG + 0.01 * np.asarray(view.tool_axis_C, float)) - grip
    axis_C = np.asarray(view.tool_axis_C, float)
    return HookViewSpec(
        view.name,
        tuple(grip),
        float(p_CG[2]),
        tuple(axis_C / np.linalg.norm(axis_C)),
        tuple(axis / np.linalg.norm(axis)),
        "hook" if isinstance(view, HookView) else "grip",
    )


def plan_hook_measurement(scenario: Scenario, views=HOOK_VIEWS) -> MeasurementPlan:
    """The gripper IK of each hook view and of the moves between them (`plan_measurement`);
    it depends on the robot and the camera, not on the tool, so one plan serves every hook."""
    return plan_measurement(scenario, views)


def build_hook_measurement_diagram(
    scenario: Scenario, plan: MeasurementPlan | None = None, **options
) -> MeasurementDiagram:
    """World (true hook) + joint schedule through the views + head camera [+ colour noise] +
    HookEstimator. Exported outputs: `hook`, `measurement`, `color_image`, `depth_image`.
    `plan`: from `plan_hook_measurement`, to reuse; `options`: `noise_sigma`, `lighting`,
    `scene_objects`, `seed`, `move_time`, `settle_time`, as `build_camera_measurement`'s."""
    check_hook_scenario(scenario)

    def estimator(planned, first_capture, capture_period):
        specs = [hook_view_spec(scenario, pv.view) for pv in planned]
        info = camera_info(scenario.camera)
        return HookEstimator(info, specs, first_capture, capture_period)

    return build_camera_measurement(
        scenario,
        plan,
        estimator,
        name="hook_measurement",
        estimator_name="hook_estimator",
        views=HOOK_VIEWS,
        **options,
    )


def check_hook_scenario(scenario: Scenario) -> None:
    """The scenario's tool must be an attached hook described by its `ToolConfig`."""
    tool = scenario.tool
    if not tool.attached or tool.kind != "hook" or tool.model:
        what = (
            "no tool"
            if not tool.attached
            else (f"tool.model={tool.model!r}" if tool.model else f"tool.kind={tool.kind!r}")
        )
        raise ValueError(
            f"the hook measurement needs a hook in the hand (tool.kind='hook', attached, no "
            f"tool.model); the scenario has {what}"
        )


def combine_views(views, X_GC) -> dict:
    """The four quantities and their spreads from the views' results (`HookViewMeasurement`)
    and each view's camera pose in the gripper frame at its capture, X_GC (RigidTransform):
    the grasp along the tool (G's z of the grip band's outer end, mean over the grip views:
    in a hook view the near finger can hide a few mm of the band unnoticed), the handle
    length (G's z of the corner minus that grasp, mean over the hook views), the hook length
    and angle (means over the hook views). A tool welded in the hand runs along G's z
    (`robot.model.tool_grasp_pose`). NaN where no view gives one."""

    def z_G(point, X):
        return float((X @ np.asarray(point, float))[2])

    along = np.array(
        [z_G(v.p_CA, X) for v, X in zip(views, X_GC) if v.accepted and v.kind == "grip" and v.p_CA]
    )
    corner = np.array([z_G(v.p_CK, X) for v, X in zip(views, X_GC) if v.accepted and v.p_CK])
    grasp = float(np.mean(along)) if along.size else math.nan
    hook = HookMeasurement(views=list(views))
    return {
        "handle_length": float(np.mean(corner)) - grasp if corner.size else math.nan,
        "hook_length": hook.mean("hook_length"),
        "angle": hook.mean("angle"),
        "grasp_along": grasp,
        "spread": {
            "handle_length": float(np.ptp(corner)) if corner.size else math.nan,
            "hook_length": hook.spread("hook_length"),
            "angle": hook.spread("angle"),
            "grasp_along": float(np.ptp(along)) if along.size else math.nan,
        },
    }


@dc.dataclass
class HookMeasurementResult:
    """A hook measured over the views: each quantity the mean over the accepted views and its
    spread (largest minus smallest view); NaN if no view was accepted. Lengths in m, the angle
    in degrees, `grasp_along` as the scenario's `tool.grasp_offset_along` (m along the tool
    from the gripper frame's origin). `truth` holds the scenario's values, for comparison."""

    handle_length: float
    hook_length: float
    angle: float
    grasp_along: float
    spread: dict  # quantity -> m or deg; the handle's: of the corner's z in G
    views: list  # HookViewMeasurement per view, in capture order
    truth: dict  # quantity -> the scenario's value
    wall_time: float  # s: plan (if not given), build, simulate, estimate
    sim_time: float  # s, simulated
    images: list | None = None  # [(color RGBA, depth)] per view when asked for
    image_files: list = dc.field(default_factory=list)

    @property
    def dropped(self) -> list[dict]:
        return [{"view": v.view, "reason": v.reason} for v in self.views if not v.accepted]

    def value(self, quantity: str) -> float:
        return getattr(self, check_one_of(quantity, QUANTITIES, "quantity"))

    def error(self, quantity: str) -> float:
        """Measured minus true (m or deg)."""
        return self.value(quantity) - self.truth[quantity]

    def measured_dimensions(self) -> dict[str, float]:
        """What was measured of the hook, named as `HookTool.dimensions()` names it (before
        `measured_hook` takes a value just past its range at the range's end)."""
        return {
            "handle_length_m": self.handle_length,
            "hook_length_m": self.hook_length,
            "angle_deg": self.angle,
        }

    def summary_lines(self) -> list[str]:
        """The measurement in words, quantity by quantity (a figure's caption)."""
        accepted = [v.view for v in self.views if v.accepted]
        if not accepted:
            return ["no view was accepted: " + "; ".join(d["reason"] for d in self.dropped)]
        lines = [f"views: {', '.join(accepted)};", "measured (true, unknown to the robot):"]
        for q in QUANTITIES:
            unit, scale = ("deg", 1.0) if q == "angle" else ("mm", 1000.0)
            value, true = self.value(q) * scale, self.truth[q] * scale
            lines.append(f"{q.replace('_', ' ')}: {value:.1f} {unit} ({true:.1f})")
        return lines

    def as_dict(self) -> dict:
        def f(x):
            return None if not math.isfinite(x) else float(x)

        units = {"handle_length": "m", "hook_length": "m", "angle": "deg", "grasp_along": "m"}
        return {
            **{f"{q}_{units[q]}": f(self.value(q)) for q in QUANTITIES},
            "spread": {f"{q}_{units[q]}": f(self.spread[q]) for q in QUANTITIES},
            "truth": {f"{q}_{units[q]}": f(self.truth[q]) for q in QUANTITIES},
            "error": {f"{q}_{units[q]}": f(self.error(q)) for q in QUANTITIES},
            "dropped": self.dropped,
            "views": [v.as_dict() for v in self.views],
            "wall_time_s": self.wall_time,
            "sim_time_s": self.sim_time,
            "image_files": [str(p) for p in self.image_files],
        }


def measure_hook(
    scenario: Scenario, *, keep_images: bool = False, save_images_dir=None, **options
) -> HookMeasurementResult:
    """Moves the held hook through the views in the dynamic simulation and measures it.

    Args:
        scenario: the world; its tool (`kind: hook`) is the truth the camera sees (the robot
            never reads it). `scenario.camera` sets the intrinsics.
        keep_images: keep each view's (colour, depth) images in the result.
        save_images_dir: if given, each view is written there annotated
            (`annotate_hook_view`) as `measure_<view>.png`, all of them as one set
            (`check_images_dir`).
        options: `plan` (from `plan_hook_measurement`, to reuse: it depends on the robot and
            the camera, not on the hook), `noise_sigma`, `lighting`, `scene_objects`, `seed`,
            `move_time`, `settle_time`, as `build_camera_measurement`'s.

    Raises ValueError if the scenario holds no hook, or (naming the quantities, each view and
    what it missed) if no view gives one of the four. Dropped views are in `result.dropped`
    with the reason; a hook view that could not see the grasp says why in its `grip_reason`.
    """
    run = capture_views(
        lambda: build_hook_measurement_diagram(scenario, **options),
        lambda color, view: annotate_hook_view(color, view, camera_info(scenario.camera)),
        keep_images=keep_images,
        save_images_dir=save_images_dir,
    )
    measurement: HookMeasurement = run.measurement
    tool = scenario.tool
    result = HookMeasurementResult(
        **combine_views(measurement.views, run.X_GC),
        views=list(measurement.views),
        truth={
            "handle_length": float(tool.length),
            "hook_length": float(tool.hook_length),
            "angle": float(tool.hook_angle),
            "grasp_along": float(tool.grasp_offset_along),
        },
        wall_time=run.wall_time,
        sim_time=run.sim_time,
        images=run.images if keep_images else None,
        image_files=run.image_files,
    )
    missing = [q for q in QUANTITIES if not math.isfinite(result.value(q))]
    if missing:
        detail = "; ".join(
            f"view {v.view!r}: {v.reason or v.grip_reason or 'measured'}" for v in measurement.views
        )
        raise ValueError(
            f"the hook's {', '.join(missing)} could not be measured in any of the "
            f"{len(measurement.views)} views: {detail or 'no view was captured'}"
        )
    return result


# The measurement's goal: within these of the truth (m, m, deg). A measured value this close
# outside a HookTool range is taken at the range's end (a hook made at the end of a range
# measures a little beyond it); further out it is an error.
TOLERANCE = {"handle_length": 0.002, "hook_length": 0.002, "angle": 2.0}
_RANGES = {
    "handle_length": (HOOK_HANDLE_RANGE, "m"),
    "hook_length": (HOOK_LENGTH_RANGE, "m"),
    "angle": (HOOK_ANGLE_RANGE, "deg"),
}


def measured_hook(result: HookMeasurementResult, like: HookTool | None = None) -> HookTool:
    """The hook the robot believes after a measurement: a `HookTool` of the measured handle
    length, hook length and angle (its radius, mass and bands as `like`'s, default HookTool's).
    A value within TOLERANCE outside its range is taken at the range's end; further out (or
    NaN) it is a ValueError naming the value and the range."""
    values = {}
    for quantity, ((lo, hi), unit) in _RANGES.items():
        value = result.value(quantity)
        tol = TOLERANCE[quantity]
        if not (math.isfinite(value) and lo - tol <= value <= hi + tol):
            raise ValueError(
                f"measured hook {quantity}={value:g} {unit} is outside the allowed range "
                f"[{lo:g}, {hi:g}] {unit} (+- the measurement tolerance {tol:g} {unit})"
            )
        values[quantity] = min(max(value, lo), hi)
    extra = (
        {}
        if like is None
        else {"radius": like.radius, "mass": like.mass, "marker_length": like.marker_length}
    )
    return HookTool(values["handle_length"], values["hook_length"], values["angle"], **extra)


def measure_hook_belief(
    scenario: Scenario, *, use_grasp_estimate: bool = True, **measure_kwargs
) -> tuple[RobotBelief, HookMeasurementResult]:
    """Measures the scenario's (true) hook (`measure_hook`) and returns what the robot then
    believes: the measured hook (`measured_hook`) held where the camera saw the grasp along
    the handle (with `use_grasp_estimate`; else at the nominal grasp)."""
    result = measure_hook(scenario, **measure_kwargs)
    along = result.grasp_along if use_grasp_estimate else 0.0
    return RobotBelief(measured_hook(result), (0.0, along)), result
