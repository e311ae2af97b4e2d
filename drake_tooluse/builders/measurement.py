"""Measuring the tool's length with the head camera, as the paper did with Baxter's.

```
TrajectorySource ─[q*, v*]─► plant (PD) ─► SceneGraph ─► RgbdSensor (head_camera)
 hold view 0, move to 1,     true tool                    │color       │depth
 hold, move to 2, hold                          [ColorImageNoise]      │
                                                          └─► ToolLengthEstimator
                                                               ├─► tool_length
                                                               └─► measurement
```

The robot does not know the length it measures, so each view fixes the GRIPPER pose in the
camera frame C (IK with no tool: `ToolTipIK(None)`, the tip frame is `right_gripper`, whose +z
is the tool axis) such that a tool of any length in [0.05, 0.60] m lies wholly in view, about
0.65 m in front of the camera:

| view | grip p_CG (m) | tool axis in C |
| --- | --- | --- |
| grip_right | (0.15, 0.20, 0.65) | -x: to the image's left; the hand leaves the image right |
| grip_bottom | (0.15, 0.30, 0.65) | -y: up the image; the hand is below the image |
| grip_left | (0.12, 0.22, 0.65) | +x, turned 20 deg away from the camera and 10 deg up |

"Grip on the left, tool to the right" needs the hand to the left of the grip, on the tool's
line. Baxter's right arm cannot reach that with the tool square to the optical axis anywhere
the whole tool stays in view: an IK search over grip positions and tilts found it only with
the tool tilted 20 deg away from the camera (15 deg if also turned 30 deg up the image). The
grip then sits right of centre, the tool running right and away. The depth variant measures
in 3-D and does not mind the tilt; the pixel variant does (the tool is foreshortened) and
reads 15-30 % short in that view (the longer the tool, the farther its tip).

The measurement starts with the arm holding view 0 (the tool raised into view: starting from
the home posture would put a long tool through the table), then drives the arm to views 1
and 2 in the dynamic simulation along straight gripper paths (the tool stays in front of the
robot, above the table); each view is captured after the arm has settled.
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from pathlib import Path

import numpy as np
from pydrake.geometry import (
    Box,
    GeometryInstance,
    IllustrationProperties,
    PerceptionProperties,
    RenderLabel,
    Rgba,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial, PiecewisePose

from drake_tooluse.files import atomic_dir, atomic_write_image, remove_orphans
from drake_tooluse.perception.markers import (
    LIGHTINGS,
    METHODS,
    ToolLengthMeasurement,
    ViewSpec,
    annotate_view,
    check_noise_sigma,
)
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import StraightTool, check_tool_length
from drake_tooluse.systems.camera import (
    ColorImageNoise,
    DepthImageNoise,
    ToolLengthEstimator,
    add_head_camera,
    camera_info,
    check_depth_noise,
    head_camera_pose,
)
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.validation import check_in_range, check_one_of
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import World, add_world


@dc.dataclass(frozen=True)
class MeasurementView:
    """A measurement pose, fixed in the camera frame C: the grip point p_CG and the tool axis
    z_G in C. The fingers' closing axis (y_G) is the first of `finger_axes_C` the arm reaches:
    across the tool in the image first, which keeps the fingers beside the grip marker rather
    than in front of it."""

    name: str
    p_CG: tuple[float, float, float]
    tool_axis_C: tuple[float, float, float]

    def finger_axes_C(self) -> list[np.ndarray]:
        z = np.asarray(self.tool_axis_C, float)
        across = np.cross([0.0, 0.0, 1.0], z)
        across /= np.linalg.norm(across)
        toward = np.array([0.0, 0.0, 1.0]) - z[2] * z
        toward /= np.linalg.norm(toward)
        return [across, -across, toward, -toward]

    def X_CG(self, finger_axis_C) -> RigidTransform:
        z = np.asarray(self.tool_axis_C, float)
        z = z / np.linalg.norm(z)
        y = np.asarray(finger_axis_C, float)
        y = y - y.dot(z) * z
        y /= np.linalg.norm(y)
        return RigidTransform(
            RotationMatrix(np.column_stack([np.cross(y, z), y, z])), np.asarray(self.p_CG, float)
        )


def _axis(tilt_away_deg: float, tilt_up_deg: float) -> tuple[float, float, float]:
    """Unit vector along +x of C turned `tilt_up` towards -y (up the image) and `tilt_away`
    towards +z (away from the camera)."""
    a, b = math.radians(tilt_away_deg), math.radians(tilt_up_deg)
    return (math.cos(a) * math.cos(b), -math.cos(a) * math.sin(b), math.sin(a))


# Capture order: the right arm's easiest view first, the reach across last.
MEASUREMENT_VIEWS = (
    MeasurementView("grip_right", (0.15, 0.20, 0.65), (-1.0, 0.0, 0.0)),
    MeasurementView("grip_bottom", (0.15, 0.30, 0.65), (0.0, -1.0, 0.0)),
    MeasurementView("grip_left", (0.12, 0.22, 0.65), _axis(20.0, 10.0)),
)
MOVE_TIME = 1.0  # s, from one view to the next
MOVE_WAYPOINTS = 20  # IK waypoints along each move
MAX_WAYPOINT_STEP = 0.5  # rad: a larger joint step between waypoints is a jump of branch
SETTLE_TIME = 0.4  # s, held still before each capture


@dc.dataclass
class PlannedView:
    view: MeasurementView
    X_WG: RigidTransform
    q: np.ndarray  # right-arm joint angles s0 … w2 (rad)
    spec: ViewSpec  # what the estimator is told


@dc.dataclass
class MeasurementPlan:
    """The views' gripper poses and joint angles, and for each move from view k to view k+1
    the joint angles along it (MOVE_WAYPOINTS + 1 rows, both ends included)."""

    X_WC: RigidTransform
    views: list
    moves: list


def _smoothstep(tau):
    """0 → 1 with zero slope at both ends: the moves start and end at rest."""
    return 3.0 * tau**2 - 2.0 * tau**3


def _track(ik: ToolTipIK, X_start: RigidTransform, X_end: RigidTransform, q_start):
    """Joint angles along the straight-line, constant-axis-rotation path of the gripper from
    X_start to X_end (IK warm-started waypoint to waypoint), or None if a waypoint fails or
    the arm would jump branches (a joint step over MAX_WAYPOINT_STEP)."""
    path = PiecewisePose.MakeLinear([0.0, 1.0], [X_start, X_end])
    qs = [np.asarray(q_start, float)]
    for tau in np.linspace(0.0, 1.0, MOVE_WAYPOINTS + 1)[1:]:
        X = RigidTransform(path.GetPose(_smoothstep(tau)).GetAsMatrix4())
        result = ik.solve(X, q_seed=qs[-1])
        if not result.success or np.max(np.abs(result.q - qs[-1])) > MAX_WAYPOINT_STEP:
            return None
        qs.append(result.q)
    return np.array(qs)


def plan_measurement(scenario: Scenario, views=MEASUREMENT_VIEWS) -> MeasurementPlan:
    """The gripper IK (no tool) of each view and of the moves between them.

    View 0 is solved from the scenario's posture seed. Each next view is reached along a
    straight line of the gripper in Cartesian space (IK tracked waypoint by waypoint): joint
    interpolation between two independently solved views swung a long tool through the table
    and the robot's body. The finger orientation is the first of the view's candidates that
    works. Raises ValueError naming a view that cannot be reached."""
    ik = ToolTipIK(None, max_attempts=8)
    info = camera_info(scenario.camera)
    X_WC = head_camera_pose(ik.plant, ik.context)
    planned, moves = [], []
    for k, view in enumerate(views):
        found = None
        for finger_axis in view.finger_axes_C():
            X_WG = X_WC @ view.X_CG(finger_axis)
            if k == 0:
                result = ik.solve(X_WG, q_seed=scenario.robot.posture_seed)
                if result.success:
                    found = (X_WG, result.q, None)
            else:
                path = _track(ik, planned[-1].X_WG, X_WG, planned[-1].q)
                if path is not None:
                    found = (X_WG, path[-1], path)
            if found is not None:
                break
        if found is None:
            how = "unreachable" if k == 0 else f"not reachable from view {views[k - 1].name!r}"
            raise ValueError(
                f"measurement view {view.name!r}: the gripper pose (grip at {list(view.p_CG)} m "
                f"in the head camera frame) is {how} for the right arm"
            )
        X_WG, q, path = found
        if path is not None:
            moves.append(path)
        p_CG = np.asarray(view.p_CG, float)
        pixel = (
            info.center_x() + info.focal_x() * p_CG[0] / p_CG[2],
            info.center_y() + info.focal_y() * p_CG[1] / p_CG[2],
        )
        planned.append(PlannedView(view, X_WG, q, ViewSpec(view.name, pixel, float(p_CG[2]))))
    return MeasurementPlan(X_WC, planned, moves)


def capture_times(
    n_views: int, move_time: float = MOVE_TIME, settle_time: float = SETTLE_TIME
) -> list[float]:
    """t_k = settle + k (move + settle): view k is held `settle_time` s before it is taken."""
    return [settle_time + k * (move_time + settle_time) for k in range(n_views)]


def joint_schedule(
    plan: MeasurementPlan, move_time: float = MOVE_TIME, settle_time: float = SETTLE_TIME
) -> PiecewisePolynomial:
    """Right-arm joint targets: hold view 0, then for each move its waypoints (cubic Hermite,
    velocities by finite differences, zero at both ends) and a hold at the view; the capture
    times fall at the ends of the holds."""
    q0 = plan.views[0].q
    times, samples, rates = [0.0, settle_time], [q0, q0], [np.zeros(7), np.zeros(7)]
    t = settle_time
    for path in plan.moves:
        knot_times = t + np.linspace(0.0, move_time, len(path))
        qdot = np.gradient(path, knot_times, axis=0)
        qdot[0] = qdot[-1] = 0.0
        times += list(knot_times[1:])
        samples += list(path[1:])
        rates += list(qdot[1:])
        t += move_time + settle_time
        times.append(t)
        samples.append(path[-1])
        rates.append(np.zeros(7))
    times.append(t + 0.5)  # past the last capture
    samples.append(samples[-1])
    rates.append(np.zeros(7))
    return PiecewisePolynomial.CubicHermite(times, np.array(samples).T, np.array(rates).T)


@dc.dataclass(frozen=True)
class SceneObject:
    """Extra visual geometry for robustness tests (a distractor, an occluder), anchored in the
    world at X_CO relative to the head camera's optical frame C."""

    name: str
    shape: object  # a pydrake.geometry Shape
    X_CO: RigidTransform
    rgba: tuple[float, float, float, float]


