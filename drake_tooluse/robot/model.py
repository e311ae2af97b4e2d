"""The robot's kinematics: Baxter from the project's URDF, and a tool welded in its right hand.

- `add_baxter(plant, left_arm_q)` adds Baxter, its base welded to the world, the left arm
  welded at a pose.
- `add_tool_body(plant, baxter, tool, ...)` welds a tool (`robot.tool`: its inertia and named
  frames, no geometry) to the right gripper at a grasp. The world (`world.scene`) gives the
  same body its visual and collision geometry (`drake_shape`, `rigid_transform`).
- `make_robot_model(tool)` builds the robot as the controller believes it: a plant with no
  geometry and the *believed* tool's frames; the IK runs on it, as a controller plant does in
  Drake's own examples. `RobotBelief` holds the believed tool and grasp.
- `load_tool_model(file)` reads a tool from an SDF/URDF model file (one body, named frames).

Frames: W = Baxter's `base`; G = `right_gripper` (between the fingertips, +z out of the
fingers); H = `tool_grasp`, the tool's handle frame (G moved by the grasp offset); T =
`tool_tip` (G translated by the tool length along +z for a straight tool and the nominal
grasp); each other named frame F of the tool under its own name, at X_HF.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from xml.etree import ElementTree

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.geometry import Box, Convex, Cylinder, Mesh, SceneGraph
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, SpatialInertia, UnitInertia

from drake_tooluse.paths import BAXTER_URDF, BAXTER_URL, MODELS_DIR
from drake_tooluse.robot.baxter_model import LEFT_ARM_JOINTS, LEFT_ARM_TUCKED, RIGHT_ARM_JOINTS
from drake_tooluse.robot.tool import (
    DEFAULT_TOOL_MASS,
    DEFAULT_TOOL_RADIUS,
    GRASP,
    TOOL_HANDLE_DEPTH,
    BoxShape,
    CompositeTool,
    CylinderShape,
    MassProperties,
    MeshShape,
    Piece,
    Pose,
    StraightTool,
    Tool,
    check_tool_length,
)
from drake_tooluse.validation import check_in_range

GRIPPER_FRAME = "right_gripper"
TIP_FRAME = "tool_tip"
GRASP_FRAME = "tool_grasp"  # the tool's `grasp` frame H in a plant
# The tool pointing straight down (z_T = -z_W), the fingers' closing axis along W's x.
TOOL_DOWN_RPY = (np.pi, 0.0, np.pi / 2)


def as_tool(tool, name: str = "tool length") -> Tool | None:
    """A tool description from a `Tool`, a length (m: a `StraightTool`) or None (no tool)."""
    if tool is None or isinstance(tool, Tool):
        return tool
    return StraightTool(check_tool_length(tool, name))


@dataclass(frozen=True, init=False)
class RobotBelief:
    """What the robot believes of the tool it holds: the tool (a `robot.tool.Tool`; a length in
    m means a `StraightTool`; None: no tool) and where the hand holds it, (across, along) m
    from the gripper frame's origin (as the scenario's `tool.grasp_offset_across/along`). The
    camera measures the length and the grasp along the tool
    (`builders.measurement.measure_belief`); a robot told nothing believes the nominal grasp
    (0, 0). `RobotBelief(0.175)`, `RobotBelief(tool_length=0.175)` and
    `RobotBelief(StraightTool(0.175))` are the same belief."""

    tool: Tool | None
    grasp_offset: tuple[float, float] = (0.0, 0.0)

    def __init__(self, tool=None, grasp_offset=(0.0, 0.0), *, tool_length=None):
        if tool_length is not None:
            if tool is not None:
                raise ValueError("give the believed tool or its tool_length, not both")
            tool = tool_length
        object.__setattr__(self, "tool", as_tool(tool, "believed tool length"))
        across, along = (float(v) for v in grasp_offset)
        object.__setattr__(
            self,
            "grasp_offset",
            (
                check_in_range(across, -0.01, 0.01, "believed grasp offset across", unit="m"),
                check_in_range(along, -0.03, 0.03, "believed grasp offset along", unit="m"),
            ),
        )

    @property
    def tool_length(self) -> float | None:
        """The believed tool's length (m; `Tool.reach`), None without a tool."""
        return None if self.tool is None else self.tool.reach()


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


