"""A joint trajectory as a Baxter SDK playback CSV (`joint_trajectory_file_playback.py`).

The CSV drives both arms, so before it is written the whole trajectory is checked on the
robot's kinematics: the two arms (each link a capsule around its bone, the right one with
its tool) keep `ARM_CLEARANCE` from each other, and every link over the table keeps
`TABLE_CLEARANCE` above its top (the tool's tip: above it). The left arm stays where the
operator says (`left_q`); by default at `LEFT_ARM_SAFE`, the pose Rethink's `tuck_arms.py`
tucks it to: folded against the body, behind the table's edge.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from drake_tooluse.files import atomic_write_text
from drake_tooluse.paths import BAXTER_URL
from drake_tooluse.robot.baxter_model import (
    BONE_RADIUS,
    LEFT_ARM_JOINTS,
    Q_LOWER,
    Q_UPPER,
    RIGHT_ARM_JOINTS,
    V_MAX,
)
from drake_tooluse.robot.model import DEFAULT_TOOL_RADIUS, make_parser
from drake_tooluse.validation import check_finite_vector
from drake_tooluse.world.scenario import TableConfig

CSV_HEADER = ["time", *LEFT_ARM_JOINTS, "left_gripper", *RIGHT_ARM_JOINTS, "right_gripper"]
# baxter_tools' tuck_arms.py "tuck" pose of the left arm (s0 … w2, rad).
LEFT_ARM_SAFE = (-1.0, -2.07, 3.0, 2.55, 0.0, 0.01, 0.0)
ARM_CLEARANCE = 0.05  # m between any link of one arm and any of the other
TABLE_CLEARANCE = 0.03  # m between an arm link over the table and its top
# The frames along each arm, shoulder to fingertips; a capsule joins each to the next with
# the radius of the link it starts at.
_CHAIN = (
    "upper_shoulder",
    "lower_shoulder",
    "upper_elbow",
    "lower_elbow",
    "upper_forearm",
    "lower_forearm",
    "wrist",
    "hand",
    "gripper_base",
    "gripper",
)
_GRIPPER_RADIUS = 0.04  # m, the gripper's fingers around the tool


def check_left_arm(left_q, name: str = "left_q") -> np.ndarray:
    """The left arm's pose: 7 finite angles within Baxter's limits (default `LEFT_ARM_SAFE`)."""
    q = check_finite_vector(LEFT_ARM_SAFE if left_q is None else left_q, 7, name)
    for i, joint in enumerate(LEFT_ARM_JOINTS):
        if not Q_LOWER[i] <= q[i] <= Q_UPPER[i]:
            raise ValueError(
                f"{name}: {joint}={q[i]:g} rad is outside [{Q_LOWER[i]:.4g}, {Q_UPPER[i]:.4g}] rad"
            )
    return q


def _gap(gap: float, what: str) -> str:
    """'comes within 2.0 cm of the table' or 'reaches 1.0 cm into the table'."""
    if gap < 0:
        return f"reaches {-gap * 100:.1f} cm into {what}"
    return f"comes within {gap * 100:.1f} cm of {what}"


def _segment_distances(p0, p1, q0, q1) -> np.ndarray:
    """Distances between segments p0-p1 and q0-q1 (arrays (..., 3)), the closest points
    clamped to both (Ericson, Real-Time Collision Detection, 5.1.9)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-12, np.clip((b * f - c * e) / denom, 0, 1), 0.0)
        t = np.where(e > 1e-12, (b * s + f) / e, 0.0)
        s = np.where(t < 0, np.where(a > 1e-12, np.clip(-c / a, 0, 1), 0.0), s)
        s = np.where(t > 1, np.where(a > 1e-12, np.clip((b - c) / a, 0, 1), 0.0), s)
    t = np.clip(t, 0, 1)
    closest = (p0 + d1 * s[..., None]) - (q0 + d2 * t[..., None])
    return np.linalg.norm(closest, axis=-1)


def _arm_points(plant, context, side: str) -> np.ndarray:
    return np.array(
        [plant.GetFrameByName(f"{side}_{n}").CalcPoseInWorld(context).translation() for n in _CHAIN]
    )


