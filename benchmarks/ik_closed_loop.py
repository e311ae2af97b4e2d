"""Closed-loop tool-tip accuracy (the paper's IK experiment), in the dynamic simulation.

For each tool (none, 0.125 m, 0.175 m) the tip is sent, with the tool pointing down, to a grid
of table-top targets 2 cm above the table; after each move it settles and the true tip's error
is measured in the world plant. The box is moved out of the way. A second condition shifts the
true grasp (default 5 mm along and 2 mm across the tool) while the robot believes the nominal
grasp: the error the camera's measurement must remove; a third condition has the robot
model hold the length the head camera measured (with the same shifted grasp), and a fourth
adds the camera's estimate of the grasp shift along the tool.

    python benchmarks/ik_closed_loop.py [--grid 5] [--settle 1.5] [--grasp-shift 0.005 0.002]
        [--out FILE | --update-docs] [--figure FILE]

Prints a Markdown table, writes it as JSON to a new runs/ik_closed_loop-<time>/ik_closed_loop.json
(or --out) and a figure beside it (or --figure); `--update-docs` writes
docs/results/ik_closed_loop.json and docs/figures/ik_closed_loop.png, which docs/BENCHMARKS.md
quotes.
"""

import argparse
import dataclasses as dc
import platform
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from pydrake.math import RigidTransform, RollPitchYaw  # noqa: E402

from drake_tooluse.builders.trajectory_diagram import simulate_waypoints  # noqa: E402
from drake_tooluse.cli.common import run_script  # noqa: E402
from drake_tooluse.experiments.runs import BenchmarkOutput  # noqa: E402
from drake_tooluse.files import atomic_write_json  # noqa: E402
from drake_tooluse.robot.model import TOOL_DOWN_RPY, RobotBelief  # noqa: E402
from drake_tooluse.world.scenario import Scenario, validate_scenario  # noqa: E402

OUTPUT = BenchmarkOutput(Path(__file__))
TOOLS = [None, 0.125, 0.175]


def scenario_for(tool_length, along: float = 0.0, across: float = 0.0) -> Scenario:
    s = Scenario()
    tool = dc.replace(
        s.tool,
        attached=tool_length is not None,
        length=tool_length or s.tool.length,
        grasp_offset_along=along,
        grasp_offset_across=across,
    )
    box = dc.replace(s.box, position=[0.95, 0.60, 0.0])  # out of the way
    return validate_scenario(dc.replace(s, tool=tool, box=box))


def targets(scenario: Scenario, grid: int) -> list[RigidTransform]:
    z = scenario.table.top_z + 0.02
    R = RollPitchYaw(*TOOL_DOWN_RPY)
    return [
        RigidTransform(R, [x, y, z])
        for x in np.linspace(0.55, 0.79, grid)
        for y in np.linspace(-0.45, -0.05, grid)
    ]


