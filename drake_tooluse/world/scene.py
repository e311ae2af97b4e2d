"""The world (truth) built from a scenario: Baxter holding the true tool, the table, the box.

- `add_world(builder, scenario)` adds a discrete MultibodyPlant (SAP) + SceneGraph holding
  Baxter with the tool welded in its right gripper (the true tool, `robot.tool`, and grasp), a
  table and a free box. The seven right-arm joints are PD-controlled in the plant; every other joint is welded.
- The robot's belief (a robot-only plant with the *believed* tool) is `robot.model`.

Frames: W = Baxter's `base`; G = `right_gripper` (between the fingertips, +z out of the
fingers); T = `tool_tip` (G translated by the tool length along +z for the nominal grasp).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    Box,
    CollisionFilterDeclaration,
    ProximityProperties,
    RoleAssign,
    Sphere,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import PdControllerGains, SpatialInertia

from drake_tooluse.robot.baxter_model import RIGHT_ARM_JOINTS
from drake_tooluse.robot.model import (
    GRASP_FRAME,
    GRIPPER_FRAME,
    TIP_FRAME,
    TOOL_DOWN_RPY,
    add_baxter,
    add_tip_at_gripper,
    add_tool_body,
    drake_shape,
    load_tool_model,
    rigid_transform,
    tool_grasp_pose,
)
from drake_tooluse.robot.tool import TIP_COLLISION_LENGTH, Tool  # noqa: F401  (offered here)
from drake_tooluse.world.scenario import Scenario

ORANGE = np.array([1.0, 0.45, 0.0, 1.0])
TOOL_RGBA = np.array([0.55, 0.6, 0.68, 1.0])
WOOD_RGBA = np.array([0.72, 0.53, 0.33, 1.0])
TABLE_RGBA = np.array([0.45, 0.33, 0.22, 1.0])
FLOOR_Z = -0.95  # the floor under Baxter's pedestal, in W (m)
# Point contact: the box stands on spheres at its bottom corners (a box on point contact
# otherwise rests on one support point that jumps between its corners).
BOX_CORNER_SPHERE_RADIUS = 0.003


def true_tool(scenario: Scenario) -> Tool | None:
    """The scenario's (true) tool as geometry: its model file's tool, or the rod its
    `ToolConfig` describes; None when no tool is attached."""
    t = scenario.tool
    if not t.attached:
        return None
    if not t.model:
        return t.description()
    if t.model.startswith("package://"):
        return load_tool_model(url=t.model)
    return load_tool_model(t.model)


def add_tool(plant: MultibodyPlant, instance, scenario: Scenario, visuals: bool = True):
    """Welds the scenario's (true) tool (`ToolConfig.description`) to the right gripper at its
    grasp (`robot.model.add_tool_body`) and gives it its geometry (`add_tool_geometry`): for
    the straight rod, a rod from TOOL_HANDLE_DEPTH behind the grasp point to `length` in front
    of it, with orange marker bands at the grip end and at the tip (`visuals`: as
    `add_tool_geometry`'s). Returns the body."""
    t = scenario.tool
    tool = true_tool(scenario)
    body = add_tool_body(
        plant,
        instance,
        tool,
        grasp_across=t.grasp_offset_across,
        grasp_along=t.grasp_offset_along,
    )
    add_tool_geometry(plant, body, tool, visuals)
    return body


def add_tool_geometry(plant: MultibodyPlant, body, tool: Tool, visuals: bool = True) -> None:
    """Registers a tool's geometry on its body, each piece at X_HP in the body frame H: the
    solid pieces as visuals (their colour, or TOOL_RGBA), the marker bands (ORANGE, visual
    only), then the collision pieces (Coulomb friction 0.4). Without `visuals`, the
    collision pieces alone."""
    for piece in tool.pieces() if visuals else ():
        rgba = TOOL_RGBA if piece.rgba is None else np.array(piece.rgba)
        plant.RegisterVisualGeometry(
            body, rigid_transform(piece.X_HP), drake_shape(piece.shape), piece.name, rgba
        )
    for piece in tool.marker_pieces() if visuals else ():
        plant.RegisterVisualGeometry(
            body, rigid_transform(piece.X_HP), drake_shape(piece.shape), piece.name, ORANGE
        )
    props = ProximityProperties()
    AddContactMaterial(friction=CoulombFriction(0.4, 0.4), properties=props)
    for piece in tool.collision_pieces():
        plant.RegisterCollisionGeometry(
            body, rigid_transform(piece.X_HP), drake_shape(piece.shape), piece.name, props
        )


def add_table(plant: MultibodyPlant, scenario: Scenario, visuals: bool = True):
    """The table welded to the world, and the floor under it (collision); without `visuals`,
    no visual geometry (its top and legs)."""
    tb = scenario.table
    sx, sy = tb.size_xy
    X_WTable = RigidTransform([tb.center_xy[0], tb.center_xy[1], tb.top_z - tb.thickness / 2])
    table = plant.AddRigidBody(
        "table",
        plant.AddModelInstance("table"),
        SpatialInertia.SolidBoxWithMass(20.0, sx, sy, tb.thickness),
    )
    plant.WeldFrames(plant.world_frame(), table.body_frame(), X_WTable)
    shape = Box(sx, sy, tb.thickness)
    props = ProximityProperties()
    AddContactMaterial(friction=CoulombFriction(tb.friction, tb.friction), properties=props)
    if scenario.plant.contact_model != "point":
        AddCompliantHydroelasticProperties(0.01, 1e7, props)
    plant.RegisterCollisionGeometry(table, RigidTransform(), shape, "table_collision", props)
    # The floor Baxter's pedestal stands on: a box pushed off the table lands there.
    # (A box rather than a HalfSpace, which Drake warns about for deformable contact.)
    plant.RegisterCollisionGeometry(
        plant.world_body(),
        RigidTransform([0.0, 0.0, FLOOR_Z - 0.05]),
        Box(6.0, 6.0, 0.1),
        "floor_collision",
        props,
    )
    if not visuals:
        return table
    plant.RegisterVisualGeometry(table, RigidTransform(), shape, "table_visual", TABLE_RGBA)
    # Legs down to the floor (visual only).
    leg = tb.top_z - tb.thickness - FLOOR_Z
    for i, (cx, cy) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
        p = [cx * (sx / 2 - 0.04), cy * (sy / 2 - 0.04), -tb.thickness / 2 - leg / 2]
        plant.RegisterVisualGeometry(
            table, RigidTransform(p), Box(0.04, 0.04, leg), f"table_leg_{i}", TABLE_RGBA
        )
    return table


def add_box(plant: MultibodyPlant, scenario: Scenario, visuals: bool = True):
    """A free wooden box. Point contact: corner spheres carry it; its sides take the pushes.
    Without `visuals`, no visual geometry."""
    b = scenario.box
    sx, sy, sz = b.size
    box = plant.AddRigidBody(
        "box", plant.AddModelInstance("box"), SpatialInertia.SolidBoxWithMass(b.mass, sx, sy, sz)
    )
    props = ProximityProperties()
    AddContactMaterial(friction=CoulombFriction(b.friction, b.friction), properties=props)
    if visuals:
        plant.RegisterVisualGeometry(
            box, RigidTransform(), Box(sx, sy, sz), "box_visual", WOOD_RGBA
        )
    if scenario.plant.contact_model == "point":
        r = BOX_CORNER_SPHERE_RADIUS
        lift = 2 * r  # keeps the side geometry clear of the table.
        plant.RegisterCollisionGeometry(
            box, RigidTransform([0, 0, lift / 2]), Box(sx, sy, sz - lift), "box_sides", props
        )
        for i, (cx, cy) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
            p = [cx * (sx / 2 - r), cy * (sy / 2 - r), -sz / 2 + r]
            plant.RegisterCollisionGeometry(
                box, RigidTransform(p), Sphere(r), f"box_corner_{i}", props
            )
    else:
        AddCompliantHydroelasticProperties(0.005, 1e6, props)
        plant.RegisterCollisionGeometry(
            box, RigidTransform(), Box(sx, sy, sz), "box_collision", props
        )
    return box


def initial_box_pose(scenario: Scenario) -> RigidTransform:
    b = scenario.box
    p = np.array(b.position, float)
    if b.on_table:
        p[2] = scenario.table.top_z + b.size[2] / 2
    return RigidTransform(RotationMatrix.MakeZRotation(b.yaw), p)


def home_tip_pose(scenario: Scenario) -> RigidTransform:
    """X_WT of the home pose: the tip above the table, the tool pointing down."""
    x, y = scenario.robot.home_tip_xy
    z = scenario.table.top_z + scenario.robot.home_tip_height
    return RigidTransform(RollPitchYaw(*TOOL_DOWN_RPY), [x, y, z])


def goal_position(scenario: Scenario) -> np.ndarray:
    """x*: the goal of the box centre in W."""
    return initial_box_pose(scenario).translation() + np.asarray(scenario.goal_offset, float)


@dataclass
class World:
    """Handles into the world added by `add_world`."""

    plant: MultibodyPlant
    scene_graph: object
    baxter: object  # ModelInstanceIndex of Baxter + tool
    tool: object  # the tool body, None when no tool is attached
    box: object
    scenario: Scenario

    @property
    def tip_frame(self):
        return self.plant.GetFrameByName(TIP_FRAME)

    @property
    def gripper_frame(self):
        return self.plant.GetFrameByName(GRIPPER_FRAME)

    def arm_joints(self):
        return [self.plant.GetJointByName(n) for n in RIGHT_ARM_JOINTS]


def add_world(builder, scenario: Scenario, visuals: bool = True) -> World:
    """Adds the world (truth) to `builder`: plant + scene graph, finalized, defaults set.
    Without `visuals`, nothing in it has visual geometry (Baxter: `robot.model.add_baxter`):
    for a world that nothing draws or renders (its dynamics are the same, bit for bit).

    Ports to connect (the plant's): `plant.get_desired_state_input_port(world.baxter)` takes
    [q_d (7), v_d (7)] of the right arm; `plant.get_actuation_input_port(world.baxter)` takes a
    feed-forward torque (7, N·m) added to the PD output (the sum is clipped to the effort limits).
    """
    plant, scene_graph = AddMultibodyPlant(scenario.plant, builder)
    baxter = add_baxter(plant, scenario.robot.left_arm_q, visuals=visuals)
    if scenario.tool.attached:
        tool = add_tool(plant, baxter, scenario, visuals)
    else:
        tool = None
        add_tip_at_gripper(plant, baxter)
    # Baxter's own controller compensates gravity (with the spring assist on s1, whose 50 N·m
    # limit alone could not hold the outstretched arm): modelled as ideal, gravity off for the
    # robot and the tool it holds. The box feels gravity.
    plant.set_gravity_enabled(baxter, False)
    add_table(plant, scenario, visuals)
    box = add_box(plant, scenario, visuals)
    for name, kp, kd in zip(RIGHT_ARM_JOINTS, scenario.control.kp, scenario.control.kd):
        plant.GetJointActuatorByName(f"{name}_motor").set_controller_gains(
            PdControllerGains(p=kp, d=kd)
        )
    plant.Finalize()
    _filter_robot_self_collisions(plant, scene_graph, baxter)
    for joint, q in zip(
        [plant.GetJointByName(n) for n in RIGHT_ARM_JOINTS], scenario.robot.posture_seed
    ):
        joint.set_default_angle(q)  # callers set the solved home pose (builders.control).
    plant.SetDefaultFloatingBaseBodyPose(box, initial_box_pose(scenario))
    return World(plant, scene_graph, baxter, tool, box, scenario)


def _filter_robot_self_collisions(plant, scene_graph, baxter) -> None:
    """The robot's own links and the tool never collide with each other (they are one grasp)."""
    bodies = [plant.get_body(i) for i in plant.GetBodyIndices(baxter)]
    geometries = plant.CollectRegisteredGeometries(bodies)
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration().ExcludeWithin(geometries)
    )


