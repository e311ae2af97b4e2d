"""`drake-tooluse demo`: the whole loop once, in the perturbed "reality".

1. Draw a reality (`diagrams/reality.yaml`, seeded): a tool the robot has never trained with,
   held with a shifted grasp; box mass and friction off; delayed actuation; noisy camera.
2. Measure the tool with the head camera (three views, OpenCV).
3. Push the box with the shipped policy closed-loop, its IK holding the measured tool (its
   length, and where the hand holds it along it), recorded in Meshcat.
4. Write `runs/demo-<time>/`: `recording.html` (open it in a browser), `metrics.json`,
   `trajectory.png` (tool tip and box from above and from the side), `summary.png`,
   `camera/measure_<view>.png` (the annotated camera views) and `final_scene.png`.
"""

from __future__ import annotations

import dataclasses as dc
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from tqdm import tqdm

from drake_tooluse.diagrams.measurement import measure_belief
from drake_tooluse.diagrams.push import build_policy_diagram, run_policy
from drake_tooluse.diagrams.visualization import save_recording, start_meshcat
from drake_tooluse.experiments.runs import quiet_log, stderr_log
from drake_tooluse.files import (
    atomic_dir,
    atomic_write_figure,
    atomic_write_image,
    atomic_write_json,
    check_output_dir,
)
from drake_tooluse.learning.policy_dir import check_policy_env, load_policy
from drake_tooluse.paths import REALITY_SCENARIO, TRANSFER_POLICY
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.validation import check_seed
from drake_tooluse.world.paper import DEMO_TOOL_LENGTH, SUCCESS_DISTANCE
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import load_scenario, with_tool_length
from drake_tooluse.world.scene import goal_position, initial_box_pose

FIGURE_DPI = 110


def _plot_top(ax, run, scenario) -> None:
    """Tool tip and box seen from above, with the box's start and the goal."""
    tip, box = run.tip_path, run.box_path
    goal = goal_position(scenario)
    start = initial_box_pose(scenario).translation()
    ax.plot(tip[:, 1], tip[:, 0], color="tab:red", lw=1.5, label="tool tip")
    ax.plot(box[:, 1], box[:, 0], color="tab:brown", lw=2.5, label="box")
    ax.scatter([start[1]], [start[0]], color="tab:brown", marker="s", s=40, label="box start")
    ax.add_patch(
        Circle((goal[1], goal[0]), SUCCESS_DISTANCE / 2, fill=False, color="tab:green", lw=1.5)
    )
    ax.scatter([goal[1]], [goal[0]], color="tab:green", marker="x", s=40, label="goal")
    ax.set_xlabel("y (m)")
    ax.set_ylabel("x (m)")
    ax.invert_xaxis()  # seen from above with the robot's forward x up: +y is to the left
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("from above", fontsize=9)
    ax.legend(fontsize=7, loc="best")


def _plot_time(ax, run, scenario) -> None:
    """Tip height above the table and box travel over time."""
    start = initial_box_pose(scenario).translation()
    t = np.arange(len(run.tip_path)) * scenario.control.control_period
    ax.plot(
        t,
        run.tip_path[:, 2] - scenario.table.top_z,
        color="tab:red",
        label="tip height above the table",
    )
    ax.plot(
        t,
        np.linalg.norm(run.box_path[:, :2] - start[:2], axis=1),
        color="tab:brown",
        label="box travel",
    )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("m")
    ax.set_title("over time", fontsize=9)
    ax.legend(fontsize=7)


def write_figures(out: Path, run, scenario, camera_files, final_image) -> dict:
    """trajectory.png, final_scene.png and summary.png (camera view, scene, paths)."""
    files = {}
    fig = Figure(figsize=(9, 4))
    ax_top, ax_time = fig.subplots(1, 2)
    _plot_top(ax_top, run, scenario)
    _plot_time(ax_time, run, scenario)
    fig.tight_layout()
    files["trajectory"] = atomic_write_figure(out / "trajectory.png", fig, dpi=FIGURE_DPI)
    if final_image is not None:
        files["final_scene"] = atomic_write_image(out / "final_scene.png", final_image)
    fig = Figure(figsize=(14, 4.2))
    axes = fig.subplots(1, 3)
    if camera_files:
        view = cv2.imread(str(camera_files[0]))
        axes[0].imshow(cv2.cvtColor(view, cv2.COLOR_BGR2RGB))
        axes[0].set_title(f"head camera: {Path(camera_files[0]).stem}", fontsize=9)
    axes[0].axis("off")
    if final_image is not None:
        axes[1].imshow(final_image[:, :, :3])
        axes[1].set_title("the push, at the end", fontsize=9)
    axes[1].axis("off")
    _plot_top(axes[2], run, scenario)
    fig.tight_layout()
    files["summary"] = atomic_write_figure(out / "summary.png", fig, dpi=FIGURE_DPI)
    return {k: str(v) for k, v in files.items()}