def orange_distractor(p_CO=(-0.40, -0.27, 0.90), radius: float = 0.004) -> SceneObject:
    """A small orange sphere (default: in the upper left of every view, clear of the tool and
    the arm), smaller in the image than a marker band."""
    return SceneObject(
        "orange_distractor", Sphere(radius), RigidTransform(p_CO), (1.0, 0.45, 0.0, 1.0)
    )


def occluder(p_CO, size=(0.06, 0.06, 0.005)) -> SceneObject:
    """A grey plate square to the optical axis at p_CO (m, camera frame) that hides what lies
    behind it."""
    return SceneObject("occluder", Box(*size), RigidTransform(p_CO), (0.5, 0.5, 0.5, 1.0))


def add_scene_objects(world: World, X_WC: RigidTransform, objects) -> None:
    """Registers each object with the scene graph (perception + illustration roles)."""
    if not objects:
        return
    sg = world.scene_graph
    source = sg.RegisterSource("measure_scene_objects")
    for obj in objects:
        gid = sg.RegisterAnchoredGeometry(
            source, GeometryInstance(X_WC @ obj.X_CO, obj.shape, obj.name)
        )
        perception = PerceptionProperties()
        perception.AddProperty("phong", "diffuse", Rgba(*obj.rgba))
        perception.AddProperty("label", "id", RenderLabel.kDontCare)
        sg.AssignRole(source, gid, perception)
        illustration = IllustrationProperties()
        illustration.AddProperty("phong", "diffuse", Rgba(*obj.rgba))
        sg.AssignRole(source, gid, illustration)