def check_clearance(
    right_q,
    left_q,
    tool_length: float | None,
    table: TableConfig | None = None,
    times=None,
    arm_clearance: float = ARM_CLEARANCE,
    table_clearance: float = TABLE_CLEARANCE,
) -> dict:
    """Checks every row of a right-arm trajectory (T, 7), with the left arm at `left_q` and a
    tool of `tool_length` m (None: none) in the right hand, against the other arm and the
    table (see the module docstring). Raises ValueError naming the time, the links and the
    clearance; returns the smallest clearances (m)."""
    right_q = np.atleast_2d(np.asarray(right_q, float))
    left_q = check_left_arm(left_q)
    table = table or TableConfig()
    times = np.arange(len(right_q), dtype=float) if times is None else np.asarray(times, float)
    plant = MultibodyPlant(0.0)
    (baxter,) = make_parser(plant).AddModels(url=BAXTER_URL)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base", baxter))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    for joint, angle in zip(LEFT_ARM_JOINTS, left_q):
        plant.GetJointByName(joint).set_angle(context, angle)
    left = _arm_points(plant, context, "left")
    radii = np.array([BONE_RADIUS.get(n, _GRIPPER_RADIUS) for n in _CHAIN[:-1]])
    right_radii = np.append(radii, DEFAULT_TOOL_RADIUS) if tool_length else radii
    right_names = [*(f"right_{n}" for n in _CHAIN[:-1]), *(["tool"] if tool_length else [])]
    left_names = [f"left_{n}" for n in _CHAIN[:-1]]
    (x0, y0), (sx, sy) = table.center_xy, table.size_xy

    def table_gaps(points, r):
        """Height of each capsule's lowest point above the table top, where it is over it."""
        low = np.minimum(points[:-1, 2], points[1:, 2]) - r
        xy = np.where((points[:-1, 2] < points[1:, 2])[:, None], points[:-1, :2], points[1:, :2])
        over = (np.abs(xy[:, 0] - x0) <= sx / 2 + r) & (np.abs(xy[:, 1] - y0) <= sy / 2 + r)
        return np.where(over, low - table.top_z, np.inf)

    left_table = table_gaps(left, radii)
    if np.min(left_table) < table_clearance:
        i = int(np.argmin(left_table))
        raise ValueError(
            f"the left arm at {np.round(left_q, 3).tolist()} rad "
            f"{_gap(left_table[i], 'the table')} ({left_names[i]}); it must keep "
            f"{table_clearance * 100:g} cm: give another left_q (--left-arm-q)"
        )
    worst = {"arms_m": np.inf, "table_m": np.inf, "tool_tip_above_table_m": np.inf}
    for k, q in enumerate(right_q):
        for joint, angle in zip(RIGHT_ARM_JOINTS, q):
            plant.GetJointByName(joint).set_angle(context, angle)
        right = _arm_points(plant, context, "right")
        if tool_length:
            X_WG = plant.GetFrameByName("right_gripper").CalcPoseInWorld(context)
            right = np.vstack([right, X_WG @ np.array([0.0, 0.0, tool_length])])
        gaps = _segment_distances(
            left[:-1, None], left[1:, None], right[None, :-1], right[None, 1:]
        ) - (radii[:, None] + right_radii[None, :])
        i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
        if gaps[i, j] < arm_clearance:
            other = f"the left arm's {left_names[i]}"
            raise ValueError(
                f"at t={times[k]:.3g} s the right arm's {right_names[j]} "
                f"{_gap(gaps[i, j], other)} (it must keep "
                f"{arm_clearance * 100:g} cm); give another left_q (--left-arm-q); nothing written"
            )
        over = table_gaps(right, right_radii)
        links, tool = (over[:-1], over[-1]) if tool_length else (over, np.inf)
        if np.min(links) < table_clearance:
            n = int(np.argmin(links))
            raise ValueError(
                f"at t={times[k]:.3g} s the right arm's {right_names[n]} "
                f"{_gap(links[n], 'the table')} (it must keep {table_clearance * 100:g} "
                "cm); nothing written"
            )
        if tool < 0:
            raise ValueError(
                f"at t={times[k]:.3g} s the tool reaches {-tool * 1000:.1f} mm into the table; "
                "nothing written"
            )
        worst["arms_m"] = min(worst["arms_m"], float(gaps[i, j]))
        worst["table_m"] = min(worst["table_m"], float(np.min(links)), float(np.min(left_table)))
        worst["tool_tip_above_table_m"] = min(worst["tool_tip_above_table_m"], float(tool))
    return {k: (v if np.isfinite(v) else None) for k, v in worst.items()}


def velocity_excess(times, right_q) -> tuple[float, str]:
    """How many times slower the joint trajectory (`right_q` at `times`) must run for every
    right-arm joint to stay within its velocity limit (V_MAX; ≤ 1 when it already does), and
    which joint moves fastest against its limit, where, in words."""
    times, right_q = np.asarray(times, float), np.asarray(right_q, float)
    if len(times) < 2:
        return 0.0, "the trajectory does not move"
    ratio = np.abs(np.diff(right_q, axis=0)) / np.diff(times)[:, None] / np.asarray(V_MAX)
    j, i = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    speed = ratio[j, i] * V_MAX[i]
    return float(ratio[j, i]), (
        f"{RIGHT_ARM_JOINTS[i]} moves at {speed:.3g} rad/s between t={times[j]:.3g} and "
        f"{times[j + 1]:.3g} s; its limit is {V_MAX[i]:g} rad/s"
    )


def export_baxter_csv(path, times, right_q, left_q=LEFT_ARM_SAFE, gripper: float = 0.0) -> Path:
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
    left_q = check_left_arm(left_q, "left_q")
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
    slowdown, fastest = velocity_excess(times, right_q)
    if slowdown > 1.0:
        raise ValueError(f"{fastest}: run it at least {slowdown:.3g}× slower")
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
