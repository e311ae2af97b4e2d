"""The project's tool-tip IK against TRAC-IK, side by side in one run, on one core.

TRAC-IK's own protocol: joint configurations drawn uniformly within Rethink's limits, the
target the forward kinematics of `right_gripper` (no tool) or of a tool tip L m past it; a
success is an answer within 1e-5 m and 1e-4 rad of the target, checked by Drake's forward
kinematics of the robot model, within the joint limits.

- cold: every solve seeded at mid-limits;
- warm: smooth paths (joint paths whose joints move at most 0.05 rad a step; the tip moves
  ~1 cm a step) away from the arm's singularities (w1 and e1 kept at 0.2 rad or more), each
  solve seeded by that solver's last answer; a joint jump is a step where a joint moves more
  than 0.5 rad;
- singular: the same through the singularities (w1 and e1 free to cross 0), where the arm's
  two branches meet and either continuation is exact: jumps there are counted, not required
  to be zero.

TRAC-IK is pytracik 0.0.3 (the `bench` extra) on the project's own `models/baxter/baxter.urdf`
with a fixed `tool_tip` link added in memory; Speed mode, 5 ms timeout, eps 1e-5/√3 (it checks
each twist component against eps, so 1e-5 would let it claim successes up to 1.7e-5 m off);
its answers are clipped to the limits (it holds them as float32). The two solvers alternate
target by target, each timed around its Python call.

    python benchmarks/ik_vs_tracik.py [--targets 2000] [--lengths 0 0.125 0.175 0.30] [--core 1]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytracik
from pydrake.math import RigidTransform

from drake_tooluse.cli.common import run_script
from drake_tooluse.files import atomic_write_json
from drake_tooluse.paths import BAXTER_URDF
from drake_tooluse.robot.baxter_model import Q_LOWER, Q_MID, Q_UPPER
from drake_tooluse.robot.ik import ORIENTATION_TOLERANCE, POSITION_TOLERANCE, ToolTipIK
from drake_tooluse.robot.model import GRIPPER_FRAME

OUT = Path(__file__).resolve().parent.parent / "docs" / "results" / "ik_vs_tracik.json"
JUMP = 0.5  # rad
TRACIK_TIMEOUT = 0.005  # s
TRACIK_EPS = 1e-5 / math.sqrt(3)


def tracik_solver(length: float):
    """TRAC-IK on the project's URDF, to the gripper or to a tool tip `length` m past it."""
    urdf = BAXTER_URDF.read_text()
    tip = GRIPPER_FRAME
    if length > 0:
        tip = "tool_tip"
        link = (
            f'<link name="tool_tip"/><joint name="tool_tip_joint" type="fixed">'
            f'<parent link="{GRIPPER_FRAME}"/><child link="tool_tip"/>'
            f'<origin xyz="0 0 {length}" rpy="0 0 0"/></joint></robot>'
        )
        urdf = urdf.replace("</robot>", link)
    return pytracik.TRAC_IK("base", tip, urdf, TRACIK_TIMEOUT, TRACIK_EPS, pytracik.SolveType.Speed)


def solve_ours(ik: ToolTipIK, X: RigidTransform, seed):
    t0 = time.perf_counter()
    result = ik.solve(X, seed)
    return result.q, time.perf_counter() - t0


def solve_tracik(solver, X: RigidTransform, seed):
    p, quat = X.translation(), X.rotation().ToQuaternion()
    t0 = time.perf_counter()
    out = pytracik.ik(solver, seed, p[0], p[1], p[2], quat.x(), quat.y(), quat.z(), quat.w())
    elapsed = time.perf_counter() - t0
    return np.clip(out[1:], Q_LOWER, Q_UPPER), elapsed


# Away from the arm's singularities: the wrist (w1 = 0, where w0 and w2 align) and the elbow
# (e1 = 0). Through one, the two branches of the arm meet and either continuation is exact.
REGULAR = {3: (0.2, 2.4), 5: (0.2, 1.9)}  # joint index -> (low, high), rad


def smooth_joint_path(rng, steps: int, regular: bool) -> np.ndarray:
    """A path of `steps` configurations: slow sines around a random centre, inside the
    limits (and, if `regular`, inside REGULAR), no joint moving more than 0.05 rad a step."""
    low, high = Q_LOWER.copy(), Q_UPPER.copy()
    if regular:
        for i, (lo, hi) in REGULAR.items():
            low[i], high[i] = lo, hi
    mid, half = (low + high) / 2, (high - low) / 2
    centre = mid + rng.uniform(-0.3, 0.3, 7) * half
    amplitude = np.minimum(0.4 * half, high - centre, centre - low) if regular else 0.4 * half
    t = np.arange(steps)[:, None]
    frequency, phase = rng.uniform(0.5, 2.0, 7), rng.uniform(0, 2 * np.pi, 7)
    path = np.clip(centre + amplitude * np.sin(2 * np.pi * t / steps * frequency + phase),
                   Q_LOWER, Q_UPPER)  # fmt: skip
    step = np.max(np.abs(np.diff(path, axis=0)))
    if step > 0.05:  # resample more finely
        return smooth_joint_path(np.random.default_rng(rng.integers(1 << 32)),
                                 int(steps * step / 0.05) + 1, regular)  # fmt: skip
    return path


def stats(times, ok) -> dict:
    t = np.asarray(times) * 1e3
    return {"success_rate": float(np.mean(ok)), "median_ms": float(np.median(t)),
            "p95_ms": float(np.percentile(t, 95)), "mean_ms": float(np.mean(t))}  # fmt: skip


