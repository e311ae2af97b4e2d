"""Physical sanity of a task's world, read every step: how far the tool and the gripper are inside
the table, how fast the object (the push task's box, the pull task's cube) and the arm's joints
move, and which of these is past its limit. Every task's env reports them (`PHYSICAL_LIMITS`).

A policy that drives the simulation where its contact model no longer holds (a tool deep in the
table, a box launched, a joint spinning) can still earn reward there; these figures let an
evaluation count such episodes (`PHYSICAL_LIMITS`, read by `learning.evaluate` through the
task contract) instead of trusting them.

Penetration into the table: how far a body's lowest collision point lies below the table's top
surface (m, 0 when above it), counted where the geometry's centre is over the table's footprint.
It is measured from the geometry (each collision shape's extent along −z), not from contact
results: a point contact between a thin cylinder and the 4 cm table is lost once the cylinder
has passed through it, where the depth below the top still tells.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import Box, Cylinder, Sphere

from drake_tooluse.robot.baxter_model import RIGHT_ARM_JOINTS
from drake_tooluse.tasks.contract import PhysicalLimit
from drake_tooluse.world.scene import World

# Limits: a step past one is flagged in `info` (the flag names are PHYSICAL_LIMITS').
# Point contact lets a tool pressed onto the table sink in a few mm (the shipped policies'
# episodes peak at 3.1 mm: `drake-tooluse evaluate --per-episode --json`, peak_* figures);
# 5 mm in means the arm is overpowering the contact, not touching the table.
TABLE_PENETRATION_LIMIT = 0.005  # m
# The tool's target moves at most 0.02 m per 40 ms step (0.5 m/s): an object at twice that was
# launched (struck by a flailing arm, or squeezed out of a penetrating contact), not moved.
OBJECT_SPEED_LIMIT = 1.0  # m/s
# Baxter's fastest rated joints (the wrist's, 4.0 rad/s; the shoulder's and elbow's 1.5):
# a joint past it moves faster than the real arm can.
ARM_JOINT_SPEED_LIMIT = 4.0  # rad/s

# The bodies whose collision geometry is "the gripper" (the hand and the gripper's base and
# fingers; the tool is its own body).
GRIPPER_BODIES = ("right_hand", "right_gripper_base", "right_gripper")

PHYSICAL_LIMITS = (
    PhysicalLimit(
        "tool_in_table",
        "tool_table_penetration",
        TABLE_PENETRATION_LIMIT,
        "m",
        "the arm drives the tool through the table's contact: a real table would stop it",
    ),
    PhysicalLimit(
        "gripper_in_table",
        "gripper_table_penetration",
        TABLE_PENETRATION_LIMIT,
        "m",
        "the arm drives the gripper through the table's contact: a real table would stop it",
    ),
    PhysicalLimit(
        "object_too_fast",
        "object_speed",
        OBJECT_SPEED_LIMIT,
        "m/s",
        "the object was launched, not moved: faster than twice the tool's commanded speed",
    ),
    PhysicalLimit(
        "arm_too_fast",
        "arm_joint_speed",
        ARM_JOINT_SPEED_LIMIT,
        "rad/s",
        "an arm joint moves faster than any of the real Baxter's joints can",
    ),
)


class _TableDepth:
    """How far a rigid group of collision geometries (bodies welded to `reference`, in poses
    relative to it that no context parameter changes) reaches below the table's top, from
    the one pose of `reference` the plant has cached. Each shape's extent along −z is its
    support function: a box Σ hᵢ|zᵢ|, a cylinder h|z₃| + r√(1 − z₃²), a sphere r (z: W's z
    axis in the shape's frame); another shape counts as its frame's origin."""

    def __init__(self, plant, inspector, reference, bodies, footprint):
        context = plant.CreateDefaultContext()
        welded = {int(b.index()) for b in plant.GetBodiesWeldedTo(reference)}
        columns, self._pieces = [], []  # pieces: ((a1, a2, a3), b, c)
        self._reach = 0.0  # no point of the group lies farther than this from R's origin
        for body in bodies:
            if int(body.index()) not in welded:
                raise ValueError(f"{body.name()} is not welded to {reference.name()}")
            X_RB = plant.CalcRelativeTransform(context, reference.body_frame(), body.body_frame())
            for g in plant.GetCollisionGeometriesForBody(body):
                X_RG = X_RB @ inspector.GetPoseInFrame(g)
                columns += [X_RG.translation(), *X_RG.rotation().matrix().T]
                (a1, a2, a3), b, c = support = _support(inspector.GetShape(g))
                size = math.hypot(a1, a2, a3 + b) + c  # ≥ the piece's extent in any direction
                self._reach = max(self._reach, np.linalg.norm(X_RG.translation()) + size)
                self._pieces.append(support)
        self._reference = reference
        # Per piece four columns: p_RG, then the rows of R_RG (so that R_WR @ them gives p in
        # W's axes and, in row 2, W's z axis in the piece's frame).
        self._columns = np.array(columns).T if columns else None  # 3 × 4n
        self._footprint = footprint  # (x_lo, x_hi, y_lo, y_hi, top_z)

    def depth(self, plant_context) -> float:
        """How far the group's lowest point lies below the table's top (m; 0 when above),
        counting the pieces whose centre is over the table's footprint."""
        if self._columns is None:
            return 0.0
        x_lo, x_hi, y_lo, y_hi, top = self._footprint
        X_WR = self._reference.EvalPoseInWorld(plant_context)
        px, py, pz = X_WR.translation().tolist()
        if pz - self._reach > top:  # all of it above the table's top (nearly every step)
            return 0.0
        # One product places every piece; the rest is a few floats per piece (numpy's cost
        # per call exceeds the arithmetic here).
        rows = (X_WR.rotation().matrix() @ self._columns).tolist()
        deepest = 0.0
        for i, ((a1, a2, a3), b, c) in enumerate(self._pieces):
            k = 4 * i
            x, y = px + rows[0][k], py + rows[1][k]
            if not (x_lo <= x <= x_hi and y_lo <= y <= y_hi):
                continue
            z = rows[2]
            z1, z2, z3 = z[k + 1], z[k + 2], z[k + 3]
            extent = a1 * abs(z1) + a2 * abs(z2) + a3 * abs(z3) + c
            if b:
                extent += b * math.sqrt(max(0.0, 1.0 - z3 * z3))
            deepest = max(deepest, top - (pz + z[k] - extent))
        return deepest


def _support(shape) -> tuple:
    """(a, b, c) of a shape's extent along a unit direction z in its frame: Σ aᵢ|zᵢ| + b√(1 − z₃²) + c."""
    if isinstance(shape, Box):
        return (shape.width() / 2, shape.depth() / 2, shape.height() / 2), 0.0, 0.0
    if isinstance(shape, Cylinder):
        return (0.0, 0.0, shape.length() / 2), shape.radius(), 0.0
    if isinstance(shape, Sphere):
        return (0.0, 0.0, 0.0), 0.0, shape.radius()
    return (0.0, 0.0, 0.0), 0.0, 0.0


class PhysicalSanityReader:
    """Reads the step's physical-sanity figures from the world plant (`read`); `past_limits`
    flags those past their limits."""

    def __init__(self, world: World):
        plant = world.plant
        table = world.scenario.table
        (cx, cy), (sx, sy) = table.center_xy, table.size_xy
        footprint = (cx - sx / 2, cx + sx / 2, cy - sy / 2, cy + sy / 2, table.top_z)
        inspector = world.scene_graph.model_inspector()
        # The tool from its own pose: its grasp (where it sits in the hand) is a parameter
        # each randomized episode sets, so its pose relative to the hand is not fixed.
        hand = world.gripper_frame.body()
        tool = [world.tool] if world.tool is not None else []  # none: nothing to measure
        self._tool = _TableDepth(plant, inspector, tool[0] if tool else hand, tool, footprint)
        gripper = [plant.GetBodyByName(name, world.baxter) for name in GRIPPER_BODIES]
        self._gripper = _TableDepth(plant, inspector, hand, gripper, footprint)
        nq = plant.num_positions()
        # Indices into the plant's state [q, v]: the object's translational velocity (a
        # floating body's v is [ω_WB, v_WB]) and the arm's joint velocities.
        v_object = nq + world.box.floating_velocities_start_in_v() + 3
        self._object_v = slice(v_object, v_object + 3)
        arm_v = [nq + plant.GetJointByName(n).velocity_start() for n in RIGHT_ARM_JOINTS]
        # A slice where they are contiguous (they are: one chain), else an index array.
        contiguous = arm_v == list(range(arm_v[0], arm_v[0] + len(arm_v)))
        self._arm_v = slice(arm_v[0], arm_v[-1] + 1) if contiguous else np.array(arm_v)

    def read(self, plant_context, x) -> dict:
        """The figures of the plant's state `x` ([q, v], the state in `plant_context`)."""
        return {
            "tool_table_penetration": self._tool.depth(plant_context),
            "gripper_table_penetration": self._gripper.depth(plant_context),
            "object_speed": math.hypot(*x[self._object_v].tolist()),
            "arm_joint_speed": max(map(abs, x[self._arm_v].tolist())),
        }


def past_limits(figures: dict) -> dict:
    """Each limit's flag: whether its figure in `figures` is past it."""
    return {lim.flag: figures[lim.info_key] > lim.limit for lim in PHYSICAL_LIMITS}
