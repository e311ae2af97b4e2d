"""Baxter's head camera (and a scene camera) as Drake `RgbdSensor`s, image noise, and the
tool-length estimator system.

```
            ┌─ world ─────────────┐
SceneGraph ─┤ RgbdSensor on       ├─color─► [ColorImageNoise] ─► ToolLengthEstimator
            │ head_camera (VTK)   ├─depth──────────────────────►  ├─► tool_length
            └─────────────────────┘                               └─► measurement
```

The estimator runs the OpenCV pipeline of `perception.markers` on each view. Frames: H = the
URDF's `head_camera` frame; C = the camera's optical frame (Drake's camera convention: +z out
of the lens, +x right in the image, +y down). SI units.
"""

from __future__ import annotations

import dataclasses as dc
import math

import cv2
import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    ColorRenderCamera,
    DepthRange,
    DepthRenderCamera,
    LightParameter,
    MakeRenderEngineVtk,
    RenderCameraCore,
    RenderEngineVtkParams,
    Rgba,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import LeafSystem
from pydrake.systems.sensors import CameraInfo, ImageDepth32F, ImageRgba8U, RgbdSensor

from drake_tooluse.perception.markers import (
    LIGHTINGS,
    METHODS,
    ToolLengthMeasurement,
    check_noise_sigma,
    measure_view,
)
from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.systems.view_estimator import ViewByViewEstimator
from drake_tooluse.validation import check_in_range, check_one_of
from drake_tooluse.world.scenario import CameraConfig

HEAD_CAMERA_FRAME = "head_camera"
HEAD_RENDERER = "head_camera_vtk"
# X_HC: the URDF's head_camera frame has +x to the robot's left and +y up (checked by
# rendering: the image came out upside down), so the optical frame is it turned half a turn
# about the viewing axis.
X_HC = RigidTransform(RotationMatrix.MakeZRotation(math.pi))


def camera_info(config: CameraConfig) -> CameraInfo:
    """Intrinsics of a pinhole camera with the scenario's image size and vertical field of
    view (square pixels, principal point at the image centre)."""
    return CameraInfo(config.width, config.height, config.fov_y)


def lighting_params(lighting: str) -> RenderEngineVtkParams:
    """Renderer settings: "default" is VTK's headlight; "dim_side" a single white light at 45 %
    intensity from the upper left of the camera (a lighting change for robustness tests)."""
    check_one_of(lighting, LIGHTINGS, "lighting")
    params = RenderEngineVtkParams()
    if lighting == "dim_side":
        direction = np.array([0.6, 0.5, 1.0])
        params.lights = [
            LightParameter(
                type="directional",
                color=Rgba(1.0, 1.0, 1.0, 1.0),
                intensity=0.45,
                frame="camera",
                direction=direction / np.linalg.norm(direction),
            )
        ]
    return params


def add_rgbd_sensor(
    builder,
    world,
    name: str,
    *,
    body,
    X_BC: RigidTransform,
    info: CameraInfo,
    clipping: tuple[float, float],
    depth_range: tuple[float, float],
    renderer: str,
    renderer_params: RenderEngineVtkParams | None = None,
):
    """Adds an RgbdSensor `name` fixed at X_BC on `body` of the world's plant, rendering with
    VTK (the renderer `renderer` is added to the scene graph once, with `renderer_params`);
    connects it to the scene graph. Returns the sensor; its `color_image` (ImageRgba8U) and
    `depth_image_32f` (ImageDepth32F, m) ports are left for the caller."""
    scene_graph, plant = world.scene_graph, world.plant
    if not scene_graph.HasRenderer(renderer):
        scene_graph.AddRenderer(
            renderer,
            MakeRenderEngineVtk(
                renderer_params if renderer_params is not None else RenderEngineVtkParams()
            ),
        )
    core = RenderCameraCore(renderer, info, ClippingRange(*clipping), RigidTransform())
    sensor = builder.AddNamedSystem(
        name,
        RgbdSensor(
            plant.GetBodyFrameIdOrThrow(body.index()),
            X_BC,
            ColorRenderCamera(core, False),
            DepthRenderCamera(core, DepthRange(*depth_range)),
        ),
    )
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    return sensor


