"""The push task's observation: what the robot can know, as a LeafSystem.

Two observation modes. `gripper_joints`: the paper's observation, in its order (30 values, float32; 31
with the tool length):

| slice | what | units |
| --- | --- | --- |
| 0:3 | goal box position x* | m, W |
| 3:6 | box position x | m, W |
| 6:9 | tool-tip position y (robot model: believed length) | m, W |
| 9:12 | gripper position | m, W |
| 12:16 | gripper quaternion w x y z | — |
| 16:23 | right-arm joint angles s0 … w2 | rad |
| 23:30 | right-arm joint velocities | rad/s |
| 30 | believed tool length (optional) | m |

`tip`: the task in tool-tip space only (12 values; 13 with the tool length). The paper's
observation holds the gripper pose and the joint angles, which change with the tool for the
same tip pose, so a policy trained on it meets unseen inputs with another tool; this one is
the same for any tool the IK tracks:

| slice | what | units |
| --- | --- | --- |
| 0:3 | goal box position x* | m, W |
| 3:6 | box position x | m, W |
| 6:9 | tool-tip position y (robot model: believed length) | m, W |
| 9:12 | tool-tip velocity (robot model: J(q) v) | m/s, W |
| 12 | believed tool length (optional) | m |

`tip_geometry`: `tip`, then the believed tool's shape as its support points
(`robot.tool_geometry`: for W's +x, −x, +y, −y and down, the point of the tool farthest that
way, as its offset from the tip): one observation for tools of every family (27 values):

| slice | what | units |
| --- | --- | --- |
| 0:12 | as `tip` | |
| 12:27 | support points towards +x, −x, +y, −y, down, each x y z from the tip | m, W |
| 27 | believed tool length (optional) | m |

The metrics (reward, success, info) are computed from the world plant, i.e. the true tool
(`tasks.push.metrics`).
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.model import GRIPPER_FRAME, TIP_FRAME, plant_frame_name
from drake_tooluse.robot.tool_geometry import CODE_SIZE, GeometryCode
from drake_tooluse.systems.goal_observation import GoalObservation
from drake_tooluse.validation import check_one_of
from drake_tooluse.world.scene import World

OBSERVATION_SIZES = {"gripper_joints": 30, "tip": 12, "tip_geometry": 12 + CODE_SIZE}


class ToolPushObservation(GoalObservation, LeafSystem):
    """Plant state in, the push task's observation out (see the module docstring).

    .. pydrake_system::

        name: ToolPushObservation
        input_ports:
        - plant_state
        output_ports:
        - observation

    Input ports:
        plant_state: the world plant's full state [q (14), v (13)].
    Output ports:
        observation: by mode, 30, 12 or 27 values (one more with the tool length); all NaN
            when the state is not finite.
    Parameters: the goal x* (3, m), set per episode (`set_goal`).
    """

    def __init__(
        self,
        world: World,
        robot_model,
        goal,
        include_tool_length: bool,
        believed_tool_length: float | None,
        mode: str = "gripper_joints",
        believed_tool=None,
        frame: str = TIP_FRAME,
    ):
        check_one_of(mode, tuple(OBSERVATION_SIZES), "observation_mode")
        # The observation's tail: nothing, or the tool length (no empty piece to join: numpy
        # would make an array of it every step).
        tail = (np.array([believed_tool_length or 0.0]),) if include_tool_length else ()
        super().__init__(world, goal, OBSERVATION_SIZES[mode] + len(tail))
        self._tail = tail
        self._mode = mode
        plant = world.plant
        nq = plant.num_positions()
        self._nq = nq
        self._arm_q = _index([j.position_start() for j in world.arm_joints()])
        self._arm_v = _index([nq + j.velocity_start() for j in world.arm_joints()])
        box_q0 = world.box.floating_positions_start()
        self._box_p = _index(range(box_q0 + 4, box_q0 + 7))  # after the quaternion
        self._model = robot_model
        self._model_context = robot_model.CreateDefaultContext()
        self._tip = robot_model.GetFrameByName(plant_frame_name(frame))
        self._gripper = robot_model.GetFrameByName(GRIPPER_FRAME)
        # The believed tool's shape (`tip_geometry`); None: no tool or another mode.
        self._geometry = GeometryCode(believed_tool, frame) if mode == "tip_geometry" else None

    def finite_observation(self, x, goal) -> np.ndarray:
        """`observation` of a plant state x known to be finite (not checked again)."""
        q = x[self._arm_q]
        self._model.SetPositions(self._model_context, q)
        if self._mode != "gripper_joints":
            X_WT = self._tip.CalcPoseInWorld(self._model_context)
            shape = (
                () if self._geometry is None else (self._geometry.code(X_WT.rotation().matrix()),)
            )
            return np.concatenate(
                (
                    goal,
                    x[self._box_p],
                    X_WT.translation(),
                    self._tip_jacobian() @ x[self._arm_v],
                    *shape,
                    *self._tail,
                )
            )
        X_WG = self._gripper.CalcPoseInWorld(self._model_context)
        p_WT = self._tip.CalcPoseInWorld(self._model_context).translation()
        return np.concatenate(
            (
                goal,
                x[self._box_p],
                p_WT,
                X_WG.translation(),
                X_WG.rotation().ToQuaternion().wxyz(),
                q,
                x[self._arm_v],
                *self._tail,
            )
        )

    def tip_from_paper(self, observation) -> np.ndarray:
        """The `tip` observation (no tool length) of the state a `gripper_joints` observation
        was made of: its goal, box and tip positions, and the tip velocity J(q) v of its joint
        angles and velocities (the same robot model's)."""
        o = np.asarray(observation, float)
        self._model.SetPositions(self._model_context, o[16:23])
        return np.concatenate((o[:9], self._tip_jacobian() @ o[23:30]))

    def _tip_jacobian(self) -> np.ndarray:
        """J (3 × 7): the tip's translational velocity in W per arm joint velocity, at the
        positions last set in the robot model's context."""
        world_frame = self._model.world_frame()
        return self._model.CalcJacobianTranslationalVelocity(
            self._model_context,
            JacobianWrtVariable.kV,
            self._tip,
            np.zeros(3),
            world_frame,
            world_frame,
        )


def _index(indices):
    """Indices into the state as a slice where they are consecutive (a view, cheaper than
    fancy indexing's copy; the same values), else as an array."""
    indices = [int(i) for i in indices]
    if indices == list(range(indices[0], indices[0] + len(indices))):
        return slice(indices[0], indices[0] + len(indices))
    return np.array(indices)
