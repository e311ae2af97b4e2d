"""Tool-tip inverse kinematics, exact: a frame F of the believed tool (default its tip T) at a
desired pose X_WF* to 1e-10.

`ToolTipIK(tool, frame="tool_tip").solve(X_WT_desired, q_seed)`, `tool` a `robot.tool.Tool` or
a length (m: a straight tool), `frame` any named frame of it:

1. **Fast path**: Levenberg–Marquardt on the arm's chain (`robot.kinematics`, read from the
   same robot model, its fixed end offset X_GF = X_GH · X_HF), from `q_seed`, then from the
   nearest entries of a seed library of configurations drawn once with fixed seeds.
   Damped least-squares steps move the joints as little as the frame's error needs, so a
   warm start stays on its branch. Its answer counts only once Drake's own forward
   kinematics of the robot model certifies it (position within 1e-5 m, orientation within
   1e-4 rad, the joints within their limits).
2. **Solver of record, and the fallback**: Drake `InverseKinematics` with a position and an
   orientation constraint on F (plus the joint limits), solved by SNOPT from the seed and
   then library entries (`solve_with_snopt`), where the fast path finds nothing. A test
   holds the fast path to it.

An unreachable target is a result (`success=False` with the residual), never an exception.

- `gripper_target_from_tip_target` is the paper's offset method: the gripper goes to the tip
  target minus the tool vector rotated by the target orientation, v' = q v q^-1.

The solver runs on the robot model (`robot.model.make_robot_model`: the believed tool);
`systems.tool_tip_ik.ToolTipIKSystem` wraps it as a LeafSystem.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import SnoptSolver, SolverOptions

from drake_tooluse.robot.baxter_model import (
    Q_LOWER,
    Q_LOWER_CONSERVATIVE,
    Q_MID,
    Q_UPPER,
    Q_UPPER_CONSERVATIVE,
    RIGHT_ARM_JOINTS,
)
from drake_tooluse.robot.kinematics import (
    ArmChain,
    levenberg_marquardt,
    library_poses,
    pose_errors,
    rotation_from_quaternion,
    task_distances,
)
from drake_tooluse.robot.model import (
    GRIPPER_FRAME,
    TIP_FRAME,
    RobotBelief,
    make_robot_model,
    plant_frame_name,
)
from drake_tooluse.robot.tool import GRASP, Tool
from drake_tooluse.validation import check_finite_vector, check_unit_quaternion


def joint_limit_kwargs(conservative: bool) -> dict:
    """`ToolTipIK` keyword arguments for the conservative limits, or none for Baxter's own."""
    return (
        {"joint_lower": Q_LOWER_CONSERVATIVE, "joint_upper": Q_UPPER_CONSERVATIVE}
        if conservative
        else {}
    )


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
# The fast path: library seeds tried after the warm start (from each of the two libraries, by
# default), the error it drives down to (m and rad: well below the success tolerances), its
# iterations per start, and its largest joint step per iteration (rad: a cap that keeps a far
# start from swinging through a singularity).
FAST_LIBRARY_STARTS = 24
FAST_TOLERANCE = 1e-10
FAST_ITERATIONS = 100
FAST_MAX_STEP = 0.5
# The pull of each step toward mid-range along the arm's self-motions (a fraction of the
# offset): solve after solve along a path, it keeps the redundant joint from drifting to a
# limit, where the next warm start would fail and a library start land on another branch.
FAST_CENTERING = 0.05


@dataclass
class IKResult:
    """q: right-arm joint angles s0 … w2 (rad); errors are of the tip frame at q."""

    q: np.ndarray
    success: bool
    position_error: float  # m
    orientation_error: float  # rad
    solve_time: float  # s, wall clock, all attempts
    attempts: int = 1
    solver: str = "newton"  # "newton" (the fast path) or "snopt" (InverseKinematics)

    def as_dict(self) -> dict:
        return {
            "q": [float(x) for x in self.q],
            "joint_names": list(RIGHT_ARM_JOINTS),
            "success": bool(self.success),
            "position_error_m": float(self.position_error),
            "orientation_error_rad": float(self.orientation_error),
            "solve_time_s": float(self.solve_time),
            "attempts": int(self.attempts),
            "solver": self.solver,
        }


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
    """Accepts a RigidTransform or a 7-vector; non-finite values and a rotation that is not
    orthonormal (Drake's release builds accept one) are errors."""
    if isinstance(X_WT, RigidTransform):
        check_finite_vector(X_WT.GetAsMatrix4().reshape(-1), 16, "tool-tip pose X_WT")
        if not X_WT.rotation().IsValid():
            raise ValueError(
                f"tool-tip pose X_WT has a rotation that is not orthonormal: "
                f"{np.round(X_WT.rotation().matrix(), 6).tolist()}"
            )
        return X_WT
    return pose_from_vector(X_WT)