def add_head_camera(builder, world, config: CameraConfig, lighting: str = "default"):
    """Baxter's head camera (the scenario's `camera`), on the `head_camera` frame at X_HC."""
    return add_rgbd_sensor(
        builder,
        world,
        "head_camera",
        body=world.plant.GetBodyByName(HEAD_CAMERA_FRAME),
        X_BC=X_HC,
        info=camera_info(config),
        clipping=(config.clipping_near, config.clipping_far),
        depth_range=(config.depth_min, config.depth_max),
        renderer=HEAD_RENDERER,
        renderer_params=lighting_params(lighting),
    )


def look_at(eye, target) -> RigidTransform:
    """X_WC of a camera at `eye` looking at `target` (Drake camera frame: +z along the view,
    +x right, +y down), with the world's +z up in the image."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return RigidTransform(RotationMatrix(np.column_stack([x, y, z])), np.asarray(eye, float))


# The scene camera's defaults (W, m): in front of the robot and to its right, a little above
# its head, looking down at the work area, so that the whole robot (head included), the tool,
# the table, the box and the goal are in view (checked by looking at the frames, and by a test
# that projects them into the image).
SCENE_CAMERA_POSITION = (1.8, -1.1, 0.6)
SCENE_CAMERA_TARGET = (0.4, -0.1, 0.1)
SCENE_CAMERA_SIZE = (640, 480)  # px, width x height
SCENE_CAMERA_FOV_Y = 0.9  # rad
SCENE_CAMERA_SIZES = (32, 2048)  # px: each side of the image within this
MAX_CAMERA_DISTANCE = 10.0  # m, per coordinate of the position and the target
SCENE_CAMERA = "render_camera"  # the sensor's name in the diagram
# The work area close up (the demo's final scene: the box at the goal large enough to judge by
# eye): in front of the robot, to its right, below its head, 480 x 360 px.
CLOSE_UP_CAMERA = {
    "width": 480,
    "height": 360,
    "position": (1.35, -0.85, 0.35),
    "target": (0.55, -0.15, -0.12),
}
# m: the far clipping plane of a camera within 3 m of W's origin; one further away sees as far
# again past W as it stands beyond 3 m (the near plane stays at 5 cm).
SCENE_CAMERA_FAR = 10.0


def check_scene_camera(size, position, target, name: str = "render") -> tuple:
    """The scene camera's settings, checked (each a one-line ValueError naming the value and
    the allowed range): `size` (width, height) integers in SCENE_CAMERA_SIZES px; `position`
    and `target` 3 finite numbers in W (m, within MAX_CAMERA_DISTANCE per coordinate), at
    least 5 cm apart and the view not within 1 degree of vertical (the image's up is the
    world's +z). Returns (size, position, target) as a tuple of ints and two float arrays."""
    lo, hi = SCENE_CAMERA_SIZES
    if (
        not isinstance(size, (list, tuple))
        or len(size) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in size)
    ):
        raise ValueError(f"{name}_size={size!r} must be (width, height), two integers (px)")
    if not all(lo <= v <= hi for v in size):
        raise ValueError(f"{name}_size={tuple(size)} px: each side must be in [{lo}, {hi}]")
    points = []
    for what, value in (("position", position), ("target", target)):
        arg = f"{name}_camera_{what}"
        try:
            p = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            p = None
        if p is None or p.shape != (3,) or not np.isfinite(p).all():
            raise ValueError(f"{arg}={value!r} must be 3 finite numbers (x, y, z in W, m)")
        if np.any(np.abs(p) > MAX_CAMERA_DISTANCE):
            raise ValueError(
                f"{arg}={p.tolist()} m is outside [-{MAX_CAMERA_DISTANCE:g}, "
                f"{MAX_CAMERA_DISTANCE:g}] m per coordinate"
            )
        points.append(p)
    view = points[1] - points[0]
    distance = float(np.linalg.norm(view))
    if distance < 0.05:
        raise ValueError(
            f"{name}_camera_position={points[0].tolist()} and {name}_camera_target="
            f"{points[1].tolist()} are {distance:.3g} m apart; they must be at least 0.05 m apart"
        )
    if abs(view[2]) / distance > math.cos(math.radians(1.0)):
        raise ValueError(
            f"{name}_camera_position={points[0].tolist()} looks straight up or down at "
            f"{name}_camera_target={points[1].tolist()}; tilt the view (the image's up is +z)"
        )
    return (int(size[0]), int(size[1])), points[0], points[1]