@functools.cache
def _baxter_without_visuals() -> str:
    """Baxter's URDF without its visual geometry (read once)."""
    root = ElementTree.parse(BAXTER_URDF).getroot()
    for link in root.iter("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
    return ElementTree.tostring(root, encoding="unicode")


def add_baxter(plant: MultibodyPlant, left_arm_q, right_arm_q=None, visuals: bool = True):
    """Adds Baxter with its base welded to the world; the left arm is welded at `left_arm_q`.

    If `right_arm_q` is given, the right arm is welded too (used for fixed-pose scenes).
    Without `visuals`, its links carry no visual geometry: a world nothing draws or renders
    (its dynamics are the same, bit for bit: `tests/world/test_scene.py`), built ~7 ms sooner
    (SceneGraph registers each of the 44 visuals). Returns the model instance.
    """
    parser = make_parser(plant)
    if visuals:
        (baxter,) = parser.AddModels(url=BAXTER_URL)
    else:
        (baxter,) = parser.AddModelsFromString(_baxter_without_visuals(), "urdf")
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
    """p_HC: a straight rod's centre in H (as `StraightTool.center`: the rod runs from
    TOOL_HANDLE_DEPTH behind the grasp point to `length` in front of it)."""
    return np.array([0.0, 0.0, (length - TOOL_HANDLE_DEPTH) / 2])


def rigid_transform(X: Pose) -> RigidTransform:
    """A `robot.tool.Pose` as a Drake RigidTransform (the same floats)."""
    if X.is_translation():
        return RigidTransform(np.array(X.translation))
    return RigidTransform(RotationMatrix(np.array(X.rotation)), np.array(X.translation))


def drake_shape(shape):
    """A piece's shape as Drake geometry (a cylinder's axis along its frame's +z)."""
    if isinstance(shape, CylinderShape):
        return Cylinder(shape.radius, shape.length)
    if isinstance(shape, BoxShape):
        return Box(*shape.size)
    if isinstance(shape, MeshShape):
        return Convex(shape.path) if shape.convex else Mesh(shape.path)
    raise ValueError(f"no Drake shape for {shape!r}")


def tool_spatial_inertia(tool: Tool) -> SpatialInertia:
    """M_BHo_H: the tool's spatial inertia about H's origin, in H: given outright
    (`Tool.mass_properties`), or the sum of its solid pieces' (solid cylinders and boxes of
    `Tool.piece_masses`)."""
    given = tool.mass_properties()
    if given is not None:
        return SpatialInertia(given.mass, np.array(given.p_HScm), UnitInertia(*given.G_SHo_H))
    total = None
    for piece, mass in zip(tool.pieces(), tool.piece_masses()):
        shape = piece.shape
        if isinstance(shape, CylinderShape):
            M = SpatialInertia.SolidCylinderWithMass(
                mass, shape.radius, shape.length, [0.0, 0.0, 1.0]
            )
        else:
            M = SpatialInertia.SolidBoxWithMass(mass, *shape.size)
        if not piece.X_HP.is_translation():
            M = M.ReExpress(RotationMatrix(np.array(piece.X_HP.rotation)))
        M = M.Shift(-np.array(piece.X_HP.translation))  # about Po -> about Ho
        if total is None:
            total = M
        else:
            total += M
    return total


def plant_frame_name(name: str) -> str:
    """A tool frame's name in a plant: `grasp` is `tool_grasp`, the others keep theirs."""
    return GRASP_FRAME if name == GRASP else name


def add_tool_body(
    plant: MultibodyPlant,
    instance,
    tool,
    *,
    grasp_across: float = 0.0,
    grasp_along: float = 0.0,
    radius: float | None = None,
    mass: float | None = None,
):
    """Welds a tool (a `robot.tool.Tool`; a length in m: `StraightTool(length, radius, mass)`)
    to the right gripper at the grasp (see `tool_grasp_pose`): a body named `tool` with the
    tool's inertia (`tool_spatial_inertia`), no geometry. The grasp is a frame of its own
    (`tool_grasp`, H) so that a context can move it (domain randomization); each other named
    frame F of the tool is a FixedOffsetFrame at X_HF on the body (`tool_tip`, ...). Returns
    the tool body."""
    if not isinstance(tool, Tool):
        tool = StraightTool(
            tool,
            radius=DEFAULT_TOOL_RADIUS if radius is None else radius,
            mass=DEFAULT_TOOL_MASS if mass is None else mass,
        )
    elif radius is not None or mass is not None:
        raise ValueError("radius and mass are a tool description's own: give them to the tool")
    frames = tool.frames()
    for name in [GRASP_FRAME, *(plant_frame_name(n) for n in frames if n != GRASP)]:
        if plant.HasFrameNamed(name, instance):
            raise ValueError(f"the plant already has a frame named {name!r}: rename the tool's")
    body = plant.AddRigidBody("tool", instance, tool_spatial_inertia(tool))
    gripper = plant.GetFrameByName(GRIPPER_FRAME, instance)
    grasp = plant.AddFrame(
        FixedOffsetFrame(GRASP_FRAME, gripper, tool_grasp_pose(grasp_across, grasp_along))
    )
    plant.WeldFrames(grasp, body.body_frame(), RigidTransform())
    for name, X_HF in frames.items():
        if name != GRASP:
            plant.AddFrame(FixedOffsetFrame(name, body.body_frame(), rigid_transform(X_HF)))
    return body


def add_tip_at_gripper(plant: MultibodyPlant, instance) -> None:
    """No tool: the `tool_tip` frame is the gripper frame."""
    plant.AddFrame(
        FixedOffsetFrame(TIP_FRAME, plant.GetFrameByName(GRIPPER_FRAME, instance), RigidTransform())
    )


def make_robot_model(tool, left_arm_q=LEFT_ARM_TUCKED, grasp_offset=(0.0, 0.0)) -> MultibodyPlant:
    """The robot as the controller believes it: Baxter + the believed `tool` (a
    `robot.tool.Tool`; a length in m: a `StraightTool`; None: no tool, the `tool_tip` frame
    is the gripper frame) with all its named frames, the grasp point `grasp_offset` =
    (across, along) m from the gripper frame's origin (as the scenario's
    `tool.grasp_offset_across/along`; the camera can estimate it, see
    `builders.measurement`). Finalized, continuous, no geometry."""
    belief = RobotBelief(tool, tuple(grasp_offset))
    plant = MultibodyPlant(time_step=0.0)
    baxter = add_baxter(plant, left_arm_q)
    if belief.tool is None:
        add_tip_at_gripper(plant, baxter)
    else:
        across, along = belief.grasp_offset
        add_tool_body(plant, baxter, belief.tool, grasp_across=across, grasp_along=along)
    plant.Finalize()
    return plant


def load_tool_model(filename=None, *, url: str | None = None) -> CompositeTool:
    """A tool read from a model file (SDFormat or URDF; `filename`, or a `package://` `url`)
    with Drake's parser: one model of one body, its named frames (a `grasp` frame is H; without
    one, the body frame is), a `tool_tip` frame among them. The inertia is the file's; its
    cylinders and boxes are the pieces (visual: the solids; collision), other shapes are an
    error. Raises ValueError naming what is missing."""
    if (filename is None) == (url is None):
        raise ValueError("give the tool model's filename or its url, one of them")
    where = str(filename) if url is None else url
    plant = MultibodyPlant(time_step=0.0)
    scene_graph = SceneGraph()
    plant.RegisterAsSourceForSceneGraph(scene_graph)
    parser = make_parser(plant)
    try:
        instances = (
            parser.AddModels(file_name=str(filename)) if url is None else parser.AddModels(url=url)
        )
    except RuntimeError as e:
        raise ValueError(f"tool model {where!r} cannot be parsed: {e}") from None
    if len(instances) != 1:
        raise ValueError(f"tool model {where!r} must hold one model, not {len(instances)}")
    (instance,) = instances
    bodies = plant.GetBodyIndices(instance)
    if len(bodies) != 1:
        raise ValueError(f"tool model {where!r} must hold one body, not {len(bodies)}")
    body = plant.get_body(bodies[0])
    plant.Finalize()
    context = plant.CreateDefaultContext()
    B = body.body_frame()
    X_BF = {}
    for index in plant.GetFrameIndices(instance):
        frame = plant.get_frame(index)
        if frame.index() == B.index() or frame.name().startswith("__"):
            continue
        if frame.body().index() != body.index():
            raise ValueError(f"tool model {where!r}: frame {frame.name()!r} is not on its body")
        X_BF[frame.name()] = plant.CalcRelativeTransform(context, B, frame)
    X_HB = X_BF[GRASP].inverse() if GRASP in X_BF else RigidTransform()
    frames = {name: Pose.from_matrix((X_HB @ X).GetAsMatrix4()) for name, X in X_BF.items()}
    if TIP_FRAME not in frames:
        raise ValueError(
            f"tool model {where!r} has no {TIP_FRAME!r} frame (its frames: {list(frames)})"
        )
    M = body.default_spatial_inertia().ReExpress(X_HB.rotation()).Shift(-X_HB.translation())
    G = M.get_unit_inertia()
    inertia = MassProperties(
        M.get_mass(), tuple(M.get_com()), (*G.get_moments(), *G.get_products())
    )
    inspector = scene_graph.model_inspector()

    def pieces(geometry_ids):
        out = []
        for gid in geometry_ids:
            name = inspector.GetName(gid).rsplit("::", 1)[-1]
            shape = inspector.GetShape(gid)
            if isinstance(shape, Cylinder):
                piece_shape = CylinderShape(shape.radius(), shape.length())
            elif isinstance(shape, Box):
                piece_shape = BoxShape((shape.width(), shape.depth(), shape.height()))
            elif isinstance(shape, (Mesh, Convex)) and shape.source().is_path():
                if shape.scale() != 1.0 or shape.extension() != ".obj":
                    raise ValueError(
                        f"tool model {where!r}: mesh {name!r} must be an OBJ file in metres "
                        "(scale 1)"
                    )
                piece_shape = MeshShape(str(shape.source().path()), isinstance(shape, Convex))
            else:
                raise ValueError(
                    f"tool model {where!r}: geometry {name!r} is a {type(shape).__name__}; "
                    "a tool's pieces are cylinders, boxes and OBJ meshes"
                )
            X_HP = Pose.from_matrix((X_HB @ inspector.GetPoseInFrame(gid)).GetAsMatrix4())
            props = inspector.GetIllustrationProperties(gid)
            rgba = None
            if props is not None and props.HasProperty("phong", "diffuse"):
                rgba = tuple(props.GetProperty("phong", "diffuse").rgba)
            out.append(Piece(name, piece_shape, X_HP, rgba))
        return tuple(out)

    return CompositeTool(
        frames,
        solids=pieces(plant.GetVisualGeometriesForBody(body)),
        collisions=pieces(plant.GetCollisionGeometriesForBody(body)),
        inertia=inertia,
    )
