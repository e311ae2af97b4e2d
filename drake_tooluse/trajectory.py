"""Tool-tip trajectories as the paper made them, and their export for a real Baxter.

Record N episodes of a policy (tool-tip and gripper poses at each control step), average them
(positions by the mean, orientations by the quaternion average of Markley et al. 2007: the
principal eigenvector of Σ q qᵀ, blind to the sign of q), smooth, and keep the poses the robot
can reach under the conservative real-robot joint limits. A trajectory file is an `.npz` with
`times` (T,), `positions` (T, 3) and `quaternions` (T, 4, w x y z) of the tool tip in W.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drake_tooluse.baxter_model import ARM_JOINT_SUFFIXES, ARM_LIMITS, LEFT_ARM_JOINTS, RIGHT_ARM_JOINTS
from drake_tooluse.io import atomic_write_bytes, atomic_write_text
from drake_tooluse.validation import check_finite_vector, check_one_of


@dataclass
class TipTrajectory:
    """Tool-tip poses in W at times (s)."""

    times: np.ndarray  # (T,)
    positions: np.ndarray  # (T, 3)
    quaternions: np.ndarray  # (T, 4), w x y z, unit

    def __post_init__(self):
        self.times = np.asarray(self.times, float)
        self.positions = np.asarray(self.positions, float)
        self.quaternions = np.asarray(self.quaternions, float)
        T = self.times.shape[0]
        if self.times.ndim != 1 or T < 1:
            raise ValueError(f"times must be a non-empty vector; got shape {self.times.shape}")
        if self.positions.shape != (T, 3) or self.quaternions.shape != (T, 4):
            raise ValueError(f"positions {self.positions.shape} and quaternions "
                             f"{self.quaternions.shape} must be ({T}, 3) and ({T}, 4)")
        for name, a in (("times", self.times), ("positions", self.positions),
                        ("quaternions", self.quaternions)):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"trajectory {name} hold NaN or infinite values")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("trajectory times must increase strictly")
        norms = np.linalg.norm(self.quaternions, axis=1)
        if np.any(norms < 1e-6):
            raise ValueError("trajectory quaternions must be non-zero")
        self.quaternions = self.quaternions / norms[:, None]

    def __len__(self) -> int:
        return len(self.times)

    def save(self, path) -> Path:
        buffer = io.BytesIO()
        np.savez(buffer, times=self.times, positions=self.positions,
                 quaternions=self.quaternions)
        return atomic_write_bytes(path, buffer.getvalue())

    @staticmethod
    def load(path) -> "TipTrajectory":
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"trajectory file not found: {str(path)!r}")
        try:
            with np.load(path) as data:
                return TipTrajectory(data["times"], data["positions"], data["quaternions"])
        except (KeyError, ValueError, OSError) as e:
            raise ValueError(f"malformed trajectory file {str(path)!r}: {e} (it needs times "
                             "(T,), positions (T, 3), quaternions (T, 4))") from None


def average_quaternions(quaternions: np.ndarray, weights=None) -> np.ndarray:
    """The average rotation of unit quaternions (N, 4): the eigenvector of the largest
    eigenvalue of Σ w q qᵀ (Markley et al., 2007); q and −q count as the same rotation."""
    q = np.asarray(quaternions, float)
    w = np.ones(len(q)) if weights is None else np.asarray(weights, float)
    M = np.einsum("n,ni,nj->ij", w, q, q)
    values, vectors = np.linalg.eigh(M)
    mean = vectors[:, np.argmax(values)]
    return mean if mean[0] >= 0 else -mean


def average_episodes(positions: np.ndarray, quaternions: np.ndarray, period: float) -> TipTrajectory:
    """The per-step average of N episodes: positions (N, T, 3), quaternions (N, T, 4)."""
    positions = np.asarray(positions, float)
    quaternions = np.asarray(quaternions, float)
    T = positions.shape[1]
    mean_q = np.array([average_quaternions(quaternions[:, t]) for t in range(T)])
    return TipTrajectory(np.arange(T) * period, positions.mean(axis=0), mean_q)


def pad_episodes(episodes: list[np.ndarray]) -> np.ndarray:
    """Stacks episodes of different lengths, holding each one's last row (an episode that
    succeeded early stays where it ended)."""
    T = max(len(e) for e in episodes)
    return np.stack([np.vstack([e, np.repeat(e[-1:], T - len(e), axis=0)]) for e in episodes])


def smooth(traj: TipTrajectory, window: int = 5) -> TipTrajectory:
    """Centred moving average of `window` steps (odd), positions and quaternions alike."""
    if window < 1 or window % 2 == 0:
        raise ValueError(f"window={window} must be an odd number >= 1")
    half = window // 2
    T = len(traj)
    idx = [np.arange(max(0, t - half), min(T, t + half + 1)) for t in range(T)]
    positions = np.array([traj.positions[i].mean(axis=0) for i in idx])
    quaternions = np.array([average_quaternions(traj.quaternions[i]) for i in idx])
    return TipTrajectory(traj.times, positions, quaternions)


@dataclass
class ReachabilityReport:
    poses: int
    reachable: int
    kept: TipTrajectory
    joint_positions: np.ndarray  # (kept, 7) IK solutions, warm-started along the path
    dropped_indices: list


def filter_reachable(traj: TipTrajectory, tool_length: float | None,
                     conservative: bool = True, q_start=None) -> ReachabilityReport:
    """Solves the tool-tip IK along the trajectory, each pose warm-started from the last
    (the first from `q_start`, default the scenario's home posture), under the conservative
    real-robot limits (s1 in [-1.35, 1.0]) or Baxter's own; drops the poses it cannot reach."""
    from drake_tooluse.scenario import RobotConfig

    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform

    from drake_tooluse.ik import ToolTipIK, joint_limit_kwargs

    ik = ToolTipIK(tool_length, **joint_limit_kwargs(conservative))
    q_seed = np.asarray(RobotConfig().posture_seed if q_start is None else q_start, float)
    keep, qs, dropped = [], [], []
    for i, (p, quat) in enumerate(zip(traj.positions, traj.quaternions)):
        result = ik.solve(RigidTransform(Quaternion(quat), p), q_seed)
        if result.success:
            keep.append(i)
            qs.append(result.q)
            q_seed = result.q
        else:
            dropped.append(i)
    if not keep:
        raise ValueError("no pose of the trajectory is reachable with tool length "
                         f"{tool_length} m under the {'conservative' if conservative else ''} "
                         "joint limits")
    kept = TipTrajectory(traj.times[keep], traj.positions[keep], traj.quaternions[keep])
    return ReachabilityReport(len(traj), len(keep), kept, np.array(qs), dropped)


def tip_trajectory_source(traj: TipTrajectory, lead: float = 0.0):
    """A Drake TrajectorySource of the 7-vector [p_WT (3), quaternion wxyz (4)], linear between
    the samples (the IK normalizes the quaternion), held before the first and after the last;
    at time t it gives the trajectory at `t + lead` (a recorded trajectory holds where the tip
    *was*: lead by a control period to command where it goes next)."""
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    quaternions = traj.quaternions.copy()
    for i in range(1, len(quaternions)):  # one hemisphere, so interpolation takes the short way
        if quaternions[i] @ quaternions[i - 1] < 0:
            quaternions[i] = -quaternions[i]
    values = np.hstack([traj.positions, quaternions]).T
    times = traj.times - lead
    if len(times) == 1:
        polynomial = PiecewisePolynomial(values[:, :1])
    else:
        polynomial = PiecewisePolynomial.FirstOrderHold(times, values)
    return TrajectorySource(polynomial)


# -- Baxter SDK playback CSV ------------------------------------------------------------------
Q_LOWER = np.array([ARM_LIMITS[s][0] for s in ARM_JOINT_SUFFIXES])
Q_UPPER = np.array([ARM_LIMITS[s][1] for s in ARM_JOINT_SUFFIXES])
V_MAX = np.array([ARM_LIMITS[s][2] for s in ARM_JOINT_SUFFIXES])
CSV_HEADER = (["time", *LEFT_ARM_JOINTS, "left_gripper", *RIGHT_ARM_JOINTS, "right_gripper"])


def export_baxter_csv(path, times, right_q, left_q, gripper: float = 0.0) -> Path:
    """Writes a joint trajectory in the Baxter SDK playback format
    (`joint_trajectory_file_playback.py`): time in s from the start, both arms, both grippers
    (0–100, 0 = closed on the tool). Position and velocity limits are checked first; nothing is
    written if they fail."""
    times = check_finite_vector(times, len(np.atleast_1d(times)), "times")
    right_q = np.asarray(right_q, float)
    if right_q.shape != (len(times), 7) or not np.all(np.isfinite(right_q)):
        raise ValueError(f"right_q must be finite with shape ({len(times)}, 7); got "
                         f"{right_q.shape}")
    left_q = check_finite_vector(left_q, 7, "left_q")
    if not 0.0 <= gripper <= 100.0:
        raise ValueError(f"gripper={gripper} is outside the allowed range [0, 100]")
    if times[0] < 0 or np.any(np.diff(times) <= 0):
        raise ValueError("times must start at or after 0 s and increase strictly")
    for i in range(7):
        bad = np.flatnonzero((right_q[:, i] < Q_LOWER[i] - 1e-9) | (right_q[:, i] > Q_UPPER[i] + 1e-9))
        if bad.size:
            raise ValueError(f"{RIGHT_ARM_JOINTS[i]}={right_q[bad[0], i]:.4g} rad at t="
                             f"{times[bad[0]]:.3g} s is outside [{Q_LOWER[i]:.4g}, "
                             f"{Q_UPPER[i]:.4g}] rad")
    if len(times) > 1:
        v = np.abs(np.diff(right_q, axis=0)) / np.diff(times)[:, None]
        for i in range(7):
            j = int(np.argmax(v[:, i]))
            if v[j, i] > V_MAX[i]:
                raise ValueError(f"{RIGHT_ARM_JOINTS[i]} moves at {v[j, i]:.3g} rad/s between "
                                 f"t={times[j]:.3g} and {times[j + 1]:.3g} s; its limit is "
                                 f"{V_MAX[i]:g} rad/s (slow the trajectory down)")
    rows = [",".join(CSV_HEADER)]
    for t, q in zip(times, right_q):
        values = [t, *left_q, gripper, *q, gripper]
        rows.append(",".join(f"{x:.6f}" for x in values))
    return atomic_write_text(path, "\n".join(rows) + "\n")


def read_baxter_csv(path) -> dict:
    """Reads a playback CSV back: {'time': (T,), joint name: (T,), ...}."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = np.array([[float(x) for x in row] for row in reader])
    return {name: data[:, i] for i, name in enumerate(header)}


# -- from a policy --------------------------------------------------------------------------
@dataclass
class Extraction:
    tip_positions: np.ndarray  # (N, T, 3) padded episodes
    tip_quaternions: np.ndarray  # (N, T, 4)
    gripper_positions: np.ndarray  # (N, T, 3)
    mean: TipTrajectory
    smoothed: TipTrajectory
    reachability: ReachabilityReport
    successes: int


def _pose_row(env) -> np.ndarray:
    """[p_WT (3), quaternion wxyz of the tip (4), p_WG (3)] as the robot believes them."""
    X_WT, X_WG = env.unwrapped.believed_poses()
    return np.concatenate([X_WT.translation(), X_WT.rotation().ToQuaternion().wxyz(),
                           X_WG.translation()])


ALIGNMENTS = ("start", "contact")


def delay_to_event(episodes: list[np.ndarray], events: list) -> list[np.ndarray]:
    """Delays each episode (repeating its first row) so that its event step (an index, or
    None) comes at the latest one; episodes without the event stay as they are."""
    latest = max((e for e in events if e is not None), default=None)
    if latest is None:
        return list(episodes)
    return [ep if e is None else np.vstack([np.repeat(ep[:1], latest - e, axis=0), ep])
            for ep, e in zip(episodes, events)]


def record_episodes(policy_dir, episodes: int = 100, seed: int = 0, env_kwargs=None,
                    align: str = "start"):
    """Runs the policy; returns per-episode arrays of the tool tip's and the gripper's poses at
    each control step (the robot's belief: forward kinematics of its model) and the number of
    successes. `align="start"` (the paper's) stacks the episodes from their first step;
    `"contact"` delays each so that the tool first touches the box at the same step (an
    episode that never touches it stays as it is)."""
    import gymnasium as gym

    import drake_tooluse  # noqa: F401  (registers the envs)
    from drake_tooluse.train import check_policy_matches, load_policy

    if episodes < 1:
        raise ValueError(f"episodes={episodes} must be at least 1")
    check_one_of(align, ALIGNMENTS, "align")
    policy = load_policy(policy_dir)
    kwargs = dict(policy.meta.env_kwargs)
    kwargs.update(env_kwargs or {})
    env = gym.make(policy.meta.env_id, **kwargs)
    check_policy_matches(policy, env)
    recorded, contacts, successes = [], [], 0
    for ep in range(episodes):
        obs, _ = env.reset(seed=seed + ep)
        rows, contact = [_pose_row(env)], None
        while True:
            obs, _, terminated, truncated, info = env.step(policy.act(obs))
            rows.append(_pose_row(env))
            if contact is None and info["tool_touches_box"]:
                contact = len(rows) - 1
            if terminated or truncated:
                break
        successes += bool(info["is_success"])
        recorded.append(np.array(rows, float))
        contacts.append(contact)
    if align == "contact":
        recorded = delay_to_event(recorded, contacts)
    tips = [r[:, 0:3] for r in recorded]
    quats = [r[:, 3:7] for r in recorded]
    grippers = [r[:, 7:10] for r in recorded]
    return pad_episodes(tips), pad_episodes(quats), pad_episodes(grippers), successes


def extract(policy_dir, episodes: int = 100, seed: int = 0, window: int = 5,
            tool_length: float | None = 0.175, period: float = 0.04,
            align: str = "start") -> Extraction:
    """The paper's trajectory for transfer: N episodes (aligned by `align`, see
    `record_episodes`), averaged, smoothed, and filtered to the poses reachable under the
    conservative real-robot limits with `tool_length`."""
    tips, quats, grippers, successes = record_episodes(policy_dir, episodes, seed, align=align)
    mean = average_episodes(tips, quats, period)
    smoothed = smooth(mean, window)
    report = filter_reachable(smoothed, tool_length)
    return Extraction(tips, quats, grippers, mean, smoothed, report, successes)


def plot_extraction(extraction: Extraction, path) -> Path:
    """A 3-D figure of the N recorded tool-tip paths and their mean, like the paper's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    for p in extraction.tip_positions:
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color="tab:blue", alpha=0.15, lw=0.8)
    m = extraction.smoothed.positions
    ax.plot(m[:, 0], m[:, 1], m[:, 2], color="tab:red", lw=2.5, label="mean (smoothed)")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(f"{len(extraction.tip_positions)} tool-tip paths and their mean", fontsize=10)
    ax.legend(fontsize=8)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return path