def set_randomized_state(world: World, root_context, scenario: Scenario) -> None:
    """Puts what a randomization draw changes (`world.randomization.apply_draw`) into a context
    of the world's diagram: the box's start pose, its mass and friction, and the true grasp.
    `scenario` is the world's own with a draw applied."""
    plant = world.plant
    plant_context = plant.GetMyMutableContextFromRoot(root_context)
    plant.SetFreeBodyPose(plant_context, world.box, initial_box_pose(scenario))
    world.box.SetMass(plant_context, scenario.box.mass)
    _set_box_friction(world, root_context, scenario.box.friction)
    if world.tool is not None:
        t = scenario.tool
        plant.GetFrameByName(GRASP_FRAME).SetPoseInParentFrame(
            plant_context, tool_grasp_pose(t.grasp_offset_across, t.grasp_offset_along)
        )


def _set_box_friction(world: World, root_context, friction: float) -> None:
    sg = world.scene_graph
    sg_context = sg.GetMyMutableContextFromRoot(root_context)
    inspector = sg.model_inspector()
    for gid in world.plant.GetCollisionGeometriesForBody(world.box):
        props = ProximityProperties(inspector.GetProximityProperties(gid))
        props.UpdateProperty("material", "coulomb_friction", CoulombFriction(friction, friction))
        sg.AssignRole(sg_context, world.plant.get_source_id(), gid, props, RoleAssign.kReplace)