def add_scene_camera(
    builder,
    world,
    width: int = SCENE_CAMERA_SIZE[0],
    height: int = SCENE_CAMERA_SIZE[1],
    position=SCENE_CAMERA_POSITION,
    target=SCENE_CAMERA_TARGET,
):
    """A colour camera fixed in W at `position`, looking at `target` (m), `width` x `height`
    px (the envs' `render_mode="rgb_array"`, the demo's final scene, `record-video`); by
    default it frames the task (see SCENE_CAMERA_POSITION). It renders what the scene graph
    holds and changes nothing of the physics. Exports its `color_image` port. Returns the
    sensor."""
    (width, height), position, target = check_scene_camera((width, height), position, target)
    far = SCENE_CAMERA_FAR + max(0.0, float(np.linalg.norm(position)) - 3.0)
    sensor = add_rgbd_sensor(
        builder,
        world,
        SCENE_CAMERA,
        body=world.plant.world_body(),
        X_BC=look_at(position, target),
        info=CameraInfo(width, height, SCENE_CAMERA_FOV_Y),
        clipping=(0.05, far),
        depth_range=(0.05, far),
        renderer=SCENE_CAMERA,
    )
    builder.ExportOutput(sensor.color_image_output_port(), "color_image")
    return sensor


@dc.dataclass(frozen=True)
class SceneView:
    """The scene camera's pose X_WC (C: +z out of the lens, +x right, +y down) and pinhole
    intrinsics (px): enough to draw points of W on its image."""

    X_WC: RigidTransform
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def of_sensor(cls, sensor) -> SceneView:
        """The view of an RgbdSensor fixed in W (`add_scene_camera`'s)."""
        core = sensor.default_color_render_camera().core()
        info = core.intrinsics()
        X_WC = sensor.default_X_PB().multiply(core.sensor_pose_in_camera_body())
        return cls(X_WC, info.focal_x(), info.focal_y(), info.center_x(), info.center_y())

    def project(self, p_W) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (u, v) of the (N, 3) points `p_W`, and which lie in front of the camera."""
        p_C = (self.X_WC.inverse().multiply(np.asarray(p_W, float).T)).T
        z = p_C[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.column_stack(
                [self.fx * p_C[:, 0] / z + self.cx, self.fy * p_C[:, 1] / z + self.cy]
            )
        return uv, z > 1e-6


def scene_camera_view(diagram, plant) -> SceneView | None:
    """The scene camera of `diagram` (`add_scene_camera`'s, fixed to the world), or None if it
    has none."""
    if not diagram.HasSubsystemNamed(SCENE_CAMERA):
        return None
    sensor = diagram.GetSubsystemByName(SCENE_CAMERA)
    if sensor.default_parent_frame_id() != plant.GetBodyFrameIdOrThrow(plant.world_body().index()):
        return None  # not fixed to the world: its pose would need the plant's state
    return SceneView.of_sensor(sensor)


GOAL_RGB = (40, 200, 60)  # the goal as drawn on images (the Meshcat recordings' green)


def plane_depth(view: SceneView, shape, z: float) -> np.ndarray:
    """(H, W) depth (m, along C's +z, as a depth image holds it) at which each pixel's ray
    meets the horizontal plane z (W); inf where it never does (the ray runs away from it)."""
    h, w = shape[:2]
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    R_WC = view.X_WC.rotation().matrix()
    # A point at depth t on pixel (u, v)'s ray: p_WC + t R_WC d, d = ((u-cx)/fx, (v-cy)/fy, 1).
    dz = R_WC[2, 0] * (u - view.cx) / view.fx + R_WC[2, 1] * (v - view.cy) / view.fy + R_WC[2, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z - view.X_WC.translation()[2]) / dz
    return np.where(np.isfinite(t) & (t > 0), t, np.inf)


def draw_goal(image: np.ndarray, view: SceneView, p_WG, radius: float, depth=None) -> np.ndarray:
    """`image` (RGB(A), `view`'s) as RGB with the goal drawn where the camera sees it: a
    translucent green disc of `radius` (m) in the horizontal plane through p_WG (the goal on
    the table, W, m), its rim, a cross at its centre and the word "goal". With `depth` (the
    camera's depth image, m), what stands in front of the disc (the box, the tool) stays in
    front of it. Drawn on the image only: nothing in the scene graph, so the physics stays as
    it is."""
    rgb = np.ascontiguousarray(np.asarray(image)[:, :, :3]).copy()
    gx, gy, z = (float(v) for v in p_WG)
    angles = np.linspace(0.0, 2 * np.pi, 73)
    ring = np.column_stack([gx + radius * np.cos(angles), gy + radius * np.sin(angles)])
    uv, front = view.project(np.column_stack([ring, np.full(len(ring), z)]))
    if not front.all() or not np.isfinite(uv).all():
        return rgb
    scale = max(rgb.shape[1] / 480, 0.5)
    polygon = np.rint(np.clip(uv, -1e5, 1e5)).astype(np.int32)
    disc = rgb.copy()
    cv2.fillPoly(disc, [polygon], GOAL_RGB, cv2.LINE_AA)
    marked = cv2.addWeighted(disc, 0.45, rgb, 0.55, 0.0)
    cv2.polylines(marked, [polygon], True, GOAL_RGB, max(1, round(2 * scale)), cv2.LINE_AA)
    (center,), _ = view.project([[gx, gy, z]])
    c = tuple(int(round(x)) for x in center)
    size = max(4, round(6 * scale))
    cv2.drawMarker(marked, c, GOAL_RGB, cv2.MARKER_CROSS, size, max(1, round(2 * scale)))
    if depth is not None:  # keep what is in front of the table's plane (1 cm slack)
        d = np.asarray(depth, np.float32).reshape(rgb.shape[:2])
        in_front = d < plane_depth(view, rgb.shape, z) - 0.01
        marked[in_front] = rgb[in_front]
    cv2.putText(  # to the right of the disc, off the box and the tool above it
        marked,
        "goal",
        (int(polygon[:, 0].max()) + round(4 * scale), c[1] + round(5 * scale)),
        cv2.FONT_HERSHEY_SIMPLEX,
        0.5 * scale,
        GOAL_RGB,
        max(1, round(1.5 * scale)),
        cv2.LINE_AA,
    )
    return marked


def head_camera_pose(plant, plant_context) -> RigidTransform:
    """X_WC: the optical frame C of the head camera in the world."""
    return plant.GetFrameByName(HEAD_CAMERA_FRAME).CalcPoseInWorld(plant_context) @ X_HC


class ImageNoise:
    """A LeafSystem mixin: what the image noise systems share (declared by `_declare_noise`):
    an input and an output port of one image type, named alike, the output the input with
    noise drawn from a generator seeded by (seed, time), so a run is repeatable; with `sigma`
    0 the image passes unchanged. A system using it gives `_perturb(data, rng)`, which adds
    its noise to the output's data in place."""

    def _declare_noise(self, port: str, image_type, width, height, sigma: float, seed) -> None:
        self._sigma = sigma
        self._seed = int(seed)
        width, height = int(width), int(height)  # the allocator must not hold self
        self._input = self.DeclareAbstractInputPort(
            port, AbstractValue.Make(image_type(width, height))
        )
        self.DeclareAbstractOutputPort(
            port,
            lambda: AbstractValue.Make(image_type(width, height)),
            weak_method(self._calc),
        )

    def _calc(self, context, output):
        image = self._input.Eval(context)
        out = output.get_mutable_value()
        out.resize(image.width(), image.height())
        data = out.mutable_data
        data[:] = image.data
        if self._sigma > 0:
            rng = np.random.default_rng([self._seed, int(round(context.get_time() * 1e6))])
            self._perturb(data, rng)


class ColorImageNoise(ImageNoise, LeafSystem):
    """Adds zero-mean Gaussian noise of `sigma` grey levels to each colour channel of each
    pixel (then rounds and clips to [0, 255]); the alpha channel passes through. The noise is
    a fixed function of (seed, time), so a run is repeatable.

    .. pydrake_system::

        name: ColorImageNoise
        input_ports:
        - color_image
        output_ports:
        - color_image
    """

    def __init__(self, width: int, height: int, sigma: float, seed: int = 0):
        super().__init__()
        sigma = check_noise_sigma(sigma)
        self._declare_noise("color_image", ImageRgba8U, width, height, sigma, seed)

    def _perturb(self, data, rng):
        rgb = data[:, :, :3].astype(np.float32)
        rgb += rng.normal(0.0, self._sigma, rgb.shape).astype(np.float32)
        data[:, :, :3] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


MAX_DEPTH_NOISE = 0.01  # m


def check_depth_noise(sigma, name: str = "depth noise sigma") -> float:
    """The depth noise: a standard deviation in [0, MAX_DEPTH_NOISE] m."""
    return check_in_range(sigma, 0.0, MAX_DEPTH_NOISE, name, unit="m")


class DepthImageNoise(ImageNoise, LeafSystem):
    """Adds zero-mean Gaussian noise of `sigma` m to each finite depth of a depth image (a
    depth camera's error at the tool's distance; the renderer's depth is exact). The noise is
    a fixed function of (seed, time), so a run is repeatable.

    .. pydrake_system::

        name: DepthImageNoise
        input_ports:
        - depth_image
        output_ports:
        - depth_image
    """

    def __init__(self, width: int, height: int, sigma: float, seed: int = 0):
        super().__init__()
        sigma = check_depth_noise(sigma)
        self._declare_noise("depth_image", ImageDepth32F, width, height, sigma, seed)

    def _perturb(self, data, rng):
        noise = rng.normal(0.0, self._sigma, data.shape).astype(np.float32)
        finite = np.isfinite(data)
        data[finite] += noise[finite]


class ToolLengthEstimator(ViewByViewEstimator, LeafSystem):
    """Measures the tool length from the head camera's images, one view per capture
    (`measure_view`), on the schedule of `ViewByViewEstimator`.

    .. pydrake_system::

        name: ToolLengthEstimator
        input_ports:
        - color_image
        - depth_image
        output_ports:
        - tool_length
        - measurement

    - color_image: ImageRgba8U from the RgbdSensor (or ColorImageNoise).
    - depth_image: ImageDepth32F (m) from the RgbdSensor's `depth_image_32f`.
    - tool_length: [L] (m), the mean over the accepted views captured so far (by `method`);
      NaN until one is accepted.
    - measurement: AbstractValue[ToolLengthMeasurement], every captured view's result (both
      variants, drop reasons), the mean and the spread.

    Args:
        info: the camera's intrinsics (`camera_info(scenario.camera)`).
        views: the views in capture order (what the robot knows of each, see ViewSpec).
        first_capture, capture_period: capture schedule (s).
        method: "depth" (the markers' outer ends found in 3-D with the depth image) or
            "pixel" (the paper's pixel distance x a fixed metres per pixel); both are in the
            `measurement` output either way.
    """

    def __init__(
        self,
        info: CameraInfo,
        views,
        first_capture: float,
        capture_period: float,
        method: str = "depth",
    ):
        super().__init__()
        self._set_views(info, views, "ViewSpec")
        self._method = method = check_one_of(method, METHODS, "method")
        self._declare_captures(
            first_capture,
            capture_period,
            empty=lambda: ToolLengthMeasurement(method=method),
            measure_view=measure_view,
            summary=("tool_length", 1, lambda measurement: [measurement.length()]),
        )