def target_arrays(X_WT) -> tuple[np.ndarray, np.ndarray]:
    """(p_WT (3,), R_WT (3, 3)) of a target given as a RigidTransform or as a 7-vector [p,
    quaternion wxyz] (normalized here), checked as `check_pose` checks it."""
    if isinstance(X_WT, RigidTransform):
        X_WT = check_pose(X_WT)
        return X_WT.translation(), X_WT.rotation().matrix()
    x = check_finite_vector(X_WT, 7, "tool-tip pose [x y z qw qx qy qz]")
    quat = check_unit_quaternion(x[3:], "tool-tip orientation quaternion (w, x, y, z)")
    return x[:3], rotation_from_quaternion(quat)


def tool_offset(tool, frame: str = TIP_FRAME) -> np.ndarray:
    """v = p_GF: the vector to the tool's frame F (default its tip) in the gripper frame for
    the nominal grasp (the tool axis is +z of G); `tool` a `robot.tool.Tool` or a length (m)."""
    if isinstance(tool, Tool):
        return np.array(tool.X_HF(frame).translation)
    return np.array([0.0, 0.0, float(tool)])


def gripper_target_from_tip_target(X_WT: RigidTransform, tool) -> RigidTransform:
    """The paper's offset method: p_WG = p_WT - v' with v' = q v q^-1 (q the target
    orientation, v the tool vector `tool_offset(tool)`: a length in m, or a `robot.tool.Tool`
    whose tip frame has the handle's orientation); the gripper takes the target orientation."""
    X_WT = check_pose(X_WT)
    if isinstance(tool, Tool) and not tool.X_HF(TIP_FRAME).is_translation():
        raise ValueError(
            "the offset method needs a tip frame with the handle's orientation; this tool's "
            "tip frame is rotated (use ToolTipIK on the tool)"
        )
    q = X_WT.rotation().ToQuaternion()
    v_rotated = q.rotation() @ tool_offset(tool)  # q v q^-1
    return RigidTransform(X_WT.rotation(), X_WT.translation() - v_rotated)


