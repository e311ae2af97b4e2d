"""Kinematic tool-tip IK benchmark: random reachable tool-tip poses (FK of random joint
configurations within the limits), solved from the nominal mid-limit pose.

    python benchmarks/ik_kinematic.py [--poses 10000] [--lengths 0 0.125 0.175 0.30]
        [--out FILE | --update-docs]

Prints a Markdown table (length 0 = no tool: the tip frame is the gripper frame) and writes the
figures as JSON to a new runs/ik_kinematic-<time>/ik_kinematic.json (or --out;
`--update-docs`: docs/results/ik_kinematic.json, which docs/BENCHMARKS.md quotes).
"""

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.files import atomic_write_json
from drake_tooluse.robot.baxter_model import Q_LOWER, Q_MID, Q_UPPER
from drake_tooluse.robot.ik import ToolTipIK

OUTPUT = BenchmarkOutput(Path(__file__))


def bench(length: float, poses: int, seed: int) -> dict:
    t0 = time.perf_counter()
    ik = ToolTipIK(None if length == 0 else length)
    setup = time.perf_counter() - t0
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(poses):
        X = ik.fk(rng.uniform(Q_LOWER, Q_UPPER))
        r = ik.solve(X, q_seed=Q_MID)
        violation = bool(np.any(r.q < Q_LOWER) or np.any(r.q > Q_UPPER))
        rows.append(
            (r.success, r.position_error, r.orientation_error, r.solve_time, r.attempts, violation)
        )
    ok = np.array([r[0] for r in rows])
    pos = np.array([r[1] for r in rows])[ok]
    rot = np.array([r[2] for r in rows])[ok]
    t = np.array([r[3] for r in rows])
    attempts = np.array([r[4] for r in rows])
    return {
        "tool_length_m": length,
        "poses": poses,
        "success_rate": float(ok.mean()),
        "tip_error_median_mm": float(np.median(pos) * 1e3),
        "tip_error_max_mm": float(pos.max() * 1e3),
        "orientation_error_median_rad": float(np.median(rot)),
        "orientation_error_max_rad": float(rot.max()),
        "solve_time_median_ms": float(np.median(t) * 1e3),
        "solve_time_p95_ms": float(np.percentile(t, 95) * 1e3),
        "solve_time_max_ms": float(t.max() * 1e3),
        "first_attempt_rate": float(np.mean(attempts == 1)),
        "mean_attempts": float(attempts.mean()),
        "joint_limit_violations": int(sum(r[5] for r in rows)),
        "setup_time_s": setup,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--poses", type=int, default=10000)
    ap.add_argument("--lengths", type=float, nargs="+", default=[0.0, 0.125, 0.175, 0.30])
    ap.add_argument("--seed", type=int, default=0)
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    out = OUTPUT.path(args)
    results = [bench(L, args.poses, args.seed) for L in args.lengths]
    print(
        "| tool (m) | poses | success | tip err median / max (mm) | orient. err median / max "
        "(rad) | solve median / p95 / max (ms) | 1st try | violations |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in results:
        print(
            f"| {r['tool_length_m']:.3f} | {r['poses']} | {r['success_rate'] * 100:.2f} % | "
            f"{r['tip_error_median_mm']:.2e} / {r['tip_error_max_mm']:.2e} | "
            f"{r['orientation_error_median_rad']:.1e} / {r['orientation_error_max_rad']:.1e} | "
            f"{r['solve_time_median_ms']:.2f} / {r['solve_time_p95_ms']:.2f} / "
            f"{r['solve_time_max_ms']:.1f} | {r['first_attempt_rate'] * 100:.1f} % | "
            f"{r['joint_limit_violations']} |"
        )
    atomic_write_json(
        out,
        {
            "command": f"python benchmarks/ik_kinematic.py --poses {args.poses} --seed {args.seed}",
            "machine": platform.platform(),
            "results": results,
        },
    )
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(run_script(main))
