"""The robot's kinematics: Baxter from the project's URDF, and a tool welded in its right hand.

- `add_baxter(plant, left_arm_q)` adds Baxter, its base welded to the world, the left arm
  welded at a pose.
- `add_tool_body(plant, baxter, ...)` welds a straight rod (inertia and frames, no geometry) to
  the right gripper at a grasp, with a `tool_tip` frame at its tip. The world (`world.scene`)
  gives the same body its visual and collision geometry.
- `make_robot_model(tool_length)` builds the robot as the controller believes it: a plant with
  no geometry and a tool-tip frame at the *believed* length; the IK runs on it, as a controller
  plant does in Drake's own examples.

Frames: W = Baxter's `base`; G = `right_gripper` (between the fingertips, +z out of the
fingers); T = `tool_tip` (G translated by the tool length along +z for the nominal grasp).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, SpatialInertia

from drake_tooluse.paths import BAXTER_URL, MODELS_DIR
from drake_tooluse.robot.baxter_model import LEFT_ARM_JOINTS, LEFT_ARM_TUCKED, RIGHT_ARM_JOINTS
from drake_tooluse.robot.tool import check_tool_length
from drake_tooluse.validation import check_in_range

GRIPPER_FRAME = "right_gripper"
TIP_FRAME = "tool_tip"
GRASP_FRAME = "tool_grasp"
# The tool pointing straight down (z_T = -z_W), the fingers' closing axis along W's x.
TOOL_DOWN_RPY = (np.pi, 0.0, np.pi / 2)
# The rod reaches this far into the closed fingers behind the grasp point (m).
TOOL_HANDLE_DEPTH = 0.03
# Defaults of a tool the robot believes in (the geometry does not matter to it).
DEFAULT_TOOL_RADIUS = 0.006  # m
DEFAULT_TOOL_MASS = 0.05  # kg


@dataclass(frozen=True)
class RobotBelief:
    """What the robot believes of the tool it holds: its length (m; None: no tool) and where
    the hand holds it, (across, along) m from the gripper frame's origin (as the scenario's
    `tool.grasp_offset_across/along`). The camera measures the length and the grasp along
    the tool (`builders.measurement.measure_belief`); a robot told nothing believes the
    nominal grasp (0, 0)."""

    tool_length: float | None
    grasp_offset: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        if self.tool_length is not None:
            object.__setattr__(
                self, "tool_length", check_tool_length(self.tool_length, "believed tool length")
            )
        across, along = (float(v) for v in self.grasp_offset)
        object.__setattr__(
            self,
            "grasp_offset",
            (
                check_in_range(across, -0.01, 0.01, "believed grasp offset across", unit="m"),
                check_in_range(along, -0.03, 0.03, "believed grasp offset along", unit="m"),
            ),
        )


def make_parser(plant: MultibodyPlant) -> Parser:
    """A parser that resolves `package://drake_tooluse/...` to the project's models."""
    package_xml = MODELS_DIR / "package.xml"
    if not package_xml.is_file():
        raise FileNotFoundError(
            f"the project's models are missing: {package_xml} (reinstall "
            "the package: its wheel carries them)"
        )
    parser = Parser(plant)
    parser.package_map().AddPackageXml(str(package_xml))
    return parser


def _weld_joints(plant: MultibodyPlant, names, angles) -> None:
    """Replaces each revolute joint by a weld at the given angle (rad)."""
    for name, angle in zip(names, angles):
        joint = plant.GetJointByName(name)
        frame_on_parent, frame_on_child = joint.frame_on_parent(), joint.frame_on_child()
        axis = np.asarray(joint.revolute_axis(), float)
        plant.RemoveJoint(joint)
        X_FM = RigidTransform(RotationMatrix(AngleAxis(angle, axis / np.linalg.norm(axis))))
        plant.WeldFrames(frame_on_parent, frame_on_child, X_FM)


