"""The right arm's kinematic chain read from the robot model, with compiled kernels for the
tool tip's forward kinematics, Jacobian and a Levenberg–Marquardt IK.

The chain is not a second model: `ArmChain.from_plant` reads it from the Drake plant that
`robot.model.make_robot_model` builds from `models/baxter/baxter.urdf` (each joint's parent
frame F_i relative to the previous joint's child frame M_{i-1}, its axis in F_i, and the tool
tip T relative to M_6), so it holds whatever that plant holds; a test holds the kernels to
Drake's own `CalcPoseInWorld` and `CalcJacobianSpatialVelocity`.

    X_WT(q) = X_WF0 · R_0(q_0) · X_M0F1 · R_1(q_1) · … · R_6(q_6) · X_M6T

The kernels are numba-compiled loops over 3x3 blocks (about 1 µs for the pose and the 6x7
Jacobian together, where Drake's Python-bound calls take tens), compiled once per machine
(`cache=True`). Frames: W world, T tool tip; Jacobian rows [v_WT (3); ω_WT (3)], in W.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from drake_tooluse.robot.baxter_model import RIGHT_ARM_JOINTS


@dataclass(frozen=True)
class ArmChain:
    """The seven revolute joints from the world to the tip frame, as arrays the kernels take."""

    fixed: np.ndarray  # (8, 4, 4): X_{prev F_i} for i = 0..6 (prev: W, then M_{i-1}); X_{M_6 T}
    axes: np.ndarray  # (7, 3): each joint's unit axis in F_i (= in M_i)

    @staticmethod
    def from_plant(plant, tip_frame) -> ArmChain:
        """Reads the chain of the right arm to `tip_frame` from a finalized plant whose only
        positions are the seven right-arm joints (the robot model)."""
        joints = [plant.GetJointByName(name) for name in RIGHT_ARM_JOINTS]
        if plant.num_positions() != 7 or [j.position_start() for j in joints] != list(range(7)):
            raise ValueError("the plant's positions must be the seven right-arm joints, in order")
        context = plant.CreateDefaultContext()
        fixed, axes, previous = [], [], plant.world_frame()
        for joint in joints:
            # Between two joints there are only welds: these poses do not depend on q.
            fixed.append(
                plant.CalcRelativeTransform(
                    context, previous, joint.frame_on_parent()
                ).GetAsMatrix4()
            )
            axes.append(np.asarray(joint.revolute_axis(), float))
            previous = joint.frame_on_child()
        fixed.append(plant.CalcRelativeTransform(context, previous, tip_frame).GetAsMatrix4())
        return ArmChain(np.ascontiguousarray(fixed), np.ascontiguousarray(axes))

    def pose(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(R_WT (3, 3), p_WT (3,)) at joint angles q (rad)."""
        R, p, J = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
        fk_jacobian(self.fixed, self.axes, np.asarray(q, float), R, p, J)
        return R, p

    def jacobian(self, q) -> np.ndarray:
        """J (6, 7): [v_WT; ω_WT] = J q̇, in W."""
        R, p, J = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
        fk_jacobian(self.fixed, self.axes, np.asarray(q, float), R, p, J)
        return J


@numba.njit(cache=True)
def _mul3(A, B, out):
    for r in range(3):
        for c in range(3):
            out[r, c] = A[r, 0] * B[0, c] + A[r, 1] * B[1, c] + A[r, 2] * B[2, c]


@numba.njit(cache=True)
def fk_jacobian(fixed, axes, q, R_out, p_out, J_out):
    """Writes R_WT, p_WT and the geometric Jacobian J (rows v, ω; in W) at q."""
    R = np.eye(3)
    p = np.zeros(3)
    origins = np.empty((7, 3))
    axes_W = np.empty((7, 3))
    tmp = np.empty((3, 3))
    rot = np.empty((3, 3))
    for i in range(7):
        for r in range(3):
            p[r] += R[r, 0] * fixed[i, 0, 3] + R[r, 1] * fixed[i, 1, 3] + R[r, 2] * fixed[i, 2, 3]
        _mul3(R, fixed[i, :3, :3], tmp)
        R[:, :] = tmp
        x, y, z = axes[i, 0], axes[i, 1], axes[i, 2]
        for r in range(3):
            axes_W[i, r] = R[r, 0] * x + R[r, 1] * y + R[r, 2] * z
            origins[i, r] = p[r]
        c, s = np.cos(q[i]), np.sin(q[i])
        v = 1.0 - c
        rot[0, 0], rot[0, 1], rot[0, 2] = c + x * x * v, x * y * v - z * s, x * z * v + y * s
        rot[1, 0], rot[1, 1], rot[1, 2] = y * x * v + z * s, c + y * y * v, y * z * v - x * s
        rot[2, 0], rot[2, 1], rot[2, 2] = z * x * v - y * s, z * y * v + x * s, c + z * z * v
        _mul3(R, rot, tmp)
        R[:, :] = tmp
    for r in range(3):
        p[r] += R[r, 0] * fixed[7, 0, 3] + R[r, 1] * fixed[7, 1, 3] + R[r, 2] * fixed[7, 2, 3]
    _mul3(R, fixed[7, :3, :3], R_out)
    p_out[:] = p
    for i in range(7):
        dx, dy, dz = p[0] - origins[i, 0], p[1] - origins[i, 1], p[2] - origins[i, 2]
        ax, ay, az = axes_W[i, 0], axes_W[i, 1], axes_W[i, 2]
        J_out[0, i] = ay * dz - az * dy
        J_out[1, i] = az * dx - ax * dz
        J_out[2, i] = ax * dy - ay * dx
        J_out[3, i] = ax
        J_out[4, i] = ay
        J_out[5, i] = az


