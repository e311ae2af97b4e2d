"""Writes the project's Baxter model (`models/baxter/baxter.urdf`) from tables of figures.

The kinematic and inertial figures are those of Rethink Robotics' `baxter_description` (as the
`example-robot-data` package ships it): joint origins, axes, position/velocity/effort limits and
link inertias. The structure is the project's own:

- the world frame is Baxter's `base` frame (the frame Rethink's IK service uses);
- the head, sonar ring, hand cameras and gripper fingers are rigid (the head pan is fixed at 0,
  the fingers are closed on the tool); the frames the project uses (`head_camera`,
  `{left,right}_gripper`) are kept;
- visuals are primitive shapes (a link "bone" from each joint to the next, a housing on each
  joint), so nothing depends on the upstream Collada meshes;
- collision geometry only where contact matters for the task: the right forearm, wrist, hand
  and gripper (the tool, table and box are built by `scene.py`);
- only the seven right-arm joints have actuators (transmissions); the left arm's joints are
  revolute so the world can weld them at any pose.

Regenerate with `drake-tooluse generate-models` (a test checks the committed file is current).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drake_tooluse.files import atomic_write_text

HALF_PI = 1.57079632679

ARM_JOINT_SUFFIXES = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
RIGHT_ARM_JOINTS = tuple(f"right_{s}" for s in ARM_JOINT_SUFFIXES)
LEFT_ARM_JOINTS = tuple(f"left_{s}" for s in ARM_JOINT_SUFFIXES)

# (lower, upper, velocity, effort) per arm joint, from baxter_description.
ARM_LIMITS = {
    "s0": (-1.70167993878, 1.70167993878, 1.5, 50.0),
    "s1": (-2.147, 1.047, 1.5, 50.0),
    "e0": (-3.05417993878, 3.05417993878, 1.5, 50.0),
    "e1": (-0.05, 2.618, 1.5, 50.0),
    "w0": (-3.059, 3.059, 4.0, 15.0),
    "w1": (-1.57079632679, 2.094, 4.0, 15.0),
    "w2": (-3.059, 3.059, 4.0, 15.0),
}
# The same limits as arrays in joint order s0 … w2: position (rad) and velocity (rad/s).
Q_LOWER = np.array([ARM_LIMITS[s][0] for s in ARM_JOINT_SUFFIXES])
Q_UPPER = np.array([ARM_LIMITS[s][1] for s in ARM_JOINT_SUFFIXES])
Q_MID = (Q_LOWER + Q_UPPER) / 2
V_MAX = np.array([ARM_LIMITS[s][2] for s in ARM_JOINT_SUFFIXES])
# The conservative limits a real Baxter beside a table keeps (a widely used Baxter IK setup
# narrows s1 to [-1.35, 1.0] rad): the paper's "the real IK is stricter than the sim".
Q_LOWER_CONSERVATIVE = Q_LOWER.copy()
Q_UPPER_CONSERVATIVE = Q_UPPER.copy()
Q_LOWER_CONSERVATIVE[1], Q_UPPER_CONSERVATIVE[1] = -1.35, 1.0
# The left arm's pose (s0 … w2, rad) when it is welded: tucked beside the body.
LEFT_ARM_TUCKED = (-0.6, -1.0, 0.0, 2.0, 0.0, 0.6, 0.0)

# Arm chain per side: (joint suffix, parent link suffix, child link suffix, xyz, rpy).
ARM_CHAIN = (
    ("s0", "arm_mount", "upper_shoulder", (0.055695, 0, 0.011038), (0, 0, 0)),
    ("s1", "upper_shoulder", "lower_shoulder", (0.069, 0, 0.27035), (-HALF_PI, 0, 0)),
    ("e0", "lower_shoulder", "upper_elbow", (0.102, 0, 0), (HALF_PI, 0, HALF_PI)),
    ("e1", "upper_elbow", "lower_elbow", (0.069, 0, 0.26242), (-HALF_PI, -HALF_PI, 0)),
    ("w0", "lower_elbow", "upper_forearm", (0.10359, 0, 0), (HALF_PI, 0, HALF_PI)),
    ("w1", "upper_forearm", "lower_forearm", (0.01, 0, 0.2707), (-HALF_PI, -HALF_PI, 0)),
    ("w2", "lower_forearm", "wrist", (0.115975, 0, 0), (HALF_PI, 0, HALF_PI)),
)
# Fixed frames past the wrist: hand 0.11355 past w2, gripper base 0.025 past the hand, the
# `gripper` endpoint 0.1327 past the gripper base (between the fingertips).
HAND_CHAIN = (
    ("hand", "wrist", "hand", (0, 0, 0.11355), (0, 0, 0)),
    ("gripper_base", "hand", "gripper_base", (0, 0, 0.025), (0, 0, 0)),
    ("endpoint", "gripper_base", "gripper", (0, 0, 0.1327), (0, 0, 0)),
)
ARM_MOUNT_XYZ = {"right": (0.024645, -0.219645, 0.118588), "left": (0.024645, 0.219645, 0.118588)}
ARM_MOUNT_YAW = {"right": -0.7854, "left": 0.7854}

# Link inertials: mass (kg), centre of mass (m), (ixx, ixy, ixz, iyy, iyz, izz) (kg m^2).
ARM_INERTIALS = {
    "upper_shoulder": (
        5.70044,
        (0.01783, 0.00086, 0.19127),
        (0.04709102262, 0.00012787556, 0.00614870039, 0.03766976455, 0.00078086899, 0.03595988478),
    ),
    "lower_shoulder": (
        3.22698,
        (0.06845, 0.00269, -0.00529),
        (0.01175209419, -0.00030096398, 0.00207675762, 0.0278859752, -0.00018821993, 0.02078749298),
    ),
    "upper_elbow": (
        4.31272,
        (-0.00276, 0.00132, 0.18086),
        (0.02661733557, 0.00029270634, 0.00392189887, 0.02844355207, 0.0010838933, 0.01248008322),
    ),
    "lower_elbow": (
        2.07206,
        (0.02611, 0.00159, -0.01117),
        (0.00711582686, 0.00036036173, 0.0007459496, 0.01318227876, -0.00019663418, 0.00926852064),
    ),
    "upper_forearm": (
        2.24665,
        (-0.00168, 0.0046, 0.13952),
        (0.01667742825, 0.00018403705, 0.00018657629, 0.01675457264, -0.00064732352, 0.0037463115),
    ),
    "lower_forearm": (
        1.60979,
        (0.06041, 0.00697, 0.006),
        (0.00387607152, -0.00044384784, -0.00021115038, 0.00700537914, 0.00015348067, 0.0055275524),
    ),
    "wrist": (
        0.35093,
        (0.00198, 0.00125, 0.01855),
        (0.00025289155, 0.00000575311, -0.00000159345, 0.0002688601, -0.00000519818, 0.0003074118),
    ),
    "hand": (
        0.19125,
        (0.01093, 0.00042, -0.01532),
        (0.00017588, 0.00000147073, 0.0000243633, 0.00021166377, 0.00000172689, 0.00023745397),
    ),
    # The gripper base with its two fingers (0.3 kg + 2 x 0.02 kg + 2 x 0.01 kg tips).
    "gripper_base": (0.36, (0, 0, 0.06), (2e-4, 0, 0, 2e-4, 0, 1e-4)),
}
TORSO_INERTIAL = (
    35.336455,
    (0, 0, 0),
    (1.849155, -0.000354, -0.154188, 1.662671, 0.003292, 0.802239),
)
HEAD_INERTIAL = (
    0.547767 + 0.440171,
    (0, 0, 0),
    (0.004641, 0.000159, 0.000242, 0.003295, -0.001324, 0.003415),
)
# The head: pan joint origin on the torso, and the head camera on the head.
HEAD_XYZ = (0.06, 0, 0.686)
HEAD_CAMERA_XYZ = (0.12839, 0, 0.06368)
HEAD_CAMERA_RPY = (1.75057, 0, HALF_PI)

# Colours (rgba): Baxter's red arm shells, dark grey joints and body, black screen.
RED = (0.62, 0.06, 0.06, 1.0)
DARK = (0.18, 0.18, 0.2, 1.0)
BLACK = (0.05, 0.05, 0.05, 1.0)
SCREEN = (0.95, 0.55, 0.1, 1.0)
# URDF materials are named (urdfdom, and so KDL and TRAC-IK, require a name).
MATERIAL_NAMES = {
    RED: "baxter_red",
    DARK: "baxter_dark",
    BLACK: "baxter_black",
    SCREEN: "baxter_screen",
}
# Radius of each arm link's visual "bone" (m).
BONE_RADIUS = {
    "upper_shoulder": 0.07,
    "lower_shoulder": 0.06,
    "upper_elbow": 0.055,
    "lower_elbow": 0.05,
    "upper_forearm": 0.045,
    "lower_forearm": 0.042,
    "wrist": 0.04,
    "hand": 0.04,
}
# Links of the right arm that carry collision geometry.
COLLISION_LINKS = ("lower_forearm", "wrist", "hand")


@dataclass(frozen=True)
class _Shape:
    kind: str  # "box", "cylinder" or "sphere"
    size: tuple
    xyz: tuple
    rpy: tuple = (0, 0, 0)
    rgba: tuple | None = None


def _fmt(values) -> str:
    return " ".join(f"{v:.10g}" for v in values)


def _rpy_aligning_z_with(direction) -> tuple:
    """Roll-pitch-yaw of a frame whose +z points along `direction` (a cylinder's axis)."""
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    pitch = math.atan2(math.hypot(d[0], d[1]), d[2])
    yaw = math.atan2(d[1], d[0])
    # R = Rz(yaw) Ry(pitch) maps +z to d; as URDF rpy that is (0, pitch, yaw).
    return (0.0, pitch, yaw)


def _bone(to_xyz, radius, rgba) -> _Shape:
    """A cylinder from the link origin to `to_xyz`."""
    p = np.asarray(to_xyz, float)
    return _Shape(
        "cylinder", (radius, float(np.linalg.norm(p))), tuple(p / 2), _rpy_aligning_z_with(p), rgba
    )


def _geometry_xml(shape: _Shape) -> str:
    if shape.kind == "box":
        return f'<box size="{_fmt(shape.size)}"/>'
    if shape.kind == "cylinder":
        return f'<cylinder radius="{shape.size[0]:.10g}" length="{shape.size[1]:.10g}"/>'
    return f'<sphere radius="{shape.size[0]:.10g}"/>'


def _link_xml(name, inertial=None, visuals=(), collisions=()) -> str:
    lines = [f'  <link name="{name}">']
    if inertial is not None:
        mass, com, (ixx, ixy, ixz, iyy, iyz, izz) = inertial
        lines += [
            "    <inertial>",
            f'      <origin xyz="{_fmt(com)}" rpy="0 0 0"/>',
            f'      <mass value="{mass:.10g}"/>',
            f'      <inertia ixx="{ixx:.10g}" ixy="{ixy:.10g}" ixz="{ixz:.10g}" '
            f'iyy="{iyy:.10g}" iyz="{iyz:.10g}" izz="{izz:.10g}"/>',
            "    </inertial>",
        ]
    for tag, shapes in (("visual", visuals), ("collision", collisions)):
        for i, s in enumerate(shapes):
            lines += [
                f'    <{tag} name="{name}_{tag}_{i}">',
                f'      <origin xyz="{_fmt(s.xyz)}" rpy="{_fmt(s.rpy)}"/>',
                f"      <geometry>{_geometry_xml(s)}</geometry>",
            ]
            if tag == "visual":
                lines.append(
                    f'      <material name="{MATERIAL_NAMES[s.rgba]}">'
                    f'<color rgba="{_fmt(s.rgba)}"/></material>'
                )
            lines.append(f"    </{tag}>")
    lines.append("  </link>")
    return "\n".join(lines)


def _joint_xml(name, kind, parent, child, xyz, rpy, limits=None) -> str:
    lines = [
        f'  <joint name="{name}" type="{kind}">',
        f'    <parent link="{parent}"/>',
        f'    <child link="{child}"/>',
        f'    <origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>',
    ]
    if kind == "revolute":
        lower, upper, velocity, effort = limits
        lines += [
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{lower:.12g}" upper="{upper:.12g}" '
            f'velocity="{velocity:.10g}" effort="{effort:.10g}"/>',
        ]
    lines.append("  </joint>")
    return "\n".join(lines)


def _transmission_xml(joint) -> str:
    return (
        f'  <transmission name="{joint}_transmission">\n'
        "    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{joint}"><hardwareInterface>EffortJointInterface'
        "</hardwareInterface></joint>\n"
        f'    <actuator name="{joint}_motor"><mechanicalReduction>1</mechanicalReduction>'
        "</actuator>\n  </transmission>"
    )


def _gripper_shapes() -> list[_Shape]:
    """Baxter's electric gripper in the gripper-base frame: a plate and two closed fingers."""
    plate = _Shape("box", (0.05, 0.13, 0.03), (0, 0, 0.01), rgba=DARK)
    fingers = [
        _Shape("box", (0.022, 0.01, 0.1127), (0, y, 0.02 + 0.1127 / 2), rgba=BLACK)
        for y in (-0.0175, 0.0175)
    ]
    return [plate, *fingers]


def _arm_xml(side: str) -> list[str]:
    parts = [_link_xml(f"{side}_arm_mount")]
    parts.append(
        _joint_xml(
            f"{side}_torso_arm_mount",
            "fixed",
            "torso",
            f"{side}_arm_mount",
            ARM_MOUNT_XYZ[side],
            (0, 0, ARM_MOUNT_YAW[side]),
        )
    )
    children = {parent: xyz for _, parent, _, xyz, _ in ARM_CHAIN + HAND_CHAIN}
    for suffix, parent, child, xyz, rpy in ARM_CHAIN:
        link = f"{side}_{child}"
        visuals = [
            _bone(children[child], BONE_RADIUS[child], RED),
            _Shape("cylinder", (BONE_RADIUS[child] * 1.05, 0.11), (0, 0, 0), rgba=DARK),
        ]
        collisions = []
        if side == "right" and child in COLLISION_LINKS:
            collisions = [_bone(children[child], BONE_RADIUS[child], None)]
        parts.append(_link_xml(link, ARM_INERTIALS[child], visuals, collisions))
        parts.append(
            _joint_xml(
                f"{side}_{suffix}",
                "revolute",
                f"{side}_{parent}",
                link,
                xyz,
                rpy,
                ARM_LIMITS[suffix],
            )
        )
    for name, parent, child, xyz, rpy in HAND_CHAIN:
        link = f"{side}_{child}"
        if child == "hand":
            shapes = [_Shape("cylinder", (0.04, 0.05), (0, 0, -0.01), rgba=DARK)]
            inertial, collisions = ARM_INERTIALS["hand"], shapes if side == "right" else []
        elif child == "gripper_base":
            shapes = _gripper_shapes()
            inertial, collisions = ARM_INERTIALS["gripper_base"], shapes if side == "right" else []
        else:  # the endpoint frame: massless, Drake merges it into its parent.
            shapes, inertial, collisions = [], None, []
        parts.append(_link_xml(link, inertial, shapes, collisions))
        parts.append(
            _joint_xml(f"{side}_{name}_joint", "fixed", f"{side}_{parent}", link, xyz, rpy)
        )
    return parts


def baxter_urdf() -> str:
    """The text of the project's Baxter URDF."""
    torso_visuals = [
        _Shape("box", (0.30, 0.34, 0.62), (-0.06, 0, 0.22), rgba=DARK),
        _Shape("cylinder", (0.17, 0.04), (-0.02, 0, -0.11), rgba=BLACK),
        _Shape("cylinder", (0.09, 0.80), (-0.02, 0, -0.52), rgba=DARK),  # pedestal column
        _Shape("box", (0.70, 0.70, 0.06), (-0.02, 0, -0.92), rgba=BLACK),  # pedestal foot
        _Shape("cylinder", (0.13, 0.05), (0.09, 0, 0.80), rgba=DARK),  # sonar ring
    ]
    head_visuals = [
        _Shape("box", (0.03, 0.29, 0.19), (0.11, 0, 0.03), (0, -0.18, 0), BLACK),
        _Shape("box", (0.004, 0.25, 0.15), (0.127, 0, 0.033), (0, -0.18, 0), SCREEN),
        _Shape("cylinder", (0.03, 0.12), (0, 0, -0.06), rgba=DARK),
    ]
    parts = [
        '<?xml version="1.0"?>',
        "<!-- Generated by drake_tooluse/baxter_model.py (`drake-tooluse generate-models`);"
        " do not edit. -->",
        '<robot name="baxter">',
        _link_xml("base"),
        _link_xml("torso", TORSO_INERTIAL, torso_visuals),
        _joint_xml("torso_t0", "fixed", "base", "torso", (0, 0, 0), (0, 0, 0)),
        _link_xml("head", HEAD_INERTIAL, head_visuals),
        _joint_xml("head_pan", "fixed", "torso", "head", HEAD_XYZ, (0, 0, 0)),
        _link_xml("head_camera"),
        _joint_xml(
            "head_camera_joint", "fixed", "head", "head_camera", HEAD_CAMERA_XYZ, HEAD_CAMERA_RPY
        ),
    ]
    for side in ("right", "left"):
        parts += _arm_xml(side)
    parts += [_transmission_xml(j) for j in RIGHT_ARM_JOINTS]
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


def write_models(models_dir: Path) -> Path:
    """Writes `baxter/baxter.urdf` under `models_dir` and returns its path."""
    return atomic_write_text(Path(models_dir) / "baxter" / "baxter.urdf", baxter_urdf())
