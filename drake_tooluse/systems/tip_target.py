"""Actions in tool-tip space, and the LeafSystem that turns them into a desired tool-tip pose.

Three action modes (all actions are in [-1, 1]; values outside are clipped):

| mode | size | meaning (per control step, at an action of ±1) |
| --- | --- | --- |
| `position_quaternion` | 7 | change of tip position (3) × 0.02 m, change of the quaternion w x y z (4) × 0.05, normalized (the paper's mocap) |
| `pose` | 6 | change of tip position (3) × 0.02 m, rotation vector (3) × 0.10 rad, in the world frame |
| `position` | 3 | change of tip position (3) × 0.02 m; the orientation is held |

The target position is kept inside a workspace box above the table (clipped, see
`Workspace`), so a policy cannot drive the target through the table or out of reach.

`position_quaternion` adds its change to the quaternion of the tip's current orientation. q and
-q are the same orientation, and Drake's `RotationMatrix.ToQuaternion` picks the sign by the
largest component: for this scene's home tip orientation, w ≈ 0 = (0, ±0.707, ±0.707, 0), the
sign jumps from one step to the next, and the same action would turn the tip one way or the
other. The quaternion is therefore taken in the hemisphere of the initial target's (as a mocap
body's stored quaternion, which the paper's Fetch env moved, is continuous).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.kinematics import ArmChain, fk_jacobian
from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.systems.tool_tip_ik import NO_WITNESS_FUNCTIONS
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
    # A finite dot product proves every value finite in one C call (`all_finite`'s sum goes
    # through numpy's Python code); only where it is not does `all_finite` decide.
    if not (math.isfinite(a.dot(a)) or all_finite(a)):
        raise ValueError(
            f"action {a.tolist()} holds NaN or infinite values; actions must be "
            "finite (they are clipped to [-1, 1])"
        )
    return np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip, without its dispatch cost


def apply_action(
    target: np.ndarray, action: np.ndarray, mode: str, workspace: Workspace
) -> np.ndarray:
    """The tool-tip target [p (3), quaternion wxyz (4)] moved by a (clipped) action."""
    return np.concatenate(_moved(target[:3], target[3:], action, mode, workspace))


def _moved(p, quat, action, mode: str, workspace: Workspace) -> tuple:
    """`apply_action` of the target's position p and quaternion: (p, quaternion) moved."""
    p = np.minimum(
        np.maximum(p + MAX_TRANSLATION_STEP * action[:3], workspace.lower), workspace.upper
    )
    if mode == "position_quaternion":
        moved = quat + MAX_QUATERNION_STEP * action[3:7]
        norm = math.sqrt(moved.dot(moved))  # np.linalg.norm's own arithmetic, without its dispatch
        quat = moved / norm if norm > 1e-6 else quat
    elif mode == "pose":
        rotvec = MAX_ROTATION_STEP * action[3:6]
        angle = float(np.linalg.norm(rotvec))
        if angle > 1e-12:
            dq = Quaternion(AngleAxis(angle, rotvec / angle).rotation())
            quat = (dq.multiply(Quaternion(quat))).wxyz()
            quat = quat / np.linalg.norm(quat)
    return p, quat