class ToolTipIK:
    """Solves for the right-arm joints that put a frame F of the believed tool (default its
    tip T) at a desired pose X_WF.

    Args:
        tool: the believed tool, a `robot.tool.Tool`, or its length (m, in (0, 0.60]: a
            `StraightTool`); None for no tool (T = gripper). `tool_length=` is the same
            argument under its old name.
        frame: the tool's frame F the IK places: any of `tool.frame_names()` (`grasp` is H,
            the plant's `tool_grasp`); default `tool_tip`.
        grasp_offset: believed (across, along) offset of the grasp point from the gripper
            frame's origin (m; default 0, 0): with the camera's estimate the IK also knows
            where the hand holds the tool (see `builders.measurement`).
        joint_lower, joint_upper: joint limits (rad) s0 … w2; default Baxter's.
        max_attempts: SNOPT solves tried where the fast path finds nothing (the warm start,
            then library seeds).
        library_starts: fast-path starts from each seed library after the warm start.
        library_size: configurations in the central seed library (drawn with a fixed seed,
            so the same call gives the same result); the full-range library has half as many.

    Attributes: `tool` (the description or None), `tool_length` (m, `Tool.reach`, or None),
    `frame` (F's name), `tip_frame` (F in `plant`).
    """

    def __init__(
        self,
        tool: Tool | float | None = None,
        *,
        frame: str = TIP_FRAME,
        grasp_offset=(0.0, 0.0),
        joint_lower=None,
        joint_upper=None,
        max_attempts: int = 16,
        library_size: int = 4000,
        library_starts: int = FAST_LIBRARY_STARTS,
        tool_length: float | None = None,
    ):
        if tool_length is not None:
            if tool is not None:
                raise ValueError("give the tool or its tool_length, not both")
            tool = tool_length
        self.grasp_offset = tuple(float(v) for v in grasp_offset)
        belief = RobotBelief(tool, self.grasp_offset)
        self.tool = belief.tool
        self.tool_length = belief.tool_length
        self.plant = make_robot_model(self.tool, grasp_offset=self.grasp_offset)
        self.context = self.plant.CreateDefaultContext()
        names = [TIP_FRAME] if self.tool is None else self.tool.frame_names()
        if frame not in names and not (self.tool is not None and frame == plant_frame_name(GRASP)):
            raise ValueError(
                f"frame={frame!r} is not a frame of the believed tool; choose one of {names}"
            )
        self.frame = frame
        self.tip_frame = self.plant.GetFrameByName(plant_frame_name(frame))
        self.gripper_frame = self.plant.GetFrameByName(GRIPPER_FRAME)
        self.lower = (
            Q_LOWER.copy()
            if joint_lower is None
            else check_finite_vector(joint_lower, 7, "joint_lower")
        )
        self.upper = (
            Q_UPPER.copy()
            if joint_upper is None
            else check_finite_vector(joint_upper, 7, "joint_upper")
        )
        if np.any(self.lower > self.upper):
            raise ValueError(
                f"joint_lower {self.lower.tolist()} exceeds joint_upper {self.upper.tolist()}"
            )
        if max_attempts < 1:
            raise ValueError(f"max_attempts={max_attempts} must be at least 1")
        self.max_attempts = int(max_attempts)
        if library_starts < 0:
            raise ValueError(f"library_starts={library_starts} must be at least 0")
        self.library_starts = int(library_starts)
        self.q_nominal = np.clip(Q_MID, self.lower, self.upper)
        self.chain = ArmChain.from_plant(self.plant, self.tip_frame)
        self._solver = SnoptSolver()
        self._options = SolverOptions()
        # Tighter than SNOPT's default 1e-6 so that the orientation constraint (a bound on
        # the cosine of the angle) holds to ~1e-5 rad instead of ~1e-3 rad.
        self._options.SetOption(self._solver.id(), "Major feasibility tolerance", 1e-10)
        self._options.SetOption(self._solver.id(), "Major optimality tolerance", 1e-6)
        self._options.SetOption(self._solver.id(), "Major iterations limit", 60)
        self._library_size = int(library_size)
        self._seed_libraries = None

    @property
    def _libraries(self) -> list:
        """The two seed libraries, (q, p, R) each, of configurations drawn once with fixed
        seeds: `library_size` in the central 80 % of each joint's range, where seeds rarely
        end against a limit, and half as many over the full range, for targets that need a
        joint near its limit.
        Built on first use: most solves in a control loop never need them (the warm start
        succeeds), and an env that draws a tool per episode builds a new IK each episode."""
        if self._seed_libraries is None:
            size = self._library_size
            centre, half = (self.lower + self.upper) / 2, (self.upper - self.lower) / 2
            self._seed_libraries = [
                self._library(centre - 0.8 * half, centre + 0.8 * half, size, seed=1),
                self._library(self.lower, self.upper, max(size // 2, 1), seed=2),
            ]
        return self._seed_libraries

    def _library(self, lower, upper, size: int, seed: int):
        q = np.random.default_rng(seed).uniform(lower, upper, size=(size, 7))
        p, R = np.empty((size, 3)), np.empty((size, 3, 3))
        library_poses(self.chain.fixed, self.chain.axes, q, p, R)
        return q, p, R

    def _seed_distance(self, X_WT: RigidTransform, q_seed: np.ndarray) -> float:
        """Position distance (m) + 0.2 m/rad x rotation angle of the seed's tip from X_WT."""
        X = self.fk(q_seed)
        p_target, R_target = X_WT.translation(), X_WT.rotation().matrix()
        return float(
            task_distances(X.translation()[None], X.rotation().matrix()[None], p_target, R_target)[
                0
            ]
        )

    def library_seeds(self, X_WT, count: int) -> list[np.ndarray]:
        """The `count` nearest entries (task space: m + 0.2 m/rad) of each of the two
        libraries to the target X_WT (a RigidTransform or (p, R) arrays), nearest first,
        alternating."""
        p_target, R_target = (
            (X_WT.translation(), X_WT.rotation().matrix())
            if isinstance(X_WT, RigidTransform)
            else X_WT
        )
        nearest = []
        for q, p, R in self._libraries:
            d = task_distances(p, R, p_target, R_target)
            k = min(count, len(d))
            closest = np.argpartition(d, k - 1)[:k]
            nearest.append([q[i] for i in closest[np.argsort(d[closest])]])
        return [s for pair in zip(*nearest) for s in pair]

    def attempts(self, X_WT: RigidTransform, q_seed: np.ndarray, max_attempts: int):
        """Yields (seed, find_basin) to try, best first, computing the library order only if
        needed. A warm start within NEAR_DISTANCE is tried first with the constrained solve
        alone (it is in the right basin); one within WARM_START_DISTANCE with both phases; a
        farther one after the nearest central-library entry."""
        d_seed = self._seed_distance(X_WT, q_seed)
        if d_seed <= NEAR_DISTANCE:
            yield q_seed, False
        if d_seed <= WARM_START_DISTANCE:
            yield q_seed, True
            yield from ((q, True) for q in self.library_seeds(X_WT, max_attempts))
            return
        library = self.library_seeds(X_WT, max_attempts)
        yield library[0], True
        yield q_seed, True
        yield from ((q, True) for q in library[1:])

    # -- kinematics -------------------------------------------------------------------------
    def check_q(self, q, name: str = "q") -> np.ndarray:
        """q must be 7 finite joint angles within the limits (rad)."""
        q = check_finite_vector(q, 7, name)
        bad = [
            (RIGHT_ARM_JOINTS[i], q[i], self.lower[i], self.upper[i])
            for i in range(7)
            if not self.lower[i] - 1e-9 <= q[i] <= self.upper[i] + 1e-9
        ]
        if bad:
            text = "; ".join(
                f"{n}={v:.4g} rad outside [{lo:.4g}, {hi:.4g}]" for n, v, lo, hi in bad
            )
            raise ValueError(f"{name} is outside the joint limits: {text}")
        return q

    def fk(self, q) -> RigidTransform:
        """X_WF: the pose of the IK's frame F (default the tool tip T) at joint angles q (7
        finite values, rad), by Drake."""
        self.plant.SetPositions(self.context, check_finite_vector(q, 7, "q"))
        return self.tip_frame.CalcPoseInWorld(self.context)

    def fk_gripper(self, q) -> RigidTransform:
        """X_WG: the gripper's pose at joint angles q (7 finite values, rad), by Drake."""
        self.plant.SetPositions(self.context, check_finite_vector(q, 7, "q"))
        return self.gripper_frame.CalcPoseInWorld(self.context)

    def errors(self, q, X_WT) -> tuple[float, float]:
        """(position error m, orientation error rad) of F at q from the target X_WT (a
        RigidTransform or (p, R) arrays), by Drake's forward kinematics of the robot model."""
        p_target, R_target = (
            (X_WT.translation(), X_WT.rotation().matrix())
            if isinstance(X_WT, RigidTransform)
            else X_WT
        )
        X = self.fk(q)
        return pose_errors(X.translation(), X.rotation().matrix(), p_target, R_target)

    def _certify(self, q: np.ndarray, p: np.ndarray, R: np.ndarray) -> tuple[float, float]:
        """`errors` by Drake's forward kinematics for the fast path's own (finite) answer."""
        self.plant.SetPositions(self.context, q)
        X = self.tip_frame.CalcPoseInWorld(self.context)
        return pose_errors(X.translation(), X.rotation().matrix(), p, R)

    # -- IK ---------------------------------------------------------------------------------
    def _new_ik(self, X_WT: RigidTransform) -> InverseKinematics:
        ik = InverseKinematics(self.plant, self.context, with_joint_limits=False)
        ik.get_mutable_prog().AddBoundingBoxConstraint(self.lower, self.upper, ik.q())
        p = X_WT.translation()
        ik.AddPositionConstraint(self.tip_frame, np.zeros(3), self.plant.world_frame(), p, p)
        return ik

    def _solve_once(
        self, X_WT: RigidTransform, q_seed: np.ndarray, find_basin: bool = True
    ) -> np.ndarray:
        if not find_basin:
            return self._solve_constrained(X_WT, q_seed)
        # Phase 1: tip position constrained, orientation as a cost. This finds the basin
        # quickly; where it ends far from the target orientation, the seed is in the wrong
        # basin and the attempt stops early.
        ik = self._new_ik(X_WT)
        ik.AddOrientationCost(
            self.plant.world_frame(), X_WT.rotation(), self.tip_frame, RotationMatrix(), 10.0
        )
        result = self._solver.Solve(ik.prog(), q_seed, self._options)
        q1 = np.clip(result.GetSolution(ik.q()), self.lower, self.upper)
        if self.errors(q1, X_WT)[1] > BASIN_ANGLE:
            return q1
        # Phase 2: position and orientation constraints on the tip frame, from phase 1.
        return self._solve_constrained(X_WT, q1)

    def _solve_constrained(self, X_WT: RigidTransform, q_seed: np.ndarray) -> np.ndarray:
        """Position and orientation constraints on the tip frame, from q_seed."""
        ik = self._new_ik(X_WT)
        ik.AddOrientationConstraint(
            self.plant.world_frame(), X_WT.rotation(), self.tip_frame, RotationMatrix(), 0.0
        )
        result = self._solver.Solve(ik.prog(), q_seed, self._options)
        return result.GetSolution(ik.q())

    def solve(self, X_WT_desired, q_seed=None, max_attempts: int | None = None) -> IKResult:
        """Joint angles that put T at X_WT_desired (a RigidTransform or [p, quaternion wxyz]),
        warm-started from `q_seed` (default: mid-range): the fast path, then, where it finds
        nothing, at most `max_attempts` SNOPT solves (default: the solver's own)."""
        p, R = target_arrays(X_WT_desired)
        q_seed = self.q_nominal if q_seed is None else check_finite_vector(q_seed, 7, "q_seed")
        q_seed = np.minimum(np.maximum(q_seed, self.lower), self.upper)
        limit = self.max_attempts if max_attempts is None else int(max_attempts)
        if limit < 1:
            raise ValueError(f"max_attempts={limit} must be at least 1")
        start = time.perf_counter()
        q, starts, pos_err, rot_err = self._solve_fast(p, R, q_seed)
        if q is not None:
            return IKResult(q, True, pos_err, rot_err, time.perf_counter() - start, starts)
        result = self.solve_with_snopt(RigidTransform(RotationMatrix(R), p), q_seed, limit)
        result.solve_time = time.perf_counter() - start
        result.attempts += starts
        return result

    def _solve_fast(self, p: np.ndarray, R: np.ndarray, q_seed: np.ndarray):
        """Levenberg–Marquardt from the seed, then from the nearest library entries, until an
        answer that Drake's forward kinematics certifies. Returns (q, starts tried, position
        error, orientation error); q is None if no start gave one."""
        starts = 0
        for q_start in self._fast_starts(p, R, q_seed):
            starts += 1
            q, distance, angle, _ = levenberg_marquardt(
                self.chain.fixed, self.chain.axes, self.lower, self.upper, p, R, q_start,
                FAST_TOLERANCE, FAST_ITERATIONS, FAST_MAX_STEP, FAST_CENTERING,
            )  # fmt: skip
            if distance <= POSITION_TOLERANCE and angle <= ORIENTATION_TOLERANCE:
                pos_err, rot_err = self._certify(q, p, R)
                if pos_err <= POSITION_TOLERANCE and rot_err <= ORIENTATION_TOLERANCE:
                    return q, starts, pos_err, rot_err
        return None, starts, np.inf, np.inf

    def _fast_starts(self, p: np.ndarray, R: np.ndarray, q_seed: np.ndarray):
        """The seed, then (only if needed) the nearest library entries."""
        yield q_seed
        if self.library_starts:
            yield from self.library_seeds((p, R), self.library_starts)

    def solve_with_snopt(self, X_WT_desired, q_seed=None, max_attempts: int | None = None):
        """The solver of record: Drake `InverseKinematics` (position and orientation
        constraints on T, the joint limits) by SNOPT, from the seed and library entries,
        at most `max_attempts` solves."""
        X_WT = check_pose(X_WT_desired)
        q_seed = self.q_nominal if q_seed is None else check_finite_vector(q_seed, 7, "q_seed")
        q_seed = np.clip(q_seed, self.lower, self.upper)
        limit = self.max_attempts if max_attempts is None else int(max_attempts)
        if limit < 1:
            raise ValueError(f"max_attempts={limit} must be at least 1")
        start = time.perf_counter()
        best = None
        attempt = 0
        for q_try, find_basin in self.attempts(X_WT, q_seed, limit):
            attempt += 1
            if attempt > limit:
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
        return IKResult(
            q=q,
            success=bool(ok),
            position_error=pos_err,
            orientation_error=rot_err,
            solve_time=time.perf_counter() - start,
            attempts=attempt,
            solver="snopt",
        )
