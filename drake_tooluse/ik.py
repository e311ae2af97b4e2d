"""Tool-tip inverse kinematics: Drake `InverseKinematics` on the tool-tip frame T.

- `ToolTipIK(tool_length).solve(X_WT_desired, q_seed)` puts a position and an orientation
  constraint on T (plus the joint limits) and solves with SNOPT, warm-started from `q_seed`
  (or, when `q_seed` is far from the target, from the nearest entry of a seed library of
  configurations drawn once with fixed seeds); if that fails it retries from the next
  nearest library entries. An unreachable
  target is a result (`success=False` with the residual), never an exception.
- `gripper_target_from_tip_target` is the paper's offset method: the gripper goes to the tip
  target minus the tool vector rotated by the target orientation, v' = q v q^-1.
- `ToolTipIKSystem` wraps the solver as a LeafSystem (see its docstring for the ports).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.common.eigen_geometry import Quaternion
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import SnoptSolver, SolverOptions
from pydrake.systems.framework import LeafSystem

from drake_tooluse.baxter_model import ARM_LIMITS, ARM_JOINT_SUFFIXES, RIGHT_ARM_JOINTS
from drake_tooluse.scene import GRIPPER_FRAME, TIP_FRAME, make_robot_model
from drake_tooluse.validation import check_finite_vector, check_unit_quaternion

Q_LOWER = np.array([ARM_LIMITS[s][0] for s in ARM_JOINT_SUFFIXES])
Q_UPPER = np.array([ARM_LIMITS[s][1] for s in ARM_JOINT_SUFFIXES])
Q_MID = (Q_LOWER + Q_UPPER) / 2
# The conservative limits the real robot's IK is held to (s1 narrowed, see FACTS.md).
Q_LOWER_CONSERVATIVE = Q_LOWER.copy()
Q_UPPER_CONSERVATIVE = Q_UPPER.copy()
Q_LOWER_CONSERVATIVE[1], Q_UPPER_CONSERVATIVE[1] = -1.35, 1.0


def joint_limit_kwargs(conservative: bool) -> dict:
    """`ToolTipIK` keyword arguments for the conservative limits, or none for Baxter's own."""
    return ({"joint_lower": Q_LOWER_CONSERVATIVE, "joint_upper": Q_UPPER_CONSERVATIVE}
            if conservative else {})
# A solution counts as a success when it meets these (checked by forward kinematics).
POSITION_TOLERANCE = 1e-5  # m
ORIENTATION_TOLERANCE = 1e-4  # rad
# After the orientation-cost phase, an attempt further than this from the target orientation
# is in the wrong basin (a local minimum against the joint limits) and is abandoned.
BASIN_ANGLE = 0.02  # rad
# A warm start whose tip is within this task-space distance (m + 0.2 m/rad) of the target is
# always tried first, so consecutive solutions of a moving target stay on one branch.
WARM_START_DISTANCE = 0.15
# A warm start within this distance is tried first with the constrained solve alone.
NEAR_DISTANCE = 0.05


@dataclass
class IKResult:
    """q: right-arm joint angles s0 … w2 (rad); errors are of the tip frame at q."""

    q: np.ndarray
    success: bool
    position_error: float  # m
    orientation_error: float  # rad
    solve_time: float  # s, wall clock, all attempts
    attempts: int = 1
    within_limits: bool = True

    def as_dict(self) -> dict:
        return {"q": [float(x) for x in self.q], "joint_names": list(RIGHT_ARM_JOINTS),
                "success": bool(self.success), "position_error_m": float(self.position_error),
                "orientation_error_rad": float(self.orientation_error),
                "solve_time_s": float(self.solve_time), "attempts": int(self.attempts),
                "within_limits": bool(self.within_limits)}


def pose_from_vector(x) -> RigidTransform:
    """[p (3), quaternion w x y z (4)] -> RigidTransform; the quaternion is normalized."""
    x = check_finite_vector(x, 7, "tool-tip pose [x y z qw qx qy qz]")
    quat = check_unit_quaternion(x[3:], "tool-tip orientation quaternion (w, x, y, z)")
    return RigidTransform(Quaternion(quat), x[:3])


def pose_to_vector(X: RigidTransform) -> np.ndarray:
    return np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()])


