"""A joint trajectory as a Baxter SDK playback CSV (`joint_trajectory_file_playback.py`)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from drake_tooluse.files import atomic_write_text
from drake_tooluse.robot.baxter_model import (
    LEFT_ARM_JOINTS,
    Q_LOWER,
    Q_UPPER,
    RIGHT_ARM_JOINTS,
    V_MAX,
)
from drake_tooluse.validation import check_finite_vector

CSV_HEADER = ["time", *LEFT_ARM_JOINTS, "left_gripper", *RIGHT_ARM_JOINTS, "right_gripper"]


def export_baxter_csv(path, times, right_q, left_q, gripper: float = 0.0) -> Path:
    """Writes a joint trajectory in the Baxter SDK playback format
    (`joint_trajectory_file_playback.py`): time in s from the start, both arms, both grippers
    (0–100, 0 = closed on the tool). Position and velocity limits are checked first; nothing is
    written if they fail."""
    times = check_finite_vector(times, len(np.atleast_1d(times)), "times")
    right_q = np.asarray(right_q, float)
    if right_q.shape != (len(times), 7) or not np.all(np.isfinite(right_q)):
        raise ValueError(
            f"right_q must be finite with shape ({len(times)}, 7); got {right_q.shape}"
        )
    left_q = check_finite_vector(left_q, 7, "left_q")
    if not 0.0 <= gripper <= 100.0:
        raise ValueError(f"gripper={gripper} is outside the allowed range [0, 100]")
    if times[0] < 0 or np.any(np.diff(times) <= 0):
        raise ValueError("times must start at or after 0 s and increase strictly")
    for i in range(7):
        bad = np.flatnonzero(
            (right_q[:, i] < Q_LOWER[i] - 1e-9) | (right_q[:, i] > Q_UPPER[i] + 1e-9)
        )
        if bad.size:
            raise ValueError(
                f"{RIGHT_ARM_JOINTS[i]}={right_q[bad[0], i]:.4g} rad at t="
                f"{times[bad[0]]:.3g} s is outside [{Q_LOWER[i]:.4g}, "
                f"{Q_UPPER[i]:.4g}] rad"
            )
    if len(times) > 1:
        v = np.abs(np.diff(right_q, axis=0)) / np.diff(times)[:, None]
        for i in range(7):
            j = int(np.argmax(v[:, i]))
            if v[j, i] > V_MAX[i]:
                raise ValueError(
                    f"{RIGHT_ARM_JOINTS[i]} moves at {v[j, i]:.3g} rad/s between "
                    f"t={times[j]:.3g} and {times[j + 1]:.3g} s; its limit is "
                    f"{V_MAX[i]:g} rad/s (slow the trajectory down)"
                )
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