def run_case(length: float, targets: int, paths: int, path_steps: int, seed: int) -> dict:
    ik = ToolTipIK(length if length > 0 else None)
    tracik = tracik_solver(length)
    rng = np.random.default_rng(seed)

    def success(q, X):
        pos, rot = ik.errors(q, X)
        within = np.all(q >= Q_LOWER - 1e-12) and np.all(q <= Q_UPPER + 1e-12)
        return bool(pos <= POSITION_TOLERANCE and rot <= ORIENTATION_TOLERANCE and within)

    poses = [ik.fk(q) for q in rng.uniform(Q_LOWER, Q_UPPER, size=(targets, 7))]
    ik.solve(poses[0])  # the kernels compiled and loaded before the clock runs
    cold = {"ours": ([], []), "tracik": ([], [])}
    for i, X in enumerate(poses):
        order = (
            (("ours", ik), ("tracik", tracik)) if i % 2 == 0 else (("tracik", tracik), ("ours", ik))
        )
        for name, solver in order:
            solve = solve_ours if name == "ours" else solve_tracik
            q, elapsed = solve(solver, X, Q_MID.copy())
            cold[name][0].append(elapsed)
            cold[name][1].append(success(q, X))
    warm = {}
    for kind, regular in (("warm", True), ("singular", False)):
        times, ok, jumps, tip_steps = (
            {"ours": [], "tracik": []},
            {"ours": [], "tracik": []},
            {"ours": 0, "tracik": 0},
            [],
        )
        for _ in range(paths):
            path = smooth_joint_path(rng, path_steps, regular)
            path_poses = [ik.fk(q) for q in path]
            tip_steps += [np.linalg.norm(b.translation() - a.translation())
                          for a, b in zip(path_poses, path_poses[1:])]  # fmt: skip
            last = {"ours": path[0].copy(), "tracik": path[0].copy()}
            for i, X in enumerate(path_poses[1:]):
                for name in ("ours", "tracik") if i % 2 == 0 else ("tracik", "ours"):
                    solver, solve = (ik, solve_ours) if name == "ours" else (tracik, solve_tracik)
                    q, elapsed = solve(solver, X, last[name])
                    jumps[name] += int(np.max(np.abs(q - last[name])) > JUMP)
                    times[name].append(elapsed)
                    ok[name].append(success(q, X))
                    if ok[name][-1]:
                        last[name] = q
        warm[kind] = (times, ok, jumps, tip_steps)
    row = {"tool_length_m": length, "targets": targets, "paths": paths, "path_steps": path_steps,
           "path_tip_step_median_m": float(np.median(warm["warm"][3]))}  # fmt: skip
    for name in ("ours", "tracik"):
        row[f"cold_{name}"] = stats(*cold[name])
        for kind, (times, ok, jumps, _) in warm.items():
            row[f"{kind}_{name}"] = {**stats(times[name], ok[name]), "joint_jumps": jumps[name]}
    for mode in ("cold", "warm", "singular"):
        row[f"{mode}_median_ratio"] = (
            row[f"{mode}_tracik"]["median_ms"] / row[f"{mode}_ours"]["median_ms"]
        )
        row[f"{mode}_p95_ratio"] = row[f"{mode}_tracik"]["p95_ms"] / row[f"{mode}_ours"]["p95_ms"]
    return row


def table(rows) -> str:
    lines = [
        "| tool (m) | case | ours: success, median / p95 (ms) | TRAC-IK: success, median / p95 (ms) "
        "| TRAC-IK / ours: median, p95 | joint jumps ours / TRAC-IK |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        for mode in ("cold", "warm", "singular"):
            o, t = r[f"{mode}_ours"], r[f"{mode}_tracik"]
            jumps = f"{o['joint_jumps']} / {t['joint_jumps']}" if mode != "cold" else "—"
            lines.append(
                f"| {r['tool_length_m']:.3f} | {mode} | {o['success_rate'] * 100:.2f} %, "
                f"{o['median_ms']:.3f} / {o['p95_ms']:.3f} | {t['success_rate'] * 100:.2f} %, "
                f"{t['median_ms']:.3f} / {t['p95_ms']:.3f} | {r[f'{mode}_median_ratio']:.2f}x, "
                f"{r[f'{mode}_p95_ratio']:.2f}x | {jumps} |"
            )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--targets", type=int, default=2000, help="cold targets per tool")
    ap.add_argument("--paths", type=int, default=4, help="warm paths of each kind per tool")
    ap.add_argument("--path-steps", type=int, default=600, help="steps of each warm path")
    ap.add_argument("--lengths", type=float, nargs="+", default=[0.0, 0.125, 0.175, 0.30])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--core", type=int, default=1, help="the one CPU core to run on")
    ap.add_argument("--out", type=Path, default=OUT, help="results JSON (default: %(default)s)")
    args = ap.parse_args()
    # One core for both solvers (TRAC-IK runs two threads; spread over cores, times go bimodal).
    os.sched_setaffinity(0, {args.core})
    rows = []
    for length in args.lengths:
        rows.append(run_case(length, args.targets, args.paths, args.path_steps, args.seed))
        print(table(rows[-1:]).split("\n", 2)[2], flush=True)
    print()
    print(table(rows))
    atomic_write_json(args.out, {"protocol": __doc__.split("\n\n")[1], "core": args.core,
                                 "rows": rows})  # fmt: skip
    print(f"\n{args.out}")


if __name__ == "__main__":
    sys.exit(run_script(main))
