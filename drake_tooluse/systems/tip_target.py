"""Actions in tool-tip space, and the LeafSystem that turns them into a desired tool-tip pose.

Three action modes (all actions are in [-1, 1]; values outside are clipped):

| mode | size | meaning (per control step, at |a| = 1) |
| --- | --- | --- |
| `position_quaternion` | 7 | change of tip position (3) × 0.02 m, change of the quaternion w x y z (4) × 0.05, normalized (the paper's mocap) |
| `pose` | 6 | change of tip position (3) × 0.02 m, rotation vector (3) × 0.10 rad, in the world frame |
| `position` | 3 | change of tip position (3) × 0.02 m; the orientation is held |

The target position is kept inside a workspace box above the table (clipped, see
`Workspace`), so a policy cannot drive the target through the table or out of reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.kinematics import ArmChain
from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.validation import all_finite

ACTION_MODES = {"position_quaternion": 7, "pose": 6, "position": 3}
MAX_TRANSLATION_STEP = 0.02  # m per step
MAX_QUATERNION_STEP = 0.05  # per quaternion component per step (position_quaternion mode)
MAX_ROTATION_STEP = 0.10  # rad per step (pose mode)


@dataclass(frozen=True)
class Workspace:
    """Box the tool-tip target is kept in (m, world frame)."""

    lower: np.ndarray
    upper: np.ndarray

    @staticmethod
    def above_table(table_top_z: float) -> Workspace:
        return Workspace(
            np.array([0.40, -0.70, table_top_z + 0.005]), np.array([1.00, 0.35, table_top_z + 0.40])
        )


def check_action(action, mode: str) -> np.ndarray:
    """The action as a float array in [-1, 1]; NaN or infinite values are errors."""
    a = np.asarray(action, dtype=float).reshape(-1)
    size = ACTION_MODES[mode]
    if a.size != size:
        raise ValueError(f"action has {a.size} values; action_mode={mode!r} needs {size}")
    if not all_finite(a):
        raise ValueError(
            f"action {a.tolist()} holds NaN or infinite values; actions must be "
            "finite (they are clipped to [-1, 1])"
        )
    return np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip, without its dispatch cost


def apply_action(
    target: np.ndarray, action: np.ndarray, mode: str, workspace: Workspace
) -> np.ndarray:
    """The tool-tip target [p (3), quaternion wxyz (4)] moved by a (clipped) action."""
    p = np.minimum(
        np.maximum(target[:3] + MAX_TRANSLATION_STEP * action[:3], workspace.lower), workspace.upper
    )
    quat = target[3:]
    if mode == "position_quaternion":
        quat = quat + MAX_QUATERNION_STEP * action[3:7]
        norm = math.sqrt(quat.dot(quat))  # np.linalg.norm's own arithmetic, without its dispatch
        quat = quat / norm if norm > 1e-6 else target[3:]
    elif mode == "pose":
        rotvec = MAX_ROTATION_STEP * action[3:6]
        angle = float(np.linalg.norm(rotvec))
        if angle > 1e-12:
            dq = Quaternion(AngleAxis(angle, rotvec / angle).rotation())
            quat = (dq.multiply(Quaternion(quat))).wxyz()
            quat = quat / np.linalg.norm(quat)
    return np.concatenate([p, quat])


class TipTargetSystem(LeafSystem):
    """Policy actions in, desired tool-tip pose out: each action moves the target from where
    the tool tip is now (as Fetch's mocap control, which the paper used, moved the gripper),
    so a policy cannot wind the target up far ahead of a lagging arm.

    .. pydrake_system::

        name: TipTargetSystem
        input_ports:
        - action
        - arm_state
        output_ports:
        - tip_pose_desired

    Input ports:
        action: the policy's action (size by mode, see the module docstring); clipped to
            [-1, 1]. Unfixed, the target is the current tip pose.
        arm_state: measured right-arm state [q (7), v (7)]; the tip pose is the forward
            kinematics of q on the robot model (the believed tool: its arm chain, see
            `robot.kinematics`).
    Output ports:
        tip_pose_desired: [p_WT (3, m), quaternion wxyz (4)] — the current tip pose moved by
            the action (`position` mode holds the initial orientation instead).
    """

    def __init__(
        self, mode: str, chain: ArmChain, initial_target: np.ndarray, workspace: Workspace
    ):
        super().__init__()
        self._mode = mode
        self._workspace = workspace
        self._chain = chain
        self._held_quaternion = np.asarray(initial_target, float)[3:]
        self._action = self.DeclareVectorInputPort("action", ACTION_MODES[mode])
        self._arm_state = self.DeclareVectorInputPort("arm_state", 14)
        self.DeclareVectorOutputPort("tip_pose_desired", 7, weak_method(self._calc_target))

    def _target(self, context) -> np.ndarray:
        R_WT, p_WT = self._chain.pose(self._arm_state.Eval(context)[:7])
        quat = (
            self._held_quaternion
            if self._mode == "position"
            else RotationMatrix(R_WT).ToQuaternion().wxyz()
        )
        current = np.concatenate([p_WT, quat])
        if not self._action.HasValue(context):
            return current
        action = check_action(self._action.Eval(context), self._mode)
        return apply_action(current, action, self._mode, self._workspace)

    def _calc_target(self, context, output):
        output.SetFromVector(self._target(context))