@dc.dataclass
class MeasurementDiagram:
    """A camera measurement's diagram and its parts (`build_camera_measurement`)."""

    diagram: object
    world: World
    plan: MeasurementPlan
    sensor: object
    color_port: object  # the colour image the estimator sees (after the noise)
    estimator: object  # ToolLengthEstimator, HookEstimator: a systems.view_estimator system
    capture_times: list


def _through(builder, port, name: str, system):
    """`port` passed through `system` (one input, one output), added as `name`: its output."""
    builder.AddNamedSystem(name, system)
    builder.Connect(port, system.get_input_port())
    return system.get_output_port()


def build_camera_measurement(
    scenario: Scenario,
    plan: MeasurementPlan | None,
    make_estimator,
    *,
    name: str,
    estimator_name: str,
    views=MEASUREMENT_VIEWS,
    noise_sigma: float | None = None,
    depth_noise_sigma: float = 0.0,
    lighting: str = "default",
    scene_objects=(),
    seed: int = 0,
    move_time: float = MOVE_TIME,
    settle_time: float = SETTLE_TIME,
) -> MeasurementDiagram:
    """World (the true tool) + joint schedule through the plan's views + head camera [+ colour
    noise] + an estimator, the diagram `name`: what the straight tool's and the hook's
    measurements share (`build_measurement_diagram`, `build_hook_measurement_diagram`).

    `make_estimator(planned, first_capture, capture_period)` gives the estimator (named
    `estimator_name`) of the plan's views (`PlannedView`s, in capture order), which takes them
    at the capture times (`capture_times`); it has the inputs `color_image` and `depth_image`.
    Exported outputs: the estimator's, then `color_image` and `depth_image`.

    Args:
        plan: a plan from `plan_measurement` to reuse (it depends on the robot and the camera,
            not on the tool); None plans `views`.
        noise_sigma: Gaussian colour noise (grey levels); None takes scenario.camera.noise_sigma.
        depth_noise_sigma: Gaussian depth noise (m) on what the estimator sees
            (`DepthImageNoise`); 0, none.
        lighting: "default" or "dim_side" (see systems.camera.lighting_params).
        scene_objects: extra SceneObjects (distractors, occluders).
        seed: the colour and depth noises'.
        move_time, settle_time: each move between views, and each hold before a capture (s).
    """
    check_one_of(lighting, LIGHTINGS, "lighting")
    sigma = scenario.camera.noise_sigma if noise_sigma is None else check_noise_sigma(noise_sigma)
    depth_noise_sigma = check_depth_noise(depth_noise_sigma)
    move_time = check_in_range(move_time, 0.1, 10.0, "move_time", unit="s")
    settle_time = check_in_range(settle_time, 0.0, 10.0, "settle_time", unit="s")
    plan = plan_measurement(scenario, views) if plan is None else plan
    builder = DiagramBuilder()
    world = add_world(builder, scenario)
    for joint, q in zip(world.arm_joints(), plan.views[0].q):
        joint.set_default_angle(q)
    add_scene_objects(world, plan.X_WC, scene_objects)
    schedule = builder.AddNamedSystem(
        "joint_schedule",
        TrajectorySource(joint_schedule(plan, move_time, settle_time), output_derivative_order=1),
    )
    builder.Connect(
        schedule.get_output_port(), world.plant.get_desired_state_input_port(world.baxter)
    )
    sensor = add_head_camera(builder, world, scenario.camera, lighting)
    size = (scenario.camera.width, scenario.camera.height)
    color_port = sensor.color_image_output_port()
    if sigma > 0:
        color_port = _through(
            builder, color_port, "color_noise", ColorImageNoise(*size, sigma, seed)
        )
    times = capture_times(len(plan.views), move_time, settle_time)
    estimator = builder.AddNamedSystem(
        estimator_name, make_estimator(plan.views, times[0], move_time + settle_time)
    )
    depth_port = sensor.depth_image_32F_output_port()
    if depth_noise_sigma > 0:
        noise = DepthImageNoise(*size, depth_noise_sigma, seed)
        depth_port = _through(builder, depth_port, "depth_noise", noise)
    builder.Connect(color_port, estimator.GetInputPort("color_image"))
    builder.Connect(depth_port, estimator.GetInputPort("depth_image"))
    for i in range(estimator.num_output_ports()):
        port = estimator.get_output_port(i)
        builder.ExportOutput(port, port.get_name())
    builder.ExportOutput(color_port, "color_image")
    builder.ExportOutput(depth_port, "depth_image")
    diagram = builder.Build()
    diagram.set_name(name)
    return MeasurementDiagram(diagram, world, plan, sensor, color_port, estimator, times)


