"""Measuring where the box starts with a camera on Baxter's hand, as the robot stands at home.

```
world at home (the robot's own home configuration for the tool it believes it holds)
   └─► SceneGraph ─► RgbdSensor (hand_camera, on right_gripper) ─depth─► perception.box
```

The head camera does not see the table in front of the robot (the box lies below its image),
so the robot looks with a camera fixed on its hand (Baxter has one in each hand; this model's
URDF leaves them out): 3 cm beside the gripper, tilted down at the table ahead of the tool's
tip. The camera pose comes from the robot's forward kinematics, which does not depend on the
tool (the camera is on the hand), so neither the tool's length nor its grasp biases the box's
position; the depth image is the renderer's, noise-free (the scenario's noise is on colour).
"""

from __future__ import annotations

from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.sensors import CameraInfo

from drake_tooluse.builders.control import add_world_at_home
from drake_tooluse.perception.box import BoxMeasurement, measure_box
from drake_tooluse.robot.model import GRIPPER_FRAME, RobotBelief
from drake_tooluse.systems.camera import add_rgbd_sensor
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.world.scenario import Scenario

# X_GC: the hand camera in the gripper frame G, fixed; found once (rounded) from `look_at` with
# the eye 3 cm beside and 2 cm above the gripper at the nominal home pose (0.175 m tool), the
# target 3 cm past the nominal box start along the push: the table ahead of the tip in view.
X_GC = RigidTransform(RollPitchYaw(0.33, 0.0, 2.129), [0.0, 0.03, -0.02])
HAND_CAMERA = CameraInfo(640, 480, 1.2)  # width, height (pixels), vertical field of view (rad)
TIP_CLEARANCE = 0.02  # m: points this close under the tool's tip may be the tool


def measure_box_start(scenario: Scenario, belief: RobotBelief | None = None) -> BoxMeasurement:
    """The box's start in `scenario`, measured by the hand camera with the arm at the home
    configuration the robot computes for `belief` (default: the scenario's nominal tool)."""
    builder = DiagramBuilder()
    world, _, _ = add_world_at_home(builder, scenario, belief)
    gripper = world.plant.GetBodyByName(GRIPPER_FRAME)
    sensor = add_rgbd_sensor(
        builder,
        world,
        "hand_camera",
        body=gripper,
        X_BC=X_GC,
        info=HAND_CAMERA,
        clipping=(0.02, 3.0),
        depth_range=(0.03, 2.0),
        renderer="hand_camera_vtk",
    )
    diagram = builder.Build()
    try:
        context = diagram.CreateDefaultContext()
        depth = sensor.depth_image_32F_output_port().Eval(sensor.GetMyContextFromRoot(context))
        plant_context = world.plant.GetMyContextFromRoot(context)
        X_WC = gripper.EvalPoseInWorld(plant_context) @ X_GC
        # Look below the tool's tip at home (the tool itself is higher up).
        max_height = scenario.robot.home_tip_height - TIP_CLEARANCE
        return measure_box(
            depth.data, HAND_CAMERA, X_WC, scenario.table.top_z, max_height, scenario.box.size[:2]
        )
    finally:
        release_diagram(diagram)