@numba.njit(cache=True)
def _tip_error(p_target, R_target, p, R, e):
    """e = [p* - p; w] with exp([w]) R = R*; returns the angle |w| (rad)."""
    E = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            E[r, c] = R_target[r, 0] * R[c, 0] + R_target[r, 1] * R[c, 1] + R_target[r, 2] * R[c, 2]
    sx, sy, sz = E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]
    s = 0.5 * np.sqrt(sx * sx + sy * sy + sz * sz)
    angle = np.arctan2(s, 0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0))
    if s > 1e-9:
        f = 0.5 * angle / s
    elif angle < 1.0:  # near identity: w ≈ the skew part
        f = 0.5
    else:  # near a half turn the skew part vanishes: the axis from the symmetric part,
        # S = cos(angle) I + (1 - cos(angle)) a aᵀ, its largest diagonal's column
        cos_angle = np.cos(angle)
        k = 0
        for j in range(1, 3):
            if E[j, j] > E[k, k]:
                k = j
        axis = np.empty(3)
        for j in range(3):
            axis[j] = 0.5 * (E[k, j] + E[j, k])
        axis[k] -= cos_angle
        n = np.sqrt(axis[0] ** 2 + axis[1] ** 2 + axis[2] ** 2)
        for j in range(3):
            e[j] = p_target[j] - p[j]
            e[3 + j] = angle * axis[j] / n
        return angle
    for j in range(3):
        e[j] = p_target[j] - p[j]
    e[3], e[4], e[5] = f * sx, f * sy, f * sz
    return angle


