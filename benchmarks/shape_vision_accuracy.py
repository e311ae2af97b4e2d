"""Measuring tools the robot was not told about: the shape measurement (`measure_shape`) of
the generator's held-out tools, against the goal of working frames within 2 mm and the family
named right in ≥ 95 %, with and without camera noise; and, on straight rods and hooks, side by
side with the marker-band measurements made for them.

    python benchmarks/shape_vision_accuracy.py [--tools 100] [--tool-seed 0] [--seed 0]
        [--noise 8] [--depth-noise 0.001] [--lighting dim_side] [--reference 10]
        [--out FILE | --update-docs]

The tools are `robot.tool_generator.held_out_tools(--tools, --tool-seed)` (the rake family,
never trained on, and the corner of every other family's shape parameters), each held with a
grasp shift drawn uniformly from the scenario's ranges (across ±0.01 m, along ±0.03 m).
Each is measured twice: clean (no noise, default light) and with camera noise (`--noise` grey
levels of colour noise, `--depth-noise` m of depth noise, `--lighting`). A tool's error is the
largest position error of its working frames in the gripper frame (every frame the truth and
the fit both name; the grasp point itself is not one: module `perception.tool_shape`).
Orientation errors are zero by construction (every frame keeps the handle's orientation, held
along G's z), so the 2° goal is not measured.

The reference: `--reference` straight rods (of the straight family's lengths: a longer rod
is beyond the fit's ranges) and as many hooks (marker bands on; held at the nominal grasp
across, which the marker measurements assume, and shifted along), measured with
noise by their marker measurements (`measure_tool`, `measure_hook`) and by the shape
measurement, each frame's error side by side.

Prints Markdown tables and the goals met or missed; writes the figures as JSON to a new
runs/shape_vision_accuracy-<time>/ (or `--out FILE`; `--update-docs`:
docs/results/shape_vision_accuracy.json, which docs/BENCHMARKS.md quotes).
"""

import argparse
import dataclasses as dc
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from drake_tooluse.builders.hook_measurement import measure_hook, measured_hook
from drake_tooluse.builders.measurement import measure_tool
from drake_tooluse.builders.shape_measurement import (
    measure_shape,
    plan_shape_measurement,
    true_frames_G,
)
from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.limits import MAX_EPISODES
from drake_tooluse.perception.markers import LIGHTINGS, check_noise_sigma
from drake_tooluse.robot.tool import (
    HOOK_ANGLE_RANGE,
    HOOK_HANDLE_RANGE,
    HOOK_LENGTH_RANGE,
    HookTool,
    StraightTool,
)
from drake_tooluse.robot.tool_generator import FAMILIES, held_out_tools
from drake_tooluse.systems.camera import check_depth_noise
from drake_tooluse.validation import check_int, check_one_of, check_seed
from drake_tooluse.world.scenario import Scenario, with_tool

OUTPUT = BenchmarkOutput(Path(__file__))
FRAME_GOAL_MM = 2.0
FAMILY_GOAL = 0.95
GRASP_ACROSS = (-0.01, 0.01)  # m, as the scenario's tool.grasp_offset_across
GRASP_ALONG = (-0.03, 0.03)  # m, as its tool.grasp_offset_along


def held(tool, across: float, along: float) -> Scenario:
    """The default scenario holding `tool` (a GeneratedTool, HookTool or length) shifted in
    the hand by (across, along) m."""
    scenario = with_tool(Scenario(), tool)
    return dc.replace(
        scenario,
        tool=dc.replace(scenario.tool, grasp_offset_across=across, grasp_offset_along=along),
    )


def shape_row(result) -> dict:
    return {
        "truth_family": result.truth_family,
        "family": result.family,
        "family_right": result.family_right,
        "max_frame_error_mm": result.max_frame_error * 1e3,
        "frame_errors_mm": {n: e * 1e3 for n, e in result.frame_errors.items()},
        "rms_mm": result.shape.best.rms * 1e3,
        "points": result.shape.points,
        "dropped": result.dropped,
        "capture_time_s": result.capture_time,
        "fit_time_s": result.fit_time,
    }