@numba.njit(cache=True)
def _step(p, quat, action, lower, upper, moves_quaternion, p_out, quat_out) -> bool:
    """`apply_action`'s arithmetic for the `position` and `position_quaternion` modes in one
    compiled call (a dozen numpy calls on 3- and 4-vectors otherwise), with the same IEEE
    operations in the same order, so the same bits: the action clipped to [-1, 1], p_out = p +
    MAX_TRANSLATION_STEP a kept in [lower, upper] (NaN passes, as through numpy's clip), and
    where `moves_quaternion`, quat_out = quat + MAX_QUATERNION_STEP a (not yet normalized:
    numpy's dot does that, as in `apply_action`). False, with nothing written, where the
    action is not finite."""
    for i in range(action.shape[0]):
        if not math.isfinite(action[i]):
            return False
    for i in range(3):
        t = p[i] + MAX_TRANSLATION_STEP * min(max(action[i], -1.0), 1.0)
        p_out[i] = t if t != t else min(max(t, lower[i]), upper[i])
    if moves_quaternion:
        for i in range(4):
            quat_out[i] = quat[i] + MAX_QUATERNION_STEP * min(max(action[3 + i], -1.0), 1.0)
    return True


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
            the action (`position` mode holds the initial orientation instead); its
            quaternion is in the initial target's hemisphere (the module docstring).
    """

    DoGetWitnessFunctions = NO_WITNESS_FUNCTIONS

    def __init__(
        self,
        mode: str,
        chain: ArmChain,
        initial_target: np.ndarray,
        workspace: Workspace,
    ):
        super().__init__()
        self._mode = mode
        self._workspace = workspace
        self._chain = chain
        # The forward kinematics' outputs (R_WT, p_WT, J), reused: `ArmChain.pose` would
        # allocate them at every call.
        self._fk = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
        self._held_quaternion = np.asarray(initial_target, float)[3:]
        self._action = self.DeclareVectorInputPort("action", ACTION_MODES[mode])
        self._arm_state = self.DeclareVectorInputPort("arm_state", 14)
        self.DeclareVectorOutputPort("tip_pose_desired", 7, weak_method(self._calc_target))

    def _target(self, context) -> np.ndarray:
        # `ArmChain.pose`, into this system's arrays (read, or copied, before the next call).
        R_WT, p_WT, J = self._fk
        q = self._arm_state.Eval(context)[:7]
        fk_jacobian(self._chain.fixed, self._chain.axes, q, R_WT, p_WT, J)
        if self._mode == "position":
            quat = self._held_quaternion
        else:  # MakeUnchecked: the constructor's rotation (it checks nothing in release builds)
            quat = self._signed(RotationMatrix.MakeUnchecked(R_WT).ToQuaternion().wxyz())
        if not self._action.HasValue(context):
            return np.concatenate([p_WT, quat])
        # The port holds its size of floats: what `check_action` checks beyond that is their
        # finiteness (it raises, naming them), then the clip.
        action = self._action.Eval(context)
        if self._mode == "pose":
            if not all_finite(action):
                check_action(action, self._mode)
            action = np.minimum(np.maximum(action, -1.0), 1.0)
            return np.concatenate(_moved(p_WT, quat, action, self._mode, self._workspace))
        # `apply_action` of [p_WT, quat], its arithmetic compiled (`_step`).
        p, moved = np.empty(3), np.empty(4)
        moves_quaternion = self._mode == "position_quaternion"
        w = self._workspace
        if not _step(p_WT, quat, action, w.lower, w.upper, moves_quaternion, p, moved):
            check_action(action, self._mode)  # raises, naming the values
        if moves_quaternion:
            norm = math.sqrt(moved.dot(moved))  # as `apply_action` normalizes it
            quat = moved / norm if norm > 1e-6 else quat
        return np.concatenate((p, quat))

    @property
    def initial_quaternion(self) -> np.ndarray:
        """The initial target's orientation as a quaternion (w x y z), which `position` mode holds."""
        return self._held_quaternion.copy()

    def quaternion_at(self, q) -> np.ndarray:
        """The tip orientation's quaternion (w x y z) at the arm's joint angles q, by the robot
        model's forward kinematics, signed as this system signs the orientation it adds an
        action's change to."""
        R_WT, p_WT, J = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
        fk_jacobian(self._chain.fixed, self._chain.axes, np.asarray(q, float), R_WT, p_WT, J)
        return self._signed(RotationMatrix.MakeUnchecked(R_WT).ToQuaternion().wxyz())

    def _signed(self, quat: np.ndarray) -> np.ndarray:
        """`quat` (Drake's sign) as the same orientation in the initial target's hemisphere."""
        if quat.dot(self._held_quaternion) < 0.0:
            return -quat
        return quat

    def _calc_target(self, context, output):
        output.SetFromVector(self._target(context))
