"""The trajectory source: tool-tip poses over time as a Drake `TrajectorySource`.

A `TipTrajectory` is tool-tip poses in W at times (s); its file is an `.npz` with `times`
(T,), `positions` (T, 3) and `quaternions` (T, 4, w x y z), and may hold `arm_start` (7,):
the right-arm posture (s0 … w2, rad) a replay starts the arm near, where the IK follows the
trajectory only from there (a planned motion's start configuration; `experiments.line_contact`
chooses it). `waypoint_trajectory` makes one
from waypoints (move, then dwell), `tip_trajectory_source` turns one into the 7-vector
[p_WT, quaternion wxyz] a `ToolTipIKSystem` takes.
"""

from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_tooluse.files import atomic_write_bytes
from drake_tooluse.robot.ik import pose_to_vector
from drake_tooluse.validation import check_in_range


@dataclass
class TipTrajectory:
    """Tool-tip poses in W at times (s)."""

    times: np.ndarray  # (T,)
    positions: np.ndarray  # (T, 3)
    quaternions: np.ndarray  # (T, 4), w x y z, unit
    # The arm posture (s0 … w2, rad) that seeds the replay's home IK; None: the scenario's.
    arm_start: np.ndarray | None = None

    def __post_init__(self):
        self.times = np.asarray(self.times, float)
        self.positions = np.asarray(self.positions, float)
        self.quaternions = np.array(self.quaternions, float)  # a copy: normalised in place below
        T = self.times.shape[0]
        if self.times.ndim != 1 or T < 1:
            raise ValueError(f"times must be a non-empty vector; got shape {self.times.shape}")
        if self.positions.shape != (T, 3) or self.quaternions.shape != (T, 4):
            raise ValueError(
                f"positions {self.positions.shape} and quaternions "
                f"{self.quaternions.shape} must be ({T}, 3) and ({T}, 4)"
            )
        arrays = [
            ("times", self.times),
            ("positions", self.positions),
            ("quaternions", self.quaternions),
        ]
        if self.arm_start is not None:
            self.arm_start = np.array(self.arm_start, float)
            if self.arm_start.shape != (7,):
                raise ValueError(
                    f"arm_start must be 7 joint angles (rad); got shape {self.arm_start.shape}"
                )
            arrays.append(("arm_start", self.arm_start))
        for name, a in arrays:
            if not np.all(np.isfinite(a)):
                raise ValueError(f"trajectory {name} hold NaN or infinite values")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("trajectory times must increase strictly")
        norms = np.linalg.norm(self.quaternions, axis=1)
        if np.any(norms < 1e-6):
            raise ValueError("trajectory quaternions must be non-zero")
        # Only rows that are not unit already: a saved trajectory loads bit for bit as it was
        # (dividing again by a norm 1 ± 1e-16 moves the last bits, and a contact-rich replay
        # amplifies them to a different push).
        off = np.abs(norms - 1.0) > 1e-12
        self.quaternions[off] /= norms[off, None]

    def __len__(self) -> int:
        return len(self.times)

    def save(self, path) -> Path:
        buffer = io.BytesIO()
        arrays = dict(times=self.times, positions=self.positions, quaternions=self.quaternions)
        if self.arm_start is not None:
            arrays["arm_start"] = self.arm_start
        np.savez(buffer, **arrays)
        return atomic_write_bytes(path, buffer.getvalue())

    @staticmethod
    def load(path) -> TipTrajectory:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"trajectory file not found: {str(path)!r}")
        try:
            with np.load(path) as data:
                arm_start = data["arm_start"] if "arm_start" in data.files else None
                return TipTrajectory(
                    data["times"], data["positions"], data["quaternions"], arm_start
                )
        except (KeyError, ValueError, OSError, EOFError, zipfile.BadZipFile) as e:
            raise ValueError(
                f"malformed trajectory file {str(path)!r}: {e} (it needs times "
                "(T,), positions (T, 3), quaternions (T, 4), optionally arm_start (7,))"
            ) from None


def waypoint_trajectory(
    start: RigidTransform, waypoints, move_time: float, dwell: float
) -> TipTrajectory:
    """From `start`, move to each waypoint (a RigidTransform X_WT*) in `move_time` s and hold
    it `dwell` s (linear in position and quaternion components between the samples)."""
    if not waypoints:
        raise ValueError("waypoints is empty; give at least one tool-tip pose")
    move_time = check_in_range(move_time, 0.05, 60.0, "move_time", unit="s")
    dwell = check_in_range(dwell, 0.0, 60.0, "dwell", unit="s")
    times, poses = [0.0], [pose_to_vector(start)]
    t = 0.0
    for X in waypoints:
        t += move_time
        times.append(t)
        poses.append(pose_to_vector(X))
        if dwell > 0:
            t += dwell
            times.append(t)
            poses.append(poses[-1])
    poses = np.array(poses)
    return TipTrajectory(np.array(times), poses[:, :3], poses[:, 3:])


def tip_trajectory_source(traj: TipTrajectory, lead: float = 0.0):
    """A Drake TrajectorySource of the 7-vector [p_WT (3), quaternion wxyz (4)], linear between
    the samples (the IK normalizes the quaternion), held before the first and after the last;
    at time t it gives the trajectory at `t + lead` (a recorded trajectory holds where the tip
    *was*: lead by a control period to command where it goes next)."""
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
