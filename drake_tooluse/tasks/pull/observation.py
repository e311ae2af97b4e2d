"""The pull task's observation: what the robot can know, as a LeafSystem (16 values, float32):

| slice | what | units |
| --- | --- | --- |
| 0:3 | goal x* of the cube's centre | m, W |
| 3:6 | cube centre x | m, W |
| 6:7 | cube yaw, folded into [−π/4, π/4) (a cube looks the same every quarter turn) | rad |
| 7:10 | hook corner c (robot model: the believed hook) | m, W |
| 10:13 | hook corner velocity (robot model: J(q) v) | m/s, W |
| 13:16 | the believed hook: handle length, hook length, angle | m, m, rad |

Like the push task's `tip` observation it is in the controlled frame's space (the corner's),
so one policy serves every hook the IK tracks; the hook's geometry tells it which hook it
holds. The metrics (reward, success, info) come from the world plant (`tasks.pull.metrics`).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.kinematics import ArmChain, fk_jacobian
from drake_tooluse.systems.goal_observation import GoalObservation
from drake_tooluse.world.scene import World

OBSERVATION_SIZE = 16
# Where each part of the observation lies (see the module docstring).
GOAL, OBJECT, OBJECT_YAW, CORNER, CORNER_VELOCITY, HOOK = (
    slice(0, 3),
    slice(3, 6),
    slice(6, 7),
    slice(7, 10),
    slice(10, 13),
    slice(13, 16),
)


def folded_yaw(wxyz) -> float:
    """A cube's yaw (about W's z, rad) from its quaternion, folded into [−π/4, π/4)."""
    w, x, y, z = wxyz
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return (yaw + math.pi / 4) % (math.pi / 2) - math.pi / 4


class ToolPullObservation(GoalObservation, LeafSystem):
    """Plant state in, the pull task's observation out (see the module docstring).

    .. pydrake_system::

        name: ToolPullObservation
        input_ports:
        - plant_state
        output_ports:
        - observation

    Input ports:
        plant_state: the world plant's full state [q, v].
    Output ports:
        observation: 16 values; all NaN when the state is not finite.
    Parameters: the goal x* (3, m), set per episode (`set_goal`).
    """

    def __init__(self, world: World, corner_chain: ArmChain, goal, hook_geometry):
        super().__init__(world, goal, OBSERVATION_SIZE)
        nq = world.plant.num_positions()
        self._arm_q = np.array([j.position_start() for j in world.arm_joints()])
        self._arm_v = np.array([nq + j.velocity_start() for j in world.arm_joints()])
        q0 = world.box.floating_positions_start()
        self._box_quaternion = slice(q0, q0 + 4)
        self._box_p = slice(q0 + 4, q0 + 7)
        self._chain = corner_chain
        self._fk = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
        self._hook = np.asarray(hook_geometry, float)

    def finite_observation(self, x, goal) -> np.ndarray:
        """`observation` of a plant state x known to be finite."""
        R, p, J = self._fk
        fk_jacobian(self._chain.fixed, self._chain.axes, x[self._arm_q], R, p, J)
        return np.concatenate(
            (
                goal,
                x[self._box_p],
                [folded_yaw(x[self._box_quaternion])],
                p,
                J[:3] @ x[self._arm_v],
                self._hook,
            )
        )