def rotation_angle_between(R_a: RotationMatrix, R_b: RotationMatrix) -> float:
    """Angle (rad) of the rotation taking R_a to R_b, accurate near zero."""
    R = (R_a.inverse() @ R_b).matrix()
    # atan2 of |axis·sin| and cos keeps precision for tiny angles (acos does not).
    s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    c = 0.5 * (np.trace(R) - 1.0)
    return float(np.arctan2(s, c))


def check_pose(X_WT) -> RigidTransform:
    """Accepts a RigidTransform or a 7-vector; non-finite values are errors."""
    if isinstance(X_WT, RigidTransform):
        check_finite_vector(X_WT.GetAsMatrix4().reshape(-1), 16, "tool-tip pose X_WT")
        return X_WT
    return pose_from_vector(X_WT)


def tool_offset(tool_length: float) -> np.ndarray:
    """v = p_GT: the tool vector in the gripper frame (the tool axis is +z of G)."""
    return np.array([0.0, 0.0, float(tool_length)])


def gripper_target_from_tip_target(X_WT: RigidTransform, tool_length: float) -> RigidTransform:
    """The paper's offset method: p_WG = p_WT - v' with v' = q v q^-1 (q the target
    orientation, v the tool vector); the gripper takes the target orientation."""
    X_WT = check_pose(X_WT)
    q = X_WT.rotation().ToQuaternion()
    v_rotated = q.rotation() @ tool_offset(tool_length)  # q v q^-1
    return RigidTransform(X_WT.rotation(), X_WT.translation() - v_rotated)