def condition_summary(rows: list[dict]) -> dict:
    errors = np.array([r["max_frame_error_mm"] for r in rows])
    by_family = defaultdict(list)
    for r in rows:
        by_family[r["truth_family"]].append(r)
    return {
        "tools": len(rows),
        "family_right_rate": float(np.mean([r["family_right"] for r in rows])),
        "within_goal_rate": float(np.mean(errors <= FRAME_GOAL_MM)),
        "max_frame_error_mm": {
            "median": float(np.median(errors)),
            "p95": float(np.percentile(errors, 95)),
            "max": float(np.max(errors)),
        },
        "families": {
            f: {
                "tools": len(rs),
                "family_right": sum(r["family_right"] for r in rs),
                "max_frame_error_mm": float(max(r["max_frame_error_mm"] for r in rs)),
                "named_as": sorted({r["family"] for r in rs if not r["family_right"]}),
            }
            for f, rs in by_family.items()
        },
        "fit_time_s_median": float(np.median([r["fit_time_s"] for r in rows])),
        "capture_time_s_median": float(np.median([r["capture_time_s"] for r in rows])),
    }


def marker_frames_G(scenario: Scenario, options: dict) -> dict:
    """A rod's or a hook's frames in G as its marker measurement gives them (m)."""
    if scenario.tool.kind == "hook":
        result = measure_hook(scenario, **options)
        tool, along = measured_hook(result), result.grasp_along
    else:
        result = measure_tool(scenario, **options)
        tool, along = StraightTool(result.length), result.grasp_along
    return {n: np.array(X.translation) + [0.0, 0.0, along] for n, X in tool.frames().items()}


