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

import copy
import math

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


def add_scene_camera(builder, world, width: int = 480, height: int = 360):
    """A fixed colour camera looking at the table from the robot's front right (the envs'
    `render_mode="rgb_array"`, the demo's final scene); exports its `color_image` port.
    Returns the sensor."""
    sensor = add_rgbd_sensor(
        builder,
        world,
        "render_camera",
        body=world.plant.world_body(),
        # In front of the robot, to its right, looking at the work area of the table.
        X_BC=look_at([1.35, -0.85, 0.35], [0.55, -0.15, -0.12]),
        info=CameraInfo(width, height, 0.9),
        clipping=(0.05, 10.0),
        depth_range=(0.05, 10.0),
        renderer="render_camera",
    )
    builder.ExportOutput(sensor.color_image_output_port(), "color_image")
    return sensor


def head_camera_pose(plant, plant_context) -> RigidTransform:
    """X_WC: the optical frame C of the head camera in the world."""
    return plant.GetFrameByName(HEAD_CAMERA_FRAME).CalcPoseInWorld(plant_context) @ X_HC


class ColorImageNoise(LeafSystem):
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
        self._sigma = check_noise_sigma(sigma)
        self._seed = int(seed)
        self._width, self._height = int(width), int(height)
        self._input = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U(self._width, self._height))
        )
        width, height = self._width, self._height  # the allocator must not hold self
        self.DeclareAbstractOutputPort(
            "color_image",
            lambda: AbstractValue.Make(ImageRgba8U(width, height)),
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
            rgb = image.data[:, :, :3].astype(np.float32)
            rgb += rng.normal(0.0, self._sigma, rgb.shape).astype(np.float32)
            data[:, :, :3] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


class ToolLengthEstimator(LeafSystem):
    """Measures the tool length from the head camera's images, one view per capture.

    At the capture times t_k = first_capture + k * capture_period (k = 0 .. len(views) - 1,
    when the arm holds view k still) it measures view k from the current images
    (`measure_view`) and keeps the result in its abstract state; later times do nothing. The
    outputs are computed from that state, so they hold between captures.

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
        self._info = info
        self._views = list(views)
        if not self._views:
            raise ValueError("views is empty; give at least one ViewSpec")
        self._method = check_one_of(method, METHODS, "method")
        check_in_range(first_capture, 0.0, math.inf, "first_capture", unit="s")
        check_in_range(capture_period, 1e-3, math.inf, "capture_period", unit="s")
        w, h = info.width(), info.height()
        self._color = self.DeclareAbstractInputPort(
            "color_image", AbstractValue.Make(ImageRgba8U(w, h))
        )
        self._depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(w, h))
        )
        self._state = self.DeclareAbstractState(
            AbstractValue.Make(ToolLengthMeasurement(method=self._method))
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            capture_period, first_capture, weak_method(self._capture)
        )
        state = {self.abstract_state_ticket(self._state)}
        self.DeclareVectorOutputPort(
            "tool_length", 1, weak_method(self._calc_length), prerequisites_of_calc=state
        )
        method = self._method  # the allocator must not hold self
        self.DeclareAbstractOutputPort(
            "measurement",
            lambda: AbstractValue.Make(ToolLengthMeasurement(method=method)),
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
        result = measure_view(color, depth, self._info, self._views[k])
        updated = copy.copy(measurement)
        updated.views = measurement.views + [result]
        state.get_mutable_abstract_state(self._state).set_value(updated)

    def _calc_length(self, context, output):
        output.SetAtIndex(0, context.get_abstract_state(self._state).get_value().length())

    def _calc_measurement(self, context, output):
        output.set_value(context.get_abstract_state(self._state).get_value())
