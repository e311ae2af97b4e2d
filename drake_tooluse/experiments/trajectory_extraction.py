"""Tool-tip trajectories as the paper made them: from a policy's episodes to one trajectory.

Record N episodes of a policy (tool-tip and gripper poses at each control step), average them
(positions by the mean, orientations by the quaternion average of Markley et al. 2007: the
principal eigenvector of Σ q qᵀ, blind to the sign of q), smooth, and keep the poses the robot
can reach under the conservative real-robot joint limits. The trajectory itself and its file
format are `systems.tip_trajectory.TipTrajectory`; its export for a real Baxter is
`experiments.baxter_csv`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform

from drake_tooluse.experiments.choices import ALIGNMENTS, RECORDS
from drake_tooluse.files import atomic_dir, atomic_write_figure
from drake_tooluse.learning.evaluate import make_policy_env, run_episode
from drake_tooluse.limits import MAX_EPISODES
from drake_tooluse.progress import progress_bar
from drake_tooluse.robot.ik import ToolTipIK, joint_limit_kwargs
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.validation import check_int, check_one_of, check_seed
from drake_tooluse.world.scenario import RobotConfig
from drake_tooluse.world.scene import initial_box_pose


def average_quaternions(quaternions: np.ndarray, weights=None) -> np.ndarray:
    """The average rotation of unit quaternions (N, 4): the eigenvector of the largest
    eigenvalue of Σ w q qᵀ (Markley et al., 2007); q and −q count as the same rotation."""
    q = np.asarray(quaternions, float)
    w = np.ones(len(q)) if weights is None else np.asarray(weights, float)
    M = np.einsum("n,ni,nj->ij", w, q, q)
    values, vectors = np.linalg.eigh(M)
    mean = vectors[:, np.argmax(values)]
    return mean if mean[0] >= 0 else -mean


def average_episodes(
    positions: np.ndarray, quaternions: np.ndarray, period: float
) -> TipTrajectory:
    """The per-step average of N episodes: positions (N, T, 3), quaternions (N, T, 4)."""
    positions = np.asarray(positions, float)
    quaternions = np.asarray(quaternions, float)
    T = positions.shape[1]
    mean_q = np.array([average_quaternions(quaternions[:, t]) for t in range(T)])
    return TipTrajectory(np.arange(T) * period, positions.mean(axis=0), mean_q)


def shifted(traj: TipTrajectory, dxy) -> TipTrajectory:
    """The trajectory moved by `dxy` (m) across the table: to where a box starts `dxy` from
    the start the trajectory was made for."""
    offset = np.array([dxy[0], dxy[1], 0.0])
    return TipTrajectory(traj.times, traj.positions + offset, traj.quaternions, traj.arm_start)


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


def filter_reachable(
    traj: TipTrajectory, tool_length: float | None, conservative: bool = True, q_start=None
) -> ReachabilityReport:
    """Solves the tool-tip IK along the trajectory, each pose warm-started from the last
    (the first from `q_start`, default the scenario's home posture), under the conservative
    real-robot limits (s1 in [-1.35, 1.0]) or Baxter's own; drops the poses it cannot reach."""
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
        raise ValueError(
            "no pose of the trajectory is reachable with tool length "
            f"{tool_length} m under the {'conservative' if conservative else ''} "
            "joint limits"
        )
    kept = TipTrajectory(traj.times[keep], traj.positions[keep], traj.quaternions[keep])
    return ReachabilityReport(len(traj), len(keep), kept, np.array(qs), dropped)


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
    """[p_WT (3), quaternion wxyz of the tip (4), p_WG (3)] as the robot believes them, then
    the commanded tip pose [p_WT* (3), quaternion wxyz (4)]."""
    X_WT, X_WG = env.unwrapped.believed_poses()
    X_WTd = env.unwrapped.commanded_tip_pose()
    return np.concatenate(
        [
            X_WT.translation(),
            X_WT.rotation().ToQuaternion().wxyz(),
            X_WG.translation(),
            X_WTd.translation(),
            X_WTd.rotation().ToQuaternion().wxyz(),
        ]
    )


@dataclass
class _PoseRecorder:
    """Collects `_pose_row` after the reset and each step of an episode, the row at which
    the tool first touched the box (None: never) and where the box started (p_WB, m)."""

    env: object
    rows: list = field(default_factory=list)
    contact: int | None = None
    p_WB: np.ndarray | None = None

    def __call__(self, step: int, info: dict) -> None:
        if step == 0:
            u = self.env.unwrapped
            plant_context = u.world.plant.GetMyContextFromRoot(u.simulator.get_context())
            self.p_WB = u.world.box.EvalPoseInWorld(plant_context).translation().copy()
        self.rows.append(_pose_row(self.env))
        if step > 0 and self.contact is None and info["tool_touches_object"]:
            self.contact = len(self.rows) - 1


def delay_to_event(episodes: list[np.ndarray], events: list) -> list[np.ndarray]:
    """Delays each episode (repeating its first row) so that its event step (an index, or
    None) comes at the latest one; episodes without the event stay as they are."""
    latest = max((e for e in events if e is not None), default=None)
    if latest is None:
        return list(episodes)
    return [
        ep if e is None else np.vstack([np.repeat(ep[:1], latest - e, axis=0), ep])
        for ep, e in zip(episodes, events)
    ]


def record_episodes(
    policy_dir,
    episodes: int = 100,
    seed: int = 0,
    env_kwargs=None,
    align: str = "start",
    trust_pickle: bool = False,
    record: str = "achieved",
    box_frame: bool = False,
    progress: bool = True,
):
    """Runs the policy (a progress bar on stderr where it is a terminal and `progress`);
    returns per-episode arrays of the tool tip's poses (`record`: the
    commanded ones, or where the tip got, see RECORDS) and the gripper's positions at each
    control step (the robot's belief: forward kinematics of its model), the number of
    successes and the control period (s) between the rows. Row k + 1 is what step k commanded
    (or reached); row 0 is the start. `align="start"` (the paper's) stacks the episodes from
    their first step; `"contact"` delays each so that the tool first touches the box at the
    same step (an episode that never touches it stays as it is). With `box_frame` each
    episode is moved across the table by where its box started from the scenario's nominal
    box start (the paper's average mixes pushes of boxes up to ±2 cm apart): the average is of
    pushes of the nominal box, and a replay moves it to its own box (`shifted`)."""
    check_int(episodes, 1, MAX_EPISODES, "episodes")
    check_seed(seed, "seed", episodes)
    check_one_of(align, ALIGNMENTS, "align")
    check_one_of(record, RECORDS, "record")
    policy, env = make_policy_env(policy_dir, env_kwargs=env_kwargs, trust_pickle=trust_pickle)
    p_WB_nominal = initial_box_pose(env.unwrapped.scenario).translation()
    recorded, contacts, successes = [], [], 0
    bar = progress_bar(episodes, "episodes", "ep", progress)
    for ep in range(episodes):
        bar.update(1)
        recorder = _PoseRecorder(env)
        info, _ = run_episode(env, policy, seed + ep, on_step=recorder)
        successes += bool(info["is_success"])
        rows = np.array(recorder.rows, float)
        if box_frame:  # the tip and the gripper positions, where the nominal box is pushed
            dxy = (recorder.p_WB - p_WB_nominal)[:2]
            for columns in (slice(0, 2), slice(7, 9), slice(10, 12)):
                rows[:, columns] -= dxy
        recorded.append(rows)
        contacts.append(recorder.contact)
    bar.close()
    period = env.unwrapped.scenario.control.control_period
    env.close()
    if align == "contact":
        recorded = delay_to_event(recorded, contacts)
    tip = slice(0, 7) if record == "achieved" else slice(10, 17)
    tips = [r[:, tip][:, :3] for r in recorded]
    quats = [r[:, tip][:, 3:] for r in recorded]
    grippers = [r[:, 7:10] for r in recorded]
    return (pad_episodes(tips), pad_episodes(quats), pad_episodes(grippers), successes, period)


def extract(
    policy_dir,
    episodes: int = 100,
    seed: int = 0,
    window: int = 5,
    tool_length: float | None = 0.175,
    align: str = "start",
    env_kwargs: dict | None = None,
    trust_pickle: bool = False,
    record: str = "achieved",
    box_frame: bool = False,
) -> Extraction:
    """The paper's trajectory for transfer: N episodes (aligned by `align`, the commanded or
    the reached tip poses by `record`, see `record_episodes`), averaged, smoothed, and
    filtered to the poses reachable under the conservative real-robot limits with
    `tool_length`. The trajectory's time step is the
    control period of the env the policy acts in (its scenario's `control.control_period`);
    `env_kwargs` override the policy's own; `box_frame`: see `record_episodes`. `policy_dir`:
    a policy directory, or a policy loaded from one."""
    tips, quats, grippers, successes, period = record_episodes(
        policy_dir, episodes, seed, env_kwargs, align, trust_pickle, record, box_frame
    )
    mean = average_episodes(tips, quats, period)
    smoothed = smooth(mean, window)
    report = filter_reachable(smoothed, tool_length)
    return Extraction(tips, quats, grippers, mean, smoothed, report, successes)


def save_extraction(extraction: Extraction, out, trajectory=None) -> tuple[Path, Path]:
    """The kept trajectory (or `trajectory`, one made of it) as `trajectory.npz` and the
    extraction's figure (`trajectory.png`) written to the new directory `out` (absent or empty:
    a result directory is never overwritten), which appears complete or not at all. Returns the
    two paths."""
    out = Path(out)
    with atomic_dir(out) as work:
        (extraction.reachability.kept if trajectory is None else trajectory).save(
            work / "trajectory.npz"
        )
        plot_extraction(extraction, work / "trajectory.png")
    return out / "trajectory.npz", out / "trajectory.png"


def plot_extraction(extraction: Extraction, path) -> Path:
    """A 3-D figure of the N recorded tool-tip paths and their mean, like the paper's."""
    fig = Figure(figsize=(6, 5))
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
    return atomic_write_figure(path, fig)