def build_measurement_diagram(
    scenario: Scenario,
    plan: MeasurementPlan | None = None,
    *,
    method: str = "depth",
    **options,
) -> MeasurementDiagram:
    """World (true tool) + joint schedule through the views + head camera [+ colour noise] +
    ToolLengthEstimator. Exported outputs: `tool_length`, `measurement`, `color_image`,
    `depth_image`. `options`: `noise_sigma`, `lighting`, `scene_objects`, `seed`, `move_time`,
    `settle_time`, as `build_camera_measurement`'s."""
    check_one_of(method, METHODS, "method")

    def estimator(planned, first_capture, capture_period):
        specs = [pv.spec for pv in planned]
        info = camera_info(scenario.camera)
        return ToolLengthEstimator(info, specs, first_capture, capture_period, method)

    return build_camera_measurement(
        scenario,
        plan,
        estimator,
        name="tool_measurement",
        estimator_name="tool_length_estimator",
        **options,
    )


@dc.dataclass
class MeasurementResult:
    """The three-view measurement. `length` is the mean of the accepted views by `method`
    (NaN if none); `views` holds every view's result, both variants."""

    length: float  # m
    spread: float  # m, largest minus smallest accepted view
    method: str
    views: list  # ViewMeasurement per view, in capture order
    wall_time: float  # s, the whole call: plan, build, simulate, estimate
    sim_time: float  # s, simulated
    scenario_tool_length: float  # m, the truth in the world (for comparison only)
    images: list | None = None  # [(color RGBA, depth)] per view when asked for
    image_files: list = dc.field(default_factory=list)
    # Where the hand holds the tool along it (m from the gripper frame's origin, as
    # `tool.grasp_offset_along`), from the grip marker's outer end seen in 3-D; NaN if no
    # view gave it (see `estimate_grasp_along`).
    grasp_along: float = math.nan
    scenario_grasp_along: float = math.nan  # the truth, for comparison only

    @property
    def dropped(self) -> list[dict]:
        return [{"view": v.view, "reason": v.reason} for v in self.views if not v.accepted]

    def length_by(self, method: str) -> float:
        values = [v.length(method) for v in self.views if v.accepted]
        return float(np.mean(values)) if values else math.nan

    def measured_dimensions(self) -> dict[str, float]:
        """What was measured of the tool, named as `StraightTool.dimensions()` names it."""
        return {"length_m": self.length}

    def summary_lines(self) -> list[str]:
        """The measurement in words, view by view (a figure's caption): both variants."""
        accepted = [v for v in self.views if v.accepted]
        if not accepted:
            return ["no view was accepted: " + "; ".join(d["reason"] for d in self.dropped)]
        names = " / ".join(v.view.removeprefix("grip_") for v in accepted)

        def mm(values):
            return " / ".join(f"{x * 1000:.1f}" for x in values)

        depth = [v.length_depth for v in accepted]
        return [
            f"views (grip {names}), mm:",
            f"depth variant, what the robot uses: {mm(depth)}; mean {np.mean(depth) * 1000:.1f}",
            f"pixel variant, the paper's fixed m/px: {mm(v.length_pixel for v in accepted)}",
            "   (exact only for a tool square to the camera at the grip's depth:",
            "   a view that tilts the tool in depth foreshortens it)",
            f"true length: {self.scenario_tool_length * 1000:.1f} (unknown to the robot)",
        ]

    def as_dict(self) -> dict:
        def f(x):
            return None if not math.isfinite(x) else float(x)

        return {
            "tool_length_m": f(self.length),
            "spread_m": f(self.spread),
            "method": self.method,
            "per_view_m": {v.view: f(v.length(self.method)) for v in self.views},
            "dropped": self.dropped,
            "length_depth_m": f(self.length_by("depth")),
            "length_pixel_m": f(self.length_by("pixel")),
            "views": [v.as_dict() for v in self.views],
            "scenario_tool_length_m": f(self.scenario_tool_length),
            "error_m": f(self.length - self.scenario_tool_length),
            "grasp_along_m": f(self.grasp_along),
            "scenario_grasp_along_m": f(self.scenario_grasp_along),
            "wall_time_s": self.wall_time,
            "sim_time_s": self.sim_time,
            "image_files": [str(p) for p in self.image_files],
        }