def reference_rows(count: int, rng, plan, options: dict) -> list[dict]:
    """Rods and hooks measured both ways: each frame's error (mm) by markers and by shape."""
    tools = [float(rng.uniform(*FAMILIES["straight"].ranges["length"])) for _ in range(count)]
    tools += [
        HookTool(
            *(
                float(rng.uniform(*r))
                for r in (HOOK_HANDLE_RANGE, HOOK_LENGTH_RANGE, HOOK_ANGLE_RANGE)
            )
        )
        for _ in range(count)
    ]
    rows = []
    for k, tool in enumerate(tools):
        scenario = held(tool, 0.0, float(rng.uniform(*GRASP_ALONG)))
        truth = true_frames_G(scenario)
        markers = marker_frames_G(scenario, {**options, "seed": k})
        shape = measure_shape(scenario, plan=plan, seed=k, **options)
        fitted = shape.shape.best.frames_G()
        rows.append(
            {
                "tool": scenario.tool.kind,
                "shape_family": shape.family,
                "frames": {
                    n: {
                        "markers_mm": float(np.linalg.norm(markers[n] - p) * 1e3),
                        "shape_mm": float(np.linalg.norm(fitted[n] - p) * 1e3)
                        if n in fitted
                        else None,
                    }
                    for n, p in truth.items()
                    if n in markers
                },
            }
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--tools", type=int, default=100, help="held-out tools")
    ap.add_argument("--tool-seed", type=int, default=0, help="seed of the held-out tools' draw")
    ap.add_argument("--seed", type=int, default=0, help="seed of the grasps, noises and fits")
    ap.add_argument("--noise", type=float, default=8.0, help="colour noise sigma, grey levels")
    ap.add_argument("--depth-noise", type=float, default=0.001, help="depth noise sigma, m")
    ap.add_argument("--lighting", default="dim_side", help=f"one of {', '.join(LIGHTINGS)}")
    ap.add_argument("--reference", type=int, default=10, help="rods and hooks each (0: none)")
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    try:
        check_int(args.tools, 1, MAX_EPISODES, "--tools")
        check_int(args.reference, 0, 1_000, "--reference")
        check_seed(args.tool_seed, "--tool-seed")
        check_seed(args.seed, "--seed")
        check_noise_sigma(args.noise, "--noise")
        check_depth_noise(args.depth_noise, "--depth-noise")
        check_one_of(args.lighting, LIGHTINGS, "--lighting")
    except ValueError as e:
        ap.error(str(e))
    out = OUTPUT.path(args)
    rng = np.random.default_rng(args.seed)
    tools = held_out_tools(args.tools, args.tool_seed)
    grasps = [(float(rng.uniform(*GRASP_ACROSS)), float(rng.uniform(*GRASP_ALONG))) for _ in tools]
    start = time.perf_counter()
    plan = plan_shape_measurement(Scenario())
    noisy = {
        "noise_sigma": args.noise,
        "depth_noise_sigma": args.depth_noise,
        "lighting": args.lighting,
    }
    conditions = {
        "clean": {"noise_sigma": 0.0, "depth_noise_sigma": 0.0, "lighting": "default"},
        "noisy": noisy,
    }
    results = {}
    print(
        "| condition | family right | frames within 2 mm | largest frame error (mm): "
        "median / p95 / max | " + " | ".join(FAMILIES) + " | fit (s, median) |"
    )
    print("|---" * (5 + len(FAMILIES)) + "|")
    for name, options in conditions.items():
        rows = []
        for k, (tool, (across, along)) in enumerate(zip(tools, grasps)):
            result = measure_shape(held(tool, across, along), plan=plan, seed=k, **options)
            rows.append({**tool.as_dict(), "grasp_m": [across, along], **shape_row(result)})
        s = condition_summary(rows)
        results[name] = {"options": options, "summary": s, "tools": rows}
        e = s["max_frame_error_mm"]
        per_family = " | ".join(
            f"{s['families'][f]['family_right']}/{s['families'][f]['tools']}, "
            f"≤ {s['families'][f]['max_frame_error_mm']:.2f} mm"
            if f in s["families"]
            else "–"
            for f in FAMILIES
        )
        print(
            f"| {name} | {s['family_right_rate'] * 100:.0f} % | {s['within_goal_rate'] * 100:.0f} % "
            f"| {e['median']:.2f} / {e['p95']:.2f} / {e['max']:.2f} | {per_family} | "
            f"{s['fit_time_s_median']:.1f} |",
            flush=True,
        )
    reference = reference_rows(args.reference, rng, plan, noisy) if args.reference else []
    if reference:
        print("\n| tool | frame | marker bands: mean / max (mm) | shape: mean / max (mm) |")
        print("|---|---|---|---|")
        for kind in ("straight", "hook"):
            frames = {n for r in reference if r["tool"] == kind for n in r["frames"]}
            for n in sorted(frames):
                m = [r["frames"][n]["markers_mm"] for r in reference if r["tool"] == kind]
                sh = [r["frames"][n]["shape_mm"] for r in reference if r["tool"] == kind]
                sh = [v for v in sh if v is not None]
                print(
                    f"| {kind} | {n} | {np.mean(m):.2f} / {np.max(m):.2f} | "
                    + (f"{np.mean(sh):.2f} / {np.max(sh):.2f} |" if sh else "– |")
                )
    goals = {
        f"{c}_family_right_at_least_{FAMILY_GOAL * 100:g}pct": results[c]["summary"][
            "family_right_rate"
        ]
        >= FAMILY_GOAL
        for c in conditions
    }
    goals.update(
        {
            f"{c}_frames_within_{FRAME_GOAL_MM:g}mm": results[c]["summary"]["within_goal_rate"]
            == 1.0
            for c in conditions
        }
    )
    print(
        f"\n{args.tools} held-out tools (tool seed {args.tool_seed}, seed {args.seed}); noisy: "
        f"colour noise {args.noise:g}, depth noise {args.depth_noise * 1e3:g} mm, lighting "
        f"{args.lighting}; {time.perf_counter() - start:.0f} s"
    )
    for goal, met in goals.items():
        print(f"goal {goal}: {'met' if met else 'NOT met'}")
    command = (
        f"python benchmarks/shape_vision_accuracy.py --tools {args.tools} --tool-seed "
        f"{args.tool_seed} --seed {args.seed} --noise {args.noise:g} --depth-noise "
        f"{args.depth_noise:g} --lighting {args.lighting} --reference {args.reference}"
    )
    OUTPUT.write(
        out,
        command,
        goals=goals,
        summary={c: results[c]["summary"] for c in results},
        results={"conditions": results, "reference": reference},
    )
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(run_script(main))
