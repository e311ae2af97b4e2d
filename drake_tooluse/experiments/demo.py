"""`drake-tooluse demo`: the whole loop once, in the perturbed "reality".

1. Draw a reality (`diagrams/reality.yaml`, seeded): a tool the robot has never trained with,
   held with a shifted grasp; box mass and friction off; delayed actuation; noisy camera.
2. Measure the tool with the head camera (three views, OpenCV).
3. Push the box with the shipped policy closed-loop, its IK holding the measured tool (its
   length, and where the hand holds it along it), recorded in Meshcat.
4. Write `runs/demo-<time>/`: `recording.html` (open it in a browser), `metrics.json`,
   `trajectory.png` (tool tip and box from above and from the side), `summary.png` (the head
   camera cropped to the tool with both length estimates and a legend of the annotation's
   colours, the scene at the end with the goal marked, the paths from above),
   `camera/measure_<view>.png` (the annotated camera views) and `final_scene.png` (the scene
   camera at the end of the push, the goal drawn on it in green).

Every path in `metrics.json` (`policy`, `scenario` and each of `files`) is absolute: the
run directory's files where the directory is once written, the inputs where they were read.
"""

from __future__ import annotations

import dataclasses as dc
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Patch
from tqdm import tqdm

from drake_tooluse.builders.measurement import measure_belief
from drake_tooluse.builders.visualization import save_recording, start_meshcat
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
from drake_tooluse.perception.markers import ANNOTATION_COLORS
from drake_tooluse.systems.camera import (  # noqa: F401 (GOAL_RGB: the demo's figures' green)
    GOAL_RGB,
    SceneView,
    draw_goal,
    scene_camera_view,
)
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.tasks.push.diagram import build_policy_diagram, run_policy
from drake_tooluse.validation import check_seed
from drake_tooluse.world.paper import DEMO_TOOL_LENGTH, SUCCESS_DISTANCE
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import load_scenario, with_tool_length
from drake_tooluse.world.scene import goal_position, initial_box_pose

FIGURE_DPI = 110
GOAL_RADIUS = SUCCESS_DISTANCE / 2  # m, the goal as drawn (as in the Meshcat recording)


def mark_goal(image: np.ndarray, view: SceneView, scenario) -> np.ndarray:
    """`image` (RGB(A), the scene camera's) with the scenario's goal drawn where the camera
    sees it (`systems.camera.draw_goal`: a translucent green disc of radius GOAL_RADIUS on the
    table around x*, a cross at x*)."""
    goal = goal_position(scenario)
    return draw_goal(image, view, [goal[0], goal[1], scenario.table.top_z], GOAL_RADIUS)


def tool_crop(shape, view, aspect: float = 4 / 3) -> tuple[slice, slice]:
    """Rows and columns of an image of `shape` that frame the tool seen in `view` (a
    ViewMeasurement: its marker boxes span it), with a margin, `aspect` wide over high."""
    h, w = shape[:2]
    corners = np.array([c for box in view.boxes for c in box] + list(view.ends_px), float)
    if corners.size == 0:
        return slice(0, h), slice(0, w)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    span = max(float(np.linalg.norm(hi - lo)), 40.0)
    center = (lo + hi) / 2
    half_w = max((hi[0] - lo[0]) / 2 + 0.2 * span, aspect * ((hi[1] - lo[1]) / 2 + 0.2 * span))
    half_w = min(half_w, w / 2, aspect * h / 2)
    half_h = half_w / aspect
    u0 = int(np.clip(center[0] - half_w, 0, w - 2 * half_w))
    v0 = int(np.clip(center[1] - half_h, 0, h - 2 * half_h))
    return slice(v0, v0 + int(2 * half_h)), slice(u0, u0 + int(2 * half_w))


def _plot_top(ax, run, scenario) -> None:
    """Tool tip and box seen from above, with the box's start and the goal."""
    tip, box = run.tip_path, run.object_path
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
        np.linalg.norm(run.object_path[:, :2] - start[:2], axis=1),
        color="tab:brown",
        label="box travel",
    )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("m")
    ax.set_title("over time", fontsize=9)
    ax.legend(fontsize=7)


def _camera_panel(ax_image, ax_text, measurement) -> None:
    """The first accepted head-camera view, annotated and cropped to the tool, and under it
    both estimates of every view in words with a legend of the annotation's colours."""
    ax_image.axis("off")
    ax_text.axis("off")
    pairs = [(v, f) for v, f in zip(measurement.views, measurement.image_files) if v.accepted]
    if not pairs:
        return
    view, path = pairs[0]
    image = cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2RGB)
    rows, cols = tool_crop(image.shape, view)
    ax_image.imshow(image[rows, cols], interpolation="lanczos")
    ax_image.set_title(f"head camera, view {view.view} (cropped to the tool)", fontsize=9)
    ax_image.legend(
        handles=[
            Patch(color=np.array(bgr[::-1]) / 255, label=label.split(": ", 1)[1])
            for bgr, label in ANNOTATION_COLORS.values()
        ],
        loc="lower left",
        fontsize=6.5,
        framealpha=0.85,
    )
    accepted = [v for v in measurement.views if v.accepted]
    names = " / ".join(v.view.removeprefix("grip_") for v in accepted)

    def mm(values):
        return " / ".join(f"{x * 1000:.1f}" for x in values)

    depth = [v.length_depth for v in accepted]
    lines = [
        f"views (grip {names}), mm:",
        f"depth variant, what the robot uses: {mm(depth)}; mean {np.mean(depth) * 1000:.1f}",
        f"pixel variant, the paper's fixed m/px: {mm(v.length_pixel for v in accepted)}",
        "   (exact only for a tool square to the camera at the grip's depth:",
        "   a view that tilts the tool in depth foreshortens it)",
        f"true length: {measurement.scenario_tool_length * 1000:.1f} (unknown to the robot)",
    ]
    ax_text.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", fontsize=8.5, family="sans-serif")