def run_condition(
    length, along, across, args, measure: bool = False, grasp_estimate: bool = False
) -> dict:
    scenario = scenario_for(length, along, across)
    belief = RobotBelief(length)  # the true length, the nominal grasp
    if measure:  # the robot model holds the length the head camera measured
        from drake_tooluse.builders.measurement import measure_belief

        # ... and, with grasp_estimate, where the camera saw the hand hold it along the tool
        belief, _ = measure_belief(scenario, use_grasp_estimate=grasp_estimate)
    believed, grasp = belief.tool_length, belief.grasp_offset
    start = time.perf_counter()
    run = simulate_waypoints(
        scenario,
        targets(scenario, args.grid),
        move_time=args.move_time,
        dwell=args.settle,
        belief=belief,
    )
    wall = time.perf_counter() - start
    e = np.array([r.position_error for r in run.results]) * 1e3
    rot = np.array([r.orientation_error for r in run.results])
    tool = "no tool" if length is None else f"{length:.3f} m"
    label = "nominal" if not (along or across) else f"shifted {along * 1e3:g}/{across * 1e3:g} mm"
    if measure:
        label += f", measured length {believed * 1e3:.2f} mm"
    if grasp_estimate:
        label += f" and grasp {grasp[1] * 1e3:+.2f} mm along"
    return {
        "tool": tool,
        "grasp": label,
        "targets": len(e),
        "mean_mm": float(e.mean()),
        "median_mm": float(np.median(e)),
        "max_mm": float(e.max()),
        "orientation_max_rad": float(rot.max()),
        "ik_failures": int(sum(not r.ik_success for r in run.results)),
        "sim_time_s": run.sim_time,
        "wall_time_s": wall,
        "errors_mm": e.tolist(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--grid", type=int, default=5, help="targets per side (grid x grid)")
    ap.add_argument("--move-time", type=float, default=1.0)
    ap.add_argument("--settle", type=float, default=1.5)
    ap.add_argument(
        "--grasp-shift",
        type=float,
        nargs=2,
        default=[0.005, 0.002],
        metavar=("ALONG", "ACROSS"),
        help="second condition: the true grasp shifted along and across the tool "
        "(m) while the robot believes the nominal grasp",
    )
    OUTPUT.add_arguments(ap)
    ap.add_argument(
        "--figure",
        type=Path,
        help="PNG file (default: beside the JSON; with --update-docs docs/figures/ik_closed_loop.png)",
    )
    args = ap.parse_args()
    out = OUTPUT.path(args)
    figure = args.figure or (
        OUTPUT.docs_dir / "figures" / "ik_closed_loop.png"
        if args.update_docs
        else out.with_suffix(".png")
    )
    along, across = args.grasp_shift
    results = [run_condition(L, 0.0, 0.0, args) for L in TOOLS]
    results += [run_condition(L, along, across, args) for L in TOOLS if L is not None]
    # The camera measures the tool as held (marker to marker, the grasp shift included).
    results += [run_condition(L, along, across, args, measure=True) for L in TOOLS if L is not None]
    # ... and where the hand holds it along the tool (the grip marker's end in the gripper).
    results += [
        run_condition(L, along, across, args, measure=True, grasp_estimate=True)
        for L in TOOLS
        if L is not None
    ]
    print(
        "| tool | grasp (along/across) | targets | tip error mean / median / max (mm) | "
        "orientation max (rad) | IK failures | simulated / wall (s) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in results:
        print(
            f"| {r['tool']} | {r['grasp']} | {r['targets']} | {r['mean_mm']:.2e} / "
            f"{r['median_mm']:.2e} / {r['max_mm']:.2e} | {r['orientation_max_rad']:.1e} | "
            f"{r['ik_failures']} | {r['sim_time_s']:.1f} / {r['wall_time_s']:.1f} |"
        )
    fig, ax = plt.subplots(figsize=(7, 3.8))
    errors = [np.maximum(r["errors_mm"], 1e-9) for r in results]
    labels = [f"{r['tool']}\n{r['grasp']}" for r in results]
    ax.boxplot(errors, tick_labels=labels)
    for i, e in enumerate(errors, start=1):
        ax.scatter(
            np.full(len(e), i) + np.random.default_rng(i).uniform(-0.12, 0.12, len(e)),
            e,
            s=8,
            alpha=0.6,
        )
    ax.axhline(10.0, color="grey", ls="--", lw=0.8)
    ax.text(0.55, 10.0, "paper: < 1 cm (real robot)", va="bottom", fontsize=8, color="grey")
    ax.set_yscale("log")
    ax.set_ylim(1e-7, 50)
    ax.tick_params(axis="x", labelsize=8)
    ax.set_ylabel("settled tool-tip error (mm)")
    ax.set_title(
        f"Closed-loop tool-tip error, {results[0]['targets']} table-top targets per "
        "tool (the robot believes the nominal grasp)",
        fontsize=9,
    )
    fig.tight_layout()
    figure.parent.mkdir(parents=True, exist_ok=True)
    tmp = figure.with_name(f".{figure.stem}.tmp.png")
    fig.savefig(tmp, dpi=120)
    tmp.replace(figure)
    atomic_write_json(
        out,
        {
            "command": f"python benchmarks/ik_closed_loop.py --grid {args.grid} "
            f"--move-time {args.move_time} --settle {args.settle} "
            f"--grasp-shift {along} {across}",
            "machine": platform.platform(),
            "results": results,
        },
    )
    print(f"wrote {out}, {figure}")


if __name__ == "__main__":
    sys.exit(run_script(main))