def estimate_grasp_along(views, X_GC) -> float:
    """Where the hand holds the tool along its axis: the grasp point's z in the gripper frame
    (m, as `tool.grasp_offset_along`), the mean over the accepted views. The grip marker's
    outer end is the grasp point; `X_GC` is each view's camera pose in the gripper frame. Of
    the two outer ends (`ends_C`) it takes the one nearer the wrist (smaller z in G): the tip
    is always further out, while the image may pair the two bands the wrong way round when a
    short tool's grip band is half inside the fingers. Only the component along the tool: the
    marker points lie on the rod's surface facing the camera, a radius (~7 mm) off its axis
    across it, as large as the shifts across to be found, so those are not estimated."""
    along = [
        min((X @ np.asarray(p, float))[2] for p in view.ends_C)
        for view, X in zip(views, X_GC)
        if view.accepted and len(view.ends_C) == 2
    ]
    return float(np.mean(along)) if along else math.nan


IMAGE_NAME = "measure_{view}.png"


def check_images_dir(path, option: str = "save_images_dir") -> Path:
    """The directory `measure_tool` writes its views into, as one set that replaces the one
    there: absent, empty, or holding only an earlier measurement's views (its other files would
    go with them: refused, naming one)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise FileExistsError(f"{option} {str(path)!r} is a file; give a directory")
    if path.is_dir():
        remove_orphans(path)
        pattern = IMAGE_NAME.format(view="*")
        others = sorted(p.name for p in path.iterdir() if not p.match(pattern) or p.is_dir())
        if others:
            raise FileExistsError(
                f"{option} {str(path)!r} holds files other than a measurement's views "
                f"({', '.join(others[:3])}{', ...' if len(others) > 3 else ''}), which the new "
                "views would replace; give a new directory"
            )
    return path


@dc.dataclass
class CapturedViews:
    """What a camera measurement's run gives (`capture_views`)."""

    measurement: object  # the estimator's `measurement` output after the last capture
    X_GC: list  # RigidTransform per capture: the camera in the gripper frame
    images: list  # [(color RGBA, depth)] per capture, when kept or saved
    image_files: list  # the annotated views written
    sim_time: float  # s, simulated
    wall_time: float  # s: plan (if not given), build, simulate, estimate, save