def write_figures(out: Path, run, scenario, measurement, final_image, scene_view=None) -> dict:
    """trajectory.png, final_scene.png (the goal marked where `scene_view` sees it) and
    summary.png (camera view, scene, paths)."""
    files = {}
    fig = Figure(figsize=(9, 4))
    ax_top, ax_time = fig.subplots(1, 2)
    _plot_top(ax_top, run, scenario)
    _plot_time(ax_time, run, scenario)
    fig.tight_layout()
    files["trajectory"] = atomic_write_figure(out / "trajectory.png", fig, dpi=FIGURE_DPI)
    if final_image is not None and scene_view is not None:
        final_image = mark_goal(final_image, scene_view, scenario)
    if final_image is not None:
        files["final_scene"] = atomic_write_image(out / "final_scene.png", final_image)
    fig = Figure(figsize=(15, 5))
    grid = fig.add_gridspec(2, 3, height_ratios=[3.0, 1.25], width_ratios=[1.1, 1.0, 0.95])
    _camera_panel(fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), measurement)
    ax_scene = fig.add_subplot(grid[:, 1])
    if final_image is not None:
        ax_scene.imshow(final_image[:, :, :3])
        ax_scene.set_title("the push, at the end (green: the goal)", fontsize=9)
    ax_scene.axis("off")
    _plot_top(fig.add_subplot(grid[:, 2]), run, scenario)
    fig.tight_layout()
    files["summary"] = atomic_write_figure(out / "summary.png", fig, dpi=FIGURE_DPI)
    return files


def run_demo(
    out_dir,
    policy_dir=None,
    scenario_path=None,
    tool_length: float = DEMO_TOOL_LENGTH,
    seed: int = 0,
    max_steps: int = 100,
    progress: bool = True,
    trust_pickle: bool = False,
    meshcat=None,
) -> dict:
    """Runs the demo (see the module docstring) and returns its metrics (also in
    `out_dir/metrics.json`). `trust_pickle` lets `policy_dir` be of the older pickle format.
    The push is recorded in `meshcat` (default: a new one on a free loopback port), and the
    recording published there to play again."""
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
        meshcat = start_meshcat() if meshcat is None else meshcat
        built = build_policy_diagram(scenario, policy, belief, meshcat=meshcat, scene_camera=True)
        with tqdm(
            total=max_steps,
            desc="      control steps",
            unit="step",
            file=sys.stderr,
            disable=not progress or not sys.stderr.isatty(),  # no \r fragments in a log
            leave=False,
        ) as bar:
            run = run_policy(
                built, max_steps=max_steps, record=True, on_step=lambda step: bar.update(1)
            )
        save_recording(meshcat, built.visualizer, work / "recording.html")
        scene_view = scene_camera_view(built.diagram, built.world.plant)
        release_diagram(built.diagram)  # its Python systems would keep it alive
        times["push_s"] = time.perf_counter() - t0
        log(f"      {push_text(run.as_dict())} in {times['push_s']:.1f} s")

        log("[3/3] writing figures and metrics …")
        figures = write_figures(work, run, scenario, measurement, run.final_image, scene_view)
        times["total_s"] = time.perf_counter() - start
        where = out.resolve()

        def final(path) -> str:  # where a file will be once the directory is in place
            return str(where / Path(path).relative_to(work))

        metrics = {
            "policy": str(policy_dir.resolve()),
            "scenario": str(Path(scenario_path).resolve()),
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
            "run": run.as_dict(),
            "times": times,
            "files": {
                "recording": final(work / "recording.html"),
                "metrics": final(work / "metrics.json"),
                "camera_views": [final(f) for f in measurement.image_files],
                **{k: final(v) for k, v in figures.items()},
            },
        }
        atomic_write_json(work / "metrics.json", metrics)
    return metrics


def push_text(push: dict) -> str:
    """Where the push left the box, and when it first reached the goal."""
    first = push["first_success_step"]
    arrived = "never at the goal" if first is None else f"first at the goal at step {first}"
    end = "at the goal" if push["success"] else "not at the goal"
    return (
        f"box {end} after {push['steps']} steps, {push['final_object_to_goal_m'] * 100:.1f} cm "
        f"from it ({arrived}); it moved {push['object_travel_m'] * 100:.1f} cm"
    )


def format_demo(m: dict) -> str:
    push, tool = m["run"], m["tool"]
    return "\n".join(
        [
            f"tool: true {tool['true_length_m'] * 100:.1f} cm, measured "
            f"{tool['measured_length_m'] * 100:.2f} cm ({tool['measurement_error_m'] * 1000:+.2f} mm); "
            f"held {tool['measured_grasp_along_m'] * 1000:+.1f} mm along it (truth "
            f"{tool['true_grasp_along_m'] * 1000:+.1f} mm)",
            f"push: {push_text(push)}",
            f"open {m['files']['recording']} in a browser; figures: {m['files']['summary']}",
            f"({m['times']['total_s']:.0f} s)",
        ]
    )