def run_demo(
    out_dir,
    policy_dir=None,
    scenario_path=None,
    tool_length: float = DEMO_TOOL_LENGTH,
    seed: int = 0,
    max_steps: int = 100,
    progress: bool = True,
    trust_pickle: bool = False,
) -> dict:
    """Runs the demo (see the module docstring) and returns its metrics (also in
    `out_dir/metrics.json`). `trust_pickle` lets `policy_dir` be of the older pickle format."""
    start = time.perf_counter()
    log = stderr_log if progress else quiet_log
    check_seed(seed, "seed")
    out = Path(out_dir)
    check_output_dir(out, "the demo's directory")
    policy_dir = Path(policy_dir or TRANSFER_POLICY)
    # A bad policy fails before anything is written.
    policy = load_policy(policy_dir, trust_pickle=trust_pickle)
    check_policy_env(policy)
    scenario_path = scenario_path or REALITY_SCENARIO
    base = with_tool_length(load_scenario(scenario_path), tool_length)
    if not isinstance(max_steps, int) or not 1 <= max_steps <= 1000:
        raise ValueError(f"max_steps={max_steps!r} must be an integer in [1, 1000]")
    draw = draw_randomization(base, np.random.default_rng(seed))
    scenario = apply_draw(base, draw)
    times = {}
    # Written into a staging directory that becomes `out` only when everything is there.
    with atomic_dir(out) as work:
        log(
            f"[1/3] measuring the tool with the head camera (true length {tool_length:.3f} m, "
            "unknown to the robot) …"
        )
        t0 = time.perf_counter()
        belief, measurement = measure_belief(scenario, save_images_dir=work / "camera", seed=seed)
        times["measure_s"] = time.perf_counter() - t0
        measured, along = belief.tool_length, belief.grasp_offset[1]
        log(
            f"      measured {measured:.4f} m (error {(measured - tool_length) * 1000:+.2f} mm), "
            f"held {along * 1000:+.1f} mm along it (truth "
            f"{scenario.tool.grasp_offset_along * 1000:+.1f} mm) in {times['measure_s']:.1f} s"
        )

        log(f"[2/3] pushing the box with {policy_dir.name}, IK on the measured tool …")
        t0 = time.perf_counter()
        meshcat = start_meshcat()
        built = build_policy_diagram(scenario, policy, belief, meshcat=meshcat, scene_camera=True)
        with tqdm(
            total=max_steps,
            desc="      control steps",
            unit="step",
            file=sys.stderr,
            disable=not progress,
            leave=False,
        ) as bar:
            run = run_policy(
                built, max_steps=max_steps, record=True, on_step=lambda step: bar.update(1)
            )
        save_recording(meshcat, built.visualizer, work / "recording.html")
        release_diagram(built.diagram)  # its Python systems would keep it alive
        times["push_s"] = time.perf_counter() - t0
        log(
            f"      {'reached the goal' if run.success else 'did not reach the goal'} after "
            f"{run.steps} steps ({run.steps * scenario.control.control_period:.2f} s simulated)"
            f" in {times['push_s']:.1f} s"
        )

        log("[3/3] writing figures and metrics …")
        figures = write_figures(work, run, scenario, measurement.image_files, run.final_image)
        times["total_s"] = time.perf_counter() - start

        def final(path) -> str:  # where a file will be once the directory is in place
            return str(out / Path(path).relative_to(work))

        metrics = {
            "policy": str(policy_dir),
            "scenario": str(scenario_path),
            "seed": seed,
            "tool": {
                "true_length_m": tool_length,
                "measured_length_m": measured,
                "measurement_error_m": measured - tool_length,
                "measured_grasp_along_m": along,
                "true_grasp_along_m": scenario.tool.grasp_offset_along,
                "per_view_m": measurement.as_dict()["per_view_m"],
                "dropped_views": measurement.dropped,
            },
            "perturbation": dc.asdict(draw),
            "push": run.as_dict(),
            "times": times,
            "files": {
                "recording": str(out / "recording.html"),
                "metrics": str(out / "metrics.json"),
                "camera_views": [final(f) for f in measurement.image_files],
                **{k: final(v) for k, v in figures.items()},
            },
        }
        atomic_write_json(work / "metrics.json", metrics)
    return metrics


def format_demo(m: dict) -> str:
    push, tool = m["push"], m["tool"]
    return "\n".join(
        [
            f"tool: true {tool['true_length_m'] * 100:.1f} cm, measured "
            f"{tool['measured_length_m'] * 100:.2f} cm ({tool['measurement_error_m'] * 1000:+.2f} mm); "
            f"held {tool['measured_grasp_along_m'] * 1000:+.1f} mm along it (truth "
            f"{tool['true_grasp_along_m'] * 1000:+.1f} mm)",
            f"push: {'success' if push['success'] else 'no success'} in {push['steps']} steps; box "
            f"moved {push['box_travel_m'] * 100:.1f} cm, ends {push['final_box_to_goal_m'] * 100:.1f} cm "
            f"from the goal",
            f"open {m['files']['recording']} in a browser; figures: {m['files']['summary']}",
            f"({m['times']['total_s']:.0f} s)",
        ]
    )