class ToolTipIK:
    """Solves for the right-arm joints that put the tool tip T at a desired pose X_WT.

    Args:
        tool_length: believed tool length (m), in (0, 0.60]; None for no tool (T = gripper).
        grasp_offset: believed (across, along) offset of the grasp point from the gripper
            frame's origin (m; default 0, 0): with the camera's estimate the IK also knows
            where the hand holds the tool (see `measure.py`).
        joint_lower, joint_upper: joint limits (rad) s0 … w2; default Baxter's.
        max_attempts: solves tried (the warm start, then deterministic random seeds).
        library_size: configurations in the central seed library (drawn with a fixed seed,
            so the same call gives the same result); the full-range library has half as many.
    """

    def __init__(self, tool_length: float | None = None, *, grasp_offset=(0.0, 0.0),
                 joint_lower=None, joint_upper=None, max_attempts: int = 16,
                 library_size: int = 4000):
        self.tool_length = tool_length
        self.grasp_offset = tuple(float(v) for v in grasp_offset)
        self.plant = make_robot_model(tool_length, grasp_offset=self.grasp_offset)
        self.context = self.plant.CreateDefaultContext()
        self.tip_frame = self.plant.GetFrameByName(TIP_FRAME)
        self.gripper_frame = self.plant.GetFrameByName(GRIPPER_FRAME)
        self.lower = Q_LOWER.copy() if joint_lower is None else check_finite_vector(
            joint_lower, 7, "joint_lower")
        self.upper = Q_UPPER.copy() if joint_upper is None else check_finite_vector(
            joint_upper, 7, "joint_upper")
        if np.any(self.lower > self.upper):
            raise ValueError(f"joint_lower {self.lower.tolist()} exceeds joint_upper "
                             f"{self.upper.tolist()}")
        if max_attempts < 1:
            raise ValueError(f"max_attempts={max_attempts} must be at least 1")
        self.max_attempts = int(max_attempts)
        self.q_nominal = np.clip(Q_MID, self.lower, self.upper)
        self._solver = SnoptSolver()
        self._options = SolverOptions()
        # Tighter than SNOPT's default 1e-6 so that the orientation constraint (a bound on
        # the cosine of the angle) holds to ~1e-5 rad instead of ~1e-3 rad.
        self._options.SetOption(self._solver.id(), "Major feasibility tolerance", 1e-10)
        self._options.SetOption(self._solver.id(), "Major optimality tolerance", 1e-6)
        self._options.SetOption(self._solver.id(), "Major iterations limit", 60)
        self._build_seed_library(library_size)

    def _build_seed_library(self, size: int) -> None:
        """Two seed libraries of configurations drawn once with fixed seeds: `size` in the
        central 80 % of each joint's range (seeds there rarely end against a limit) and
        `size // 2` over the full range (for targets that need a joint near its limit)."""
        centre, half = (self.lower + self.upper) / 2, (self.upper - self.lower) / 2
        self._libraries = [
            self._library(centre - 0.8 * half, centre + 0.8 * half, size, seed=1),
            self._library(self.lower, self.upper, max(size // 2, 1), seed=2),
        ]

    def _library(self, lower, upper, size: int, seed: int):
        q = np.random.default_rng(seed).uniform(lower, upper, size=(size, 7))
        poses = [self.fk(x) for x in q]
        return (q, np.array([X.translation() for X in poses]),
                np.array([X.rotation().matrix() for X in poses]))

    @staticmethod
    def _task_distance(X_WT: RigidTransform, p, R) -> np.ndarray:
        """Position distance (m) + 0.2 m/rad x rotation angle, for arrays of poses."""
        cos = (np.einsum("ij,kij->k", X_WT.rotation().matrix(), R) - 1.0) / 2.0
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        return np.linalg.norm(p - X_WT.translation(), axis=1) + 0.2 * angle

    def _seed_distance(self, X_WT: RigidTransform, q_seed: np.ndarray) -> float:
        X = self.fk(q_seed)
        return float(self._task_distance(X_WT, X.translation()[None],
                                         X.rotation().matrix()[None])[0])

    def library_seeds(self, X_WT: RigidTransform) -> list[np.ndarray]:
        """The nearest entries (task space) of the two libraries, alternating."""
        nearest = []
        for q, p, R in self._libraries:
            order = np.argsort(self._task_distance(X_WT, p, R))[: self.max_attempts]
            nearest.append([q[i] for i in order])
        return [s for pair in zip(*nearest) for s in pair]

    def attempts(self, X_WT: RigidTransform, q_seed: np.ndarray):
        """Yields (seed, find_basin) to try, best first, computing the library order only if
        needed. A warm start within NEAR_DISTANCE is tried first with the constrained solve
        alone (it is in the right basin); one within WARM_START_DISTANCE with both phases; a
        farther one after the nearest central-library entry."""
        d_seed = self._seed_distance(X_WT, q_seed)
        if d_seed <= NEAR_DISTANCE:
            yield q_seed, False
        if d_seed <= WARM_START_DISTANCE:
            yield q_seed, True
            yield from ((q, True) for q in self.library_seeds(X_WT))
            return
        library = self.library_seeds(X_WT)
        yield library[0], True
        yield q_seed, True
        yield from ((q, True) for q in library[1:])

    # -- kinematics -------------------------------------------------------------------------
    def check_q(self, q, name: str = "q") -> np.ndarray:
        """q must be 7 finite joint angles within the limits (rad)."""
        q = check_finite_vector(q, 7, name)
        bad = [(RIGHT_ARM_JOINTS[i], q[i], self.lower[i], self.upper[i]) for i in range(7)
               if not self.lower[i] - 1e-9 <= q[i] <= self.upper[i] + 1e-9]
        if bad:
            text = "; ".join(f"{n}={v:.4g} rad outside [{lo:.4g}, {hi:.4g}]"
                             for n, v, lo, hi in bad)
            raise ValueError(f"{name} is outside the joint limits: {text}")
        return q

    def fk(self, q) -> RigidTransform:
        """X_WT: the tool-tip pose at joint angles q."""
        self.plant.SetPositions(self.context, np.asarray(q, float))
        return self.tip_frame.CalcPoseInWorld(self.context)

    def fk_gripper(self, q) -> RigidTransform:
        self.plant.SetPositions(self.context, np.asarray(q, float))
        return self.gripper_frame.CalcPoseInWorld(self.context)

    def errors(self, q, X_WT: RigidTransform) -> tuple[float, float]:
        X = self.fk(q)
        return (float(np.linalg.norm(X.translation() - X_WT.translation())),
                rotation_angle_between(X.rotation(), X_WT.rotation()))

    # -- IK ---------------------------------------------------------------------------------
    def _new_ik(self, X_WT: RigidTransform) -> InverseKinematics:
        ik = InverseKinematics(self.plant, self.context, with_joint_limits=False)
        ik.get_mutable_prog().AddBoundingBoxConstraint(self.lower, self.upper, ik.q())
        p = X_WT.translation()
        ik.AddPositionConstraint(self.tip_frame, np.zeros(3), self.plant.world_frame(), p, p)
        return ik

    def _solve_once(self, X_WT: RigidTransform, q_seed: np.ndarray,
                    find_basin: bool = True) -> np.ndarray:
        if not find_basin:
            return self._solve_constrained(X_WT, q_seed)
        # Phase 1: tip position constrained, orientation as a cost. This finds the basin
        # quickly; where it ends far from the target orientation, the seed is in the wrong
        # basin and the attempt stops early.
        ik = self._new_ik(X_WT)
        ik.AddOrientationCost(self.plant.world_frame(), X_WT.rotation(), self.tip_frame,
                              RotationMatrix(), 10.0)
        result = self._solver.Solve(ik.prog(), q_seed, self._options)
        q1 = np.clip(result.GetSolution(ik.q()), self.lower, self.upper)
        if self.errors(q1, X_WT)[1] > BASIN_ANGLE:
            return q1
        # Phase 2: position and orientation constraints on the tip frame, from phase 1.
        return self._solve_constrained(X_WT, q1)

    def _solve_constrained(self, X_WT: RigidTransform, q_seed: np.ndarray) -> np.ndarray:
        """Position and orientation constraints on the tip frame, from q_seed."""
        ik = self._new_ik(X_WT)
        ik.AddOrientationConstraint(self.plant.world_frame(), X_WT.rotation(), self.tip_frame,
                                    RotationMatrix(), 0.0)
        result = self._solver.Solve(ik.prog(), q_seed, self._options)
        return result.GetSolution(ik.q())

    def solve(self, X_WT_desired, q_seed=None) -> IKResult:
        """Joint angles that put T at X_WT_desired (a RigidTransform or [p, quaternion wxyz])."""
        X_WT = check_pose(X_WT_desired)
        q_seed = self.q_nominal if q_seed is None else check_finite_vector(q_seed, 7, "q_seed")
        q_seed = np.clip(q_seed, self.lower, self.upper)
        start = time.perf_counter()
        best = None
        attempt = 0
        for q_try, find_basin in self.attempts(X_WT, q_seed):
            attempt += 1
            if attempt > self.max_attempts:
                attempt -= 1
                break
            q = self._solve_once(X_WT, q_try, find_basin)
            q = np.clip(q, self.lower, self.upper)  # SNOPT may sit 1e-10 past a bound.
            pos_err, rot_err = self.errors(q, X_WT)
            ok = pos_err <= POSITION_TOLERANCE and rot_err <= ORIENTATION_TOLERANCE
            score = pos_err + 0.1 * rot_err
            if best is None or score < best[0]:
                best = (score, q, pos_err, rot_err)
            if ok:
                break
        _, q, pos_err, rot_err = best
        ok = pos_err <= POSITION_TOLERANCE and rot_err <= ORIENTATION_TOLERANCE
        return IKResult(q=q, success=bool(ok), position_error=pos_err, orientation_error=rot_err,
                        solve_time=time.perf_counter() - start, attempts=attempt,
                        within_limits=bool(np.all(q >= self.lower) and np.all(q <= self.upper)))


class ToolTipIKSystem(LeafSystem):
    """Desired tool-tip pose in, right-arm joint targets out; warm-started from its last
    solution. Solves once per control period (a periodic discrete update).

    Input ports:
        tip_pose_desired: [p_WT (3, m), quaternion wxyz (4)] — X_WT*, the desired tool-tip pose
            in W; the quaternion is normalized here (a zero one is an error).
    Output ports:
        q_desired: right-arm joint targets s0 … w2 (7, rad).
        desired_state: [q_desired (7), zeros (7)] — for the plant's PD desired-state input.
        status: [success (1/0), tip position error (m), orientation error (rad),
            consecutive failures] of the last solve. On an unreachable target the system holds
            its last valid solution and reports success 0 with the residual of the attempt.
    """

    def __init__(self, ik: ToolTipIK, q0, period: float):
        super().__init__()
        self._ik = ik
        q0 = ik.check_q(q0, "q0")
        self._pose_port = self.DeclareVectorInputPort("tip_pose_desired", 7)
        self._state = self.DeclareDiscreteState(np.concatenate([q0, [1.0, 0.0, 0.0, 0.0]]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        # Outputs depend on the discrete state only: cached between plant steps.
        xd = {self.xd_ticket()}
        self.DeclareVectorOutputPort("q_desired", 7, self._calc_q, prerequisites_of_calc=xd)
        self.DeclareVectorOutputPort("desired_state", 14, self._calc_desired_state,
                                     prerequisites_of_calc=xd)
        self.DeclareVectorOutputPort("status", 4, self._calc_status, prerequisites_of_calc=xd)
        self.last_result: IKResult | None = None

    @property
    def ik(self) -> ToolTipIK:
        return self._ik

    def _update(self, context, discrete_state):
        x = context.get_discrete_state(self._state).get_value()
        q_last, failures = x[:7], x[10]
        X_WT = pose_from_vector(self._pose_port.Eval(context))
        result = self._ik.solve(X_WT, q_seed=q_last)
        self.last_result = result
        if result.success:
            new = np.concatenate([result.q, [1.0, result.position_error,
                                             result.orientation_error, 0.0]])
        else:
            new = np.concatenate([q_last, [0.0, result.position_error,
                                           result.orientation_error, failures + 1]])
        discrete_state.get_mutable_vector(self._state).SetFromVector(new)

    def _calc_q(self, context, output):
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[:7])

    def _calc_desired_state(self, context, output):
        q = context.get_discrete_state(self._state).get_value()[:7]
        output.SetFromVector(np.concatenate([q, np.zeros(7)]))

    def _calc_status(self, context, output):
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[7:])


def home_configuration(scenario, tool_length: float | None,
                       grasp_offset=(0.0, 0.0)) -> np.ndarray:
    """Right-arm joint angles of the scenario's home pose for a tool of `tool_length` m (None:
    no tool), warm-started from its posture seed, within the conservative limits if the
    scenario's robot keeps them. Raises if unreachable."""
    from drake_tooluse.scene import home_tip_pose

    limits = joint_limit_kwargs(scenario.robot.conservative_limits)
    ik = ToolTipIK(tool_length, grasp_offset=grasp_offset, **limits)
    result = ik.solve(home_tip_pose(scenario), q_seed=scenario.robot.posture_seed)
    if not result.success:
        raise ValueError(
            f"the scenario's home pose (tip at {home_tip_pose(scenario).translation().tolist()}"
            f" m) is unreachable with tool length {tool_length} m: residual {result.position_error:.3g} m,"
            f" {result.orientation_error:.3g} rad"
            f"{' within the conservative joint limits' if limits else ''}; move "
            "robot.home_tip_xy / home_tip_height")
    return result.q


def add_differential_ik(builder, ik: ToolTipIK, q0, period: float):
    """A cheaper first-order alternative to `ToolTipIKSystem` for training: Drake's
    `DifferentialInverseKinematicsIntegrator` on the tool-tip frame of the robot model (one QP
    per control period, joint position limits respected; all C++, no Python in the loop). Connect a RigidTransform X_WT* to its `X_AE_desired` input; its
    `joint_positions` output (7) are the joint targets. Set its positions to q0 at each
    episode start (`SetPositions`).
    """
    from pydrake.multibody.inverse_kinematics import (
        DifferentialInverseKinematicsIntegrator,
        DifferentialInverseKinematicsParameters,
    )

    plant = ik.plant
    for joint, q in zip([plant.GetJointByName(n) for n in RIGHT_ARM_JOINTS], q0):
        joint.set_default_angle(q)
    params = DifferentialInverseKinematicsParameters(7, 7)
    params.set_joint_position_limits((ik.lower, ik.upper))
    # No joint velocity limits, like the full IK: the step is the whole Newton step, and the
    # PD controllers (effort-limited) decide how fast the arm gets there.
    params.set_nominal_joint_position(np.asarray(q0, float))
    params.set_joint_centering_gain(0.01 * np.eye(7))  # a light pull toward the home posture
    return builder.AddNamedSystem("differential_ik", DifferentialInverseKinematicsIntegrator(
        plant, ik.tip_frame, period, params, log_only_when_result_state_changes=True))