def add_baxter(plant: MultibodyPlant, left_arm_q, right_arm_q=None):
    """Adds Baxter with its base welded to the world; the left arm is welded at `left_arm_q`.

    If `right_arm_q` is given, the right arm is welded too (used for fixed-pose scenes).
    Returns the model instance.
    """
    (baxter,) = make_parser(plant).AddModels(url=BAXTER_URL)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base", baxter))
    _weld_joints(plant, LEFT_ARM_JOINTS, left_arm_q)
    if right_arm_q is not None:
        for name in RIGHT_ARM_JOINTS:
            plant.RemoveJointActuator(plant.GetJointActuatorByName(f"{name}_motor"))
        _weld_joints(plant, RIGHT_ARM_JOINTS, right_arm_q)
    return baxter


def tool_grasp_pose(grasp_across: float, grasp_along: float) -> RigidTransform:
    """X_GH: pose of the tool's handle frame H (at the grasp point, axis +z) in the gripper G,
    the grasp point `grasp_across` m along G's x and `grasp_along` m along its z."""
    return RigidTransform([grasp_across, 0.0, grasp_along])


def tool_center(length: float) -> np.ndarray:
    """p_HC: the rod's centre in the tool frame (it runs from TOOL_HANDLE_DEPTH behind the grasp
    point to `length` in front of it)."""
    return np.array([0.0, 0.0, (length - TOOL_HANDLE_DEPTH) / 2])


def add_tool_body(
    plant: MultibodyPlant,
    instance,
    length: float,
    *,
    grasp_across: float = 0.0,
    grasp_along: float = 0.0,
    radius: float = DEFAULT_TOOL_RADIUS,
    mass: float = DEFAULT_TOOL_MASS,
):
    """Welds a straight rod (a solid cylinder's inertia, no geometry) to the right gripper at the
    grasp (see `tool_grasp_pose`), and adds the `tool_tip` frame at its tip. The grasp is a
    frame of its own (`tool_grasp`) so that a context can move it (domain randomization).
    Returns the tool body."""
    total = length + TOOL_HANDLE_DEPTH
    M = SpatialInertia.SolidCylinderWithMass(mass, radius, total, [0.0, 0.0, 1.0])
    M = M.Shift(-tool_center(length))  # the cylinder's centre is at p_HC in the tool frame.
    tool = plant.AddRigidBody("tool", instance, M)
    gripper = plant.GetFrameByName(GRIPPER_FRAME, instance)
    grasp = plant.AddFrame(
        FixedOffsetFrame(GRASP_FRAME, gripper, tool_grasp_pose(grasp_across, grasp_along))
    )
    plant.WeldFrames(grasp, tool.body_frame(), RigidTransform())
    plant.AddFrame(
        FixedOffsetFrame(TIP_FRAME, tool.body_frame(), RigidTransform([0.0, 0.0, length]))
    )
    return tool


def add_tip_at_gripper(plant: MultibodyPlant, instance) -> None:
    """No tool: the `tool_tip` frame is the gripper frame."""
    plant.AddFrame(
        FixedOffsetFrame(TIP_FRAME, plant.GetFrameByName(GRIPPER_FRAME, instance), RigidTransform())
    )


def make_robot_model(
    tool_length: float | None, left_arm_q=LEFT_ARM_TUCKED, grasp_offset=(0.0, 0.0)
) -> MultibodyPlant:
    """The robot as the controller believes it: Baxter + a `tool_tip` frame `tool_length` m
    past the grasp point (None: no tool, the tip frame is the gripper frame), the grasp point
    `grasp_offset` = (across, along) m from the gripper frame's origin (as the scenario's
    `tool.grasp_offset_across/along`; the camera can estimate it, see
    `builders.measurement`). Finalized, continuous, no geometry."""
    plant = MultibodyPlant(time_step=0.0)
    baxter = add_baxter(plant, left_arm_q)
    if tool_length is None:
        add_tip_at_gripper(plant, baxter)
    else:
        belief = RobotBelief(tool_length, tuple(grasp_offset))
        across, along = belief.grasp_offset
        add_tool_body(plant, baxter, belief.tool_length, grasp_across=across, grasp_along=along)
    plant.Finalize()
    return plant