@numba.njit(cache=True)
def _cholesky6(M, L):
    """L Lᵀ = M for a symmetric positive definite 6x6 M."""
    L[:, :] = 0.0
    for i in range(6):
        for j in range(i + 1):
            s = M[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = np.sqrt(max(s, 1e-300))
            else:
                L[i, j] = s / L[j, j]


@numba.njit(cache=True)
def _cholesky_solve6(L, b, out):
    """out = (L Lᵀ)⁻¹ b."""
    y = np.empty(6)
    for i in range(6):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(5, -1, -1):
        s = y[i]
        for k in range(i + 1, 6):
            s -= L[k, i] * out[k]
        out[i] = s / L[i, i]


@numba.njit(cache=True)
def levenberg_marquardt(
    fixed, axes, lower, upper, p_target, R_target, q_start, tolerance, max_iterations, max_step,
    centering,
):  # fmt: skip
    """Joint angles within [lower, upper] that put the tip at (p*, R*), from `q_start`.

    Each step is the damped least-squares step dq = Jᵀ (J Jᵀ + λ I)⁻¹ e (the smallest joint
    motion that reduces the 6-d tip error e, so a warm start stays on its branch), plus
    on the first step `centering` × the mid-range offset projected onto the self-motions
    (I - Jᵀ (J Jᵀ + λ I)⁻¹ J): it leaves the tip where it is and keeps the redundant arm from
    drifting, solve after solve, toward its limits. Joints at a limit that the step would push further out are
    frozen for the step, ‖dq‖ is capped at `max_step` rad, and λ adapts: a step that lowers
    ‖e‖² is taken (without the centering if only that lowers it) and λ shrinks, else λ grows.
    Stops when ‖p* - p‖ and the angle to R* are both below `tolerance` (m, rad). Returns (q,
    position error m, angle rad, iterations)."""
    q = q_start.copy()
    R, p, J = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
    Rn, pn, Jn = np.empty((3, 3)), np.empty(3), np.empty((6, 7))
    e, en, y = np.empty(6), np.empty(6), np.empty(6)
    M, L = np.empty((6, 6)), np.empty((6, 6))
    qn, dq, null = np.empty(7), np.empty(7), np.empty(7)
    Jc, Jc_y = np.empty(6), np.empty(6)
    free = np.empty(7, dtype=np.bool_)
    fk_jacobian(fixed, axes, q, R, p, J)
    angle = _tip_error(p_target, R_target, p, R, e)
    cost = 0.0
    for k in range(6):
        cost += e[k] * e[k]
    damping = 1e-3
    iteration = 0
    while iteration < max_iterations:
        distance = np.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2)
        if distance < tolerance and angle < tolerance:
            return q, distance, angle, iteration
        iteration += 1
        for i in range(7):
            g = 0.0
            for r in range(6):
                g += J[r, i] * e[r]
            free[i] = not ((q[i] <= lower[i] and g < 0.0) or (q[i] >= upper[i] and g > 0.0))
        for r in range(6):
            for c in range(r + 1):
                s = 0.0
                for i in range(7):
                    if free[i]:
                        s += J[r, i] * J[c, i]
                M[r, c] = s
                M[c, r] = s
            M[r, r] += damping
        _cholesky6(M, L)
        _cholesky_solve6(L, e, y)
        # The centering's self-motion: c - Jᵀ (J Jᵀ + λ I)⁻¹ J c, c toward mid-range.
        pull = centering if iteration == 1 else 0.0  # once per solve: a nudge, not a fight
        for i in range(7):
            null[i] = pull * (0.5 * (lower[i] + upper[i]) - q[i]) if free[i] else 0.0
        for r in range(6):
            s = 0.0
            for i in range(7):
                s += J[r, i] * null[i]
            Jc[r] = s
        _cholesky_solve6(L, Jc, Jc_y)
        largest = 0.0
        for i in range(7):
            s, t = 0.0, 0.0
            if free[i]:
                for r in range(6):
                    s += J[r, i] * y[r]
                    t += J[r, i] * Jc_y[r]
                null[i] -= t
            dq[i] = s
            largest = max(largest, abs(s + null[i]))
        scale = max_step / largest if largest > max_step else 1.0
        taken = False
        for with_centering in (True, False):
            for i in range(7):
                step = dq[i] + null[i] if with_centering else dq[i]
                qn[i] = min(max(q[i] + scale * step, lower[i]), upper[i])
            fk_jacobian(fixed, axes, qn, Rn, pn, Jn)
            angle_n = _tip_error(p_target, R_target, pn, Rn, en)
            cost_n = 0.0
            for k in range(6):
                cost_n += en[k] * en[k]
            if cost_n < cost:
                q[:], R[:, :], p[:], J[:, :], e[:] = qn, Rn, pn, Jn, en
                cost, angle = cost_n, angle_n
                taken = True
                break
        if taken:
            damping = max(0.1 * damping, 1e-12)
        else:
            damping *= 10.0
            if damping > 1e3:  # no step lowers the error: a local minimum (or a limit)
                break
    distance = np.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2)
    return q, distance, angle, iteration


@numba.njit(cache=True)
def rotation_from_quaternion(quaternion):
    """R (3, 3) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = quaternion[0], quaternion[1], quaternion[2], quaternion[3]
    R = np.empty((3, 3))
    R[0, 0], R[0, 1], R[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    R[1, 0], R[1, 1], R[1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    R[2, 0], R[2, 1], R[2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return R


@numba.njit(cache=True)
def pose_errors(p_a, R_a, p_b, R_b):
    """(‖p_a - p_b‖ m, the angle of the rotation between R_a and R_b, rad: atan2 of the sine
    and cosine, accurate near zero)."""
    d = 0.0
    for j in range(3):
        d += (p_a[j] - p_b[j]) ** 2
    e = np.empty(6)
    return np.sqrt(d), _tip_error(p_a, R_a, p_a, R_b, e)


@numba.njit(cache=True)
def task_distances(p_library, R_library, p_target, R_target):
    """Position distance (m) + 0.2 m/rad × rotation angle from each library pose to the
    target."""
    n = p_library.shape[0]
    out = np.empty(n)
    for k in range(n):
        d = 0.0
        for j in range(3):
            d += (p_library[k, j] - p_target[j]) ** 2
        trace = 0.0
        for r in range(3):
            for c in range(3):
                trace += R_target[r, c] * R_library[k, r, c]
        cos = min(max(0.5 * (trace - 1.0), -1.0), 1.0)
        out[k] = np.sqrt(d) + 0.2 * np.arccos(cos)
    return out


@numba.njit(cache=True)
def library_poses(fixed, axes, q_library, p_out, R_out):
    """The tip pose of each configuration of a seed library."""
    J = np.empty((6, 7))
    for k in range(q_library.shape[0]):
        fk_jacobian(fixed, axes, q_library[k], R_out[k], p_out[k], J)