def capture_views(
    build, annotate, *, keep_images: bool = False, save_images_dir=None
) -> CapturedViews:
    """Runs a camera measurement: checks `save_images_dir` (`check_images_dir`), builds the
    diagram (`build()`, a MeasurementDiagram), simulates it through its captures and releases
    it. At each capture it records the camera's pose in the gripper frame (the robot's joint
    encoders and its head camera's calibration: the world plant's kinematics are the robot's
    own) and, with `keep_images` or `save_images_dir`, the images the estimator takes. With
    `save_images_dir`, each view is written there annotated (`annotate(color, view)`, BGR) as
    `measure_<view>.png`, all of them as one set that replaces the views there."""
    start = time.perf_counter()
    if save_images_dir is not None:
        check_images_dir(save_images_dir)
    built = build()
    try:
        simulator = Simulator(built.diagram)
        simulator.Initialize()
        context = simulator.get_context()
        diagram = built.diagram
        plant = built.world.plant
        plant_context = plant.GetMyContextFromRoot(context)
        want_images = keep_images or save_images_dir is not None
        images, X_GC = [], []
        for t in built.capture_times:
            simulator.AdvanceTo(t)
            # The camera in the gripper frame at the capture (joint encoders + calibration).
            X_WG = built.world.gripper_frame.CalcPoseInWorld(plant_context)
            X_GC.append(X_WG.inverse() @ head_camera_pose(plant, plant_context))
            if want_images:  # the images the estimator takes at t (cached, rendered once)
                color = diagram.GetOutputPort("color_image").Eval(context).data.copy()
                depth = diagram.GetOutputPort("depth_image").Eval(context).data.copy()
                images.append((color, depth))
        # The capture at the last time runs at the start of the next step.
        t_end = built.capture_times[-1] + plant.time_step()
        simulator.AdvanceTo(t_end)
        measurement = diagram.GetOutputPort("measurement").Eval(context)
        files = []
        if save_images_dir is not None:  # one set: all the new views, or the old ones
            out_dir = Path(save_images_dir)
            with atomic_dir(out_dir, replace=True) as tmp:
                for view, (color, _) in zip(measurement.views, images):
                    name = IMAGE_NAME.format(view=view.view)
                    atomic_write_image(tmp / name, annotate(color, view), bgr=True)
                    files.append(out_dir / name)
        return CapturedViews(measurement, X_GC, images, files, t_end, time.perf_counter() - start)
    finally:
        release_diagram(built.diagram)  # its Python systems would keep it alive


