"""Hook measurement accuracy: the three-view hook measurement (`measure_hook`) of hooks of
known geometry drawn from the hook's ranges, against the goal of 2 mm (handle length, hook
length, grasp along the handle) and 2 deg (angle).

    python benchmarks/hook_vision_accuracy.py [--count 20] [--seed 0] [--noise 0] [--lighting default]
        [--out FILE | --update-docs]

Geometries: the eight corners of the ranges (handle 0.15/0.35 m x hook 0.03/0.08 m x angle
60/120 deg), then uniform seeded draws up to `--count`; each holds the hook with a grasp shift
along the handle drawn uniformly from the scenario's range, [-0.03, 0.03] m (negative: deeper
in the hand, where the fingers hide the grip band from the hook views; see
`builders.hook_measurement`). One plan serves every geometry. Prints a Markdown table (true,
measured, error per quantity), the max and mean |error| per quantity and the goals met or
missed, and writes the figures as JSON to a new runs/hook_vision_accuracy-<time>/ (or `--out
FILE`; `--update-docs`: docs/results/hook_vision_accuracy.json, which docs/BENCHMARKS.md quotes).
Errors are measured minus true, mm and deg.
"""

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

from drake_tooluse.builders.hook_measurement import measure_hook, plan_hook_measurement
from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.perception.markers import LIGHTINGS
from drake_tooluse.robot.tool import HOOK_ANGLE_RANGE, HOOK_HANDLE_RANGE, HOOK_LENGTH_RANGE
from drake_tooluse.world.scenario import (
    RandomizationConfig,
    Scenario,
    ToolConfig,
    validate_scenario,
)

OUTPUT = BenchmarkOutput(Path(__file__))
GOAL = {"handle_length": 2.0, "hook_length": 2.0, "angle": 2.0, "grasp_along": 2.0}
UNITS = {"handle_length": "mm", "hook_length": "mm", "angle": "deg", "grasp_along": "mm"}
GRASP_ALONG_RANGE = (-0.03, 0.03)  # m, as the scenario's tool.grasp_offset_along


def geometries(count: int, seed: int) -> list[tuple[float, float, float, float]]:
    """(handle length m, hook length m, angle deg, grasp along m): the ranges' corners, then
    seeded uniform draws."""
    rng = np.random.default_rng(seed)
    corners = list(itertools.product(HOOK_HANDLE_RANGE, HOOK_LENGTH_RANGE, HOOK_ANGLE_RANGE))
    out = []
    for k in range(count):
        if k < len(corners):
            L, h, a = corners[k]
        else:
            L, h, a = (
                rng.uniform(*r) for r in (HOOK_HANDLE_RANGE, HOOK_LENGTH_RANGE, HOOK_ANGLE_RANGE)
            )
        out.append((float(L), float(h), float(a), float(rng.uniform(*GRASP_ALONG_RANGE))))
    return out


def scenario_of(L, h, a, along) -> Scenario:
    tool = ToolConfig(kind="hook", length=L, hook_length=h, hook_angle=a, grasp_offset_along=along)
    # No grasp randomization: the scenario's grasp is the truth measured.
    return validate_scenario(
        Scenario(tool=tool, randomization=RandomizationConfig(grasp_along=0.0))
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--count", type=int, default=20, help="geometries (the first 8: corners)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise", type=float, default=0.0, help="colour noise sigma, grey levels")
    ap.add_argument("--lighting", default="default", choices=list(LIGHTINGS))
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    out = OUTPUT.path(args)
    if args.count < 1:
        raise ValueError(f"--count={args.count} must be at least 1")
    start = time.perf_counter()
    plan = plan_hook_measurement(Scenario())
    plan_time = time.perf_counter() - start
    rows = []
    for k, (L, h, a, along) in enumerate(geometries(args.count, args.seed)):
        result = measure_hook(
            scenario_of(L, h, a, along),
            plan=plan,
            noise_sigma=args.noise,
            seed=k,
            lighting=args.lighting,
        )
        scale = {"handle_length": 1e3, "hook_length": 1e3, "angle": 1.0, "grasp_along": 1e3}
        rows.append(
            {
                "true": {q: result.truth[q] for q in GOAL},
                "measured": {q: result.value(q) for q in GOAL},
                "error": {q: result.error(q) * scale[q] for q in GOAL},
                "spread": {q: result.spread[q] * scale[q] for q in GOAL},
                "dropped": result.dropped,
                "views": len(result.views),
                "time_s": result.wall_time,
            }
        )
    print(
        "| # | handle true / meas. (mm) | err | hook true / meas. (mm) | err | angle true / "
        "meas. (deg) | err | grasp true / meas. (mm) | err | views used |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for k, r in enumerate(rows):
        t, m, e = r["true"], r["measured"], r["error"]
        print(
            f"| {k} | {t['handle_length'] * 1e3:.1f} / {m['handle_length'] * 1e3:.2f} | "
            f"{e['handle_length']:+.2f} | {t['hook_length'] * 1e3:.1f} / "
            f"{m['hook_length'] * 1e3:.2f} | {e['hook_length']:+.2f} | {t['angle']:.1f} / "
            f"{m['angle']:.2f} | {e['angle']:+.2f} | {t['grasp_along'] * 1e3:.1f} / "
            f"{m['grasp_along'] * 1e3:.2f} | {e['grasp_along']:+.2f} | "
            f"{r['views'] - len(r['dropped'])} of {r['views']} |"
        )
    summary, goals = {}, {}
    for q in GOAL:
        errors = np.abs([r["error"][q] for r in rows])
        summary[q] = {
            f"max_abs_error_{UNITS[q]}": float(np.max(errors)),
            f"mean_abs_error_{UNITS[q]}": float(np.mean(errors)),
            f"max_spread_{UNITS[q]}": float(max(r["spread"][q] for r in rows)),
        }
        goals[f"{q}_within_{GOAL[q]:g}{UNITS[q]}"] = bool(np.all(errors <= GOAL[q]))
    times = [r["time_s"] for r in rows]
    dropped = sum(len(r["dropped"]) for r in rows)
    print()
    for q in GOAL:
        s = summary[q]
        u = UNITS[q]
        print(
            f"{q}: max |error| {s[f'max_abs_error_{u}']:.2f} {u}, mean "
            f"{s[f'mean_abs_error_{u}']:.2f} {u} (largest per-view spread "
            f"{s[f'max_spread_{u}']:.2f} {u})"
        )
    print(
        f"{len(rows)} geometries (seed {args.seed}, noise sigma {args.noise:g}, lighting "
        f"{args.lighting}); dropped views: "
        f"{dropped}; plan {plan_time:.1f} s, per measurement median {np.median(times):.2f} s, "
        f"max {max(times):.2f} s"
    )
    for name, met in goals.items():
        print(f"goal {name}: {'met' if met else 'NOT met'}")
    command = (
        f"python benchmarks/hook_vision_accuracy.py --count {args.count} "
        f"--seed {args.seed} --noise {args.noise:g} --lighting {args.lighting}"
    )
    OUTPUT.write(out, command, goals=goals, summary=summary, results=rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(run_script(main))