def measure_tool(
    scenario: Scenario,
    save_images_dir=None,
    noise_sigma: float | None = None,
    method: str = "depth",
    *,
    keep_images: bool = False,
    **options,
) -> MeasurementResult:
    """Moves through the three views in the dynamic simulation and measures the tool.

    Args:
        scenario: the world; its tool is the truth the camera sees (the robot never reads
            its length). `scenario.camera` sets the intrinsics.
        save_images_dir: if given, each view is written there annotated (mask, boxes, the
            measured segment) as `measure_<view>.png`, all of them as one set that replaces
            the views there (`check_images_dir`: the directory holds nothing else).
        noise_sigma: Gaussian colour noise (grey levels); None takes scenario.camera.noise_sigma.
        method: "depth" (default) or "pixel" (the paper's fixed metres per pixel).
        keep_images: keep each view's (colour, depth) images in the result.
        options: `plan` (from `plan_measurement`, to reuse: it depends on the robot and the
            camera intrinsics, not on the tool), `lighting`, `scene_objects`, `seed`,
            `move_time`, `settle_time`, as `build_camera_measurement`'s.

    Raises ValueError (naming each view and the missing marker) if no view gives a length.
    Dropped views are in `result.dropped` with the reason.
    """
    run = capture_views(
        lambda: build_measurement_diagram(
            scenario, method=method, noise_sigma=noise_sigma, **options
        ),
        lambda color, view: annotate_view(color, view, camera_info(scenario.camera)),
        keep_images=keep_images,
        save_images_dir=save_images_dir,
    )
    measurement: ToolLengthMeasurement = run.measurement
    result = MeasurementResult(
        length=measurement.length(),
        spread=measurement.spread(),
        method=method,
        views=list(measurement.views),
        wall_time=run.wall_time,
        sim_time=run.sim_time,
        scenario_tool_length=float(scenario.tool.length) if scenario.tool.attached else math.nan,
        images=run.images if keep_images else None,
        image_files=run.image_files,
        grasp_along=estimate_grasp_along(measurement.views, run.X_GC),
        scenario_grasp_along=scenario.tool.grasp_offset_along,
    )
    measurement.length_or_raise()
    return result


def measure_belief(
    scenario: Scenario, *, use_grasp_estimate: bool = True, **measure_kwargs
) -> tuple[RobotBelief, MeasurementResult]:
    """Measures the scenario's (true) tool with the head camera (`measure_tool`) and returns
    what the robot then believes: a `StraightTool` of the measured length and, with
    `use_grasp_estimate`, where the hand holds the tool along it (else the nominal grasp: the
    paper's measurement)."""
    result = measure_tool(scenario, **measure_kwargs)
    along = result.grasp_along if use_grasp_estimate else 0.0
    return RobotBelief(measured_tool(result), (0.0, along)), result


def measured_tool(result: MeasurementResult) -> StraightTool:
    """The tool the robot believes after a measurement: a straight tool of the measured length
    (the camera measures no other geometry)."""
    return StraightTool(check_tool_length(result.length, "believed tool length"))
