"""`drake-tooluse demo`: a task's whole loop once, in the perturbed "reality".

1. Draw a reality of the task (`--task`, as the task declares it: `tasks.contract.ToolTask`;
   seeded): a tool the robot has never trained with (`--tool`, default the task's
   `demo_tool`; `random`: one the robot has never seen, from the tool generator's held-out
   family), held with a shifted grasp; the object's mass and friction off; delayed
   actuation; a noisy camera.
2. Measure the tool with the head camera (OpenCV; the straight tool's or the hook's
   measurement, by the tool's kind; a generated tool's shape from depth, its family unknown).
3. Do the task with its shipped policy closed loop (or another policy directory of the task,
   or its scripted reference: `--policy scripted`), the IK holding the measured tool where the
   camera saw the hand hold it, recorded in Meshcat.
4. Write `runs/demo-<time>/`: `recording.html` (open it in a browser), `metrics.json`,
   `trajectory.png` (the tool point and the object from above and over time), `summary.png`
   (the head camera's view cropped to the tool with the measurement in words, the scene at
   the end with the goal marked, the paths from above), `camera/measure_<view>.png` (the
   annotated camera views) and `final_scene.png` (the scene camera at the end, the goal drawn
   on it in green).

Every path in `metrics.json` (`policy`, `scenario` and each of `files`) is absolute: the
run directory's files where the directory is once written, the inputs where they were read.
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Patch

from drake_tooluse.builders.visualization import start_meshcat
from drake_tooluse.experiments.runs import quiet_log, stderr_log
from drake_tooluse.experiments.task_worlds import (
    TASKS,
    TOOL_TASKS,
    holding,
    measure,
    task_scenarios,
)
from drake_tooluse.experiments.tool_choice import (
    LearnedPolicy,
    ScriptedPolicy,
    clamped,
    no_policy_reason,
)
from drake_tooluse.files import (
    atomic_dir,
    atomic_write_figure,
    atomic_write_image,
    atomic_write_json,
    check_output_dir,
)
from drake_tooluse.paths import POLICIES_DIR, REALITY_SCENARIO, SCENARIOS_DIR
from drake_tooluse.perception.markers import ANNOTATION_COLORS
from drake_tooluse.progress import progress_bar
from drake_tooluse.robot.tool import parse_tool, tool_label
from drake_tooluse.robot.tool_generator import HELD_OUT_FAMILY, GeneratedTool, generate_tool
from drake_tooluse.systems.camera import (  # noqa: F401 (GOAL_RGB: the demo's figures' green)
    GOAL_RGB,
    SceneView,
    draw_goal,
)
from drake_tooluse.tasks.contract import declaration
from drake_tooluse.tasks.deploy import MAX_STEPS
from drake_tooluse.validation import check_one_of, check_seed
from drake_tooluse.world.paper import SUCCESS_DISTANCE
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import load_scenario
from drake_tooluse.world.scene import goal_position, initial_box_pose

SCRIPTED = "scripted"  # the `policy` that is the task's scripted reference
# The `tool` that is one the robot has never seen: drawn with the demo's seed from the tool
# generator's held-out family (`robot.tool_generator.HELD_OUT_FAMILY`, which no policy
# trains on), measured by its shape.
RANDOM = "random"
FIGURE_DPI = 110
GOAL_RADIUS = SUCCESS_DISTANCE / 2  # m, the goal as drawn (as in the Meshcat recording)


def mark_goal(image: np.ndarray, view: SceneView, scenario) -> np.ndarray:
    """`image` (RGB(A), the scene camera's) with the scenario's goal drawn where the camera
    sees it (`systems.camera.draw_goal`: a translucent green disc of radius GOAL_RADIUS on the
    table around x*, a cross at x*)."""
    goal = goal_position(scenario)
    return draw_goal(image, view, [goal[0], goal[1], scenario.table.top_z], GOAL_RADIUS)


def tool_crop(shape, view, aspect: float = 4 / 3) -> tuple[slice, slice]:
    """Rows and columns of an image of `shape` that frame the tool seen in `view` (a view's
    measurement: its `pixel_points` span the tool), with a margin, `aspect` wide over high."""
    h, w = shape[:2]
    corners = np.array(view.pixel_points(), float)
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


def _plot_top(ax, run, scenario, object_name: str) -> None:
    """The tool point and the object seen from above, with the object's start and the goal."""
    tip, thing = run.tool_path, run.object_path
    goal = goal_position(scenario)
    start = initial_box_pose(scenario).translation()
    ax.plot(tip[:, 1], tip[:, 0], color="tab:red", lw=1.5, label="tool point")
    ax.plot(thing[:, 1], thing[:, 0], color="tab:brown", lw=2.5, label=object_name)
    ax.scatter(
        [start[1]], [start[0]], color="tab:brown", marker="s", s=40, label=f"{object_name} start"
    )
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


def _plot_time(ax, run, scenario, object_name: str) -> None:
    """The tool point's height above the table and the object's travel over time."""
    start = initial_box_pose(scenario).translation()
    t = np.arange(len(run.tool_path)) * scenario.control.control_period
    ax.plot(
        t,
        run.tool_path[:, 2] - scenario.table.top_z,
        color="tab:red",
        label="tool point's height above the table",
    )
    ax.plot(
        t,
        np.linalg.norm(run.object_path[:, :2] - start[:2], axis=1),
        color="tab:brown",
        label=f"{object_name} travel",
    )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("m")
    ax.set_title("over time", fontsize=9)
    ax.legend(fontsize=7)


def _camera_panel(ax_image, ax_text, measurement) -> None:
    """An accepted head-camera view (a view of a hook's end first: it shows the bend),
    annotated and cropped to the tool, and under it the measurement in words with a legend of
    the annotation's colours (the measurement's `annotation_colors`, default the marker
    bands')."""
    ax_image.axis("off")
    ax_text.axis("off")
    pairs = [(v, f) for v, f in zip(measurement.views, measurement.image_files) if v.accepted]
    pairs.sort(key=lambda pair: not Path(pair[1]).stem.startswith("measure_hook"))
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
            for bgr, label in getattr(measurement, "annotation_colors", ANNOTATION_COLORS).values()
        ],
        loc="lower left",
        fontsize=6.5,
        framealpha=0.85,
    )
    text = "\n".join(measurement.summary_lines())
    ax_text.text(0.0, 1.0, text, va="top", ha="left", fontsize=8.5, family="sans-serif")


def write_figures(out: Path, run, scenario, measurement, object_name: str = "object") -> dict:
    """trajectory.png, final_scene.png (the run's scene camera image, the goal marked where the
    camera sees it) and summary.png (camera view, scene, paths)."""
    files = {}
    fig = Figure(figsize=(9, 4))
    ax_top, ax_time = fig.subplots(1, 2)
    _plot_top(ax_top, run, scenario, object_name)
    _plot_time(ax_time, run, scenario, object_name)
    fig.tight_layout()
    files["trajectory"] = atomic_write_figure(out / "trajectory.png", fig, dpi=FIGURE_DPI)
    final_image = run.final_image
    if final_image is not None and run.scene_view is not None:
        final_image = mark_goal(final_image, run.scene_view, scenario)
    if final_image is not None:
        files["final_scene"] = atomic_write_image(out / "final_scene.png", final_image)
    fig = Figure(figsize=(15, 5))
    grid = fig.add_gridspec(2, 3, height_ratios=[3.0, 1.25], width_ratios=[1.1, 1.0, 0.95])
    _camera_panel(fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), measurement)
    ax_scene = fig.add_subplot(grid[:, 1])
    if final_image is not None:
        ax_scene.imshow(final_image[:, :, :3])
        ax_scene.set_title("at the end (green: the goal)", fontsize=9)
    ax_scene.axis("off")
    _plot_top(fig.add_subplot(grid[:, 2]), run, scenario, object_name)
    fig.tight_layout()
    files["summary"] = atomic_write_figure(out / "summary.png", fig, dpi=FIGURE_DPI)
    return files


def _finite_or_none(x) -> float | None:
    return float(x) if math.isfinite(x) else None  # NaN: the camera did not give it


def _tool_figures(dimensions: dict, grasp_along: float) -> dict:
    """A tool's dimensions (`Tool.dimensions()`, or what the camera measured of them) and
    where it is held along it, named with units."""
    return {
        **{k: _finite_or_none(v) for k, v in dimensions.items()},
        "grasp_along_m": _finite_or_none(grasp_along),
    }


def demo_controller(task: str, policy=None, trust_pickle: bool = False, tool=None):
    """What does the demo's task: the task's shipped policy (`policy` None; for a generated
    `tool`, its policy for every shape where it has one: `ToolTask.shapes_policy`), a policy
    directory of that task, or `scripted` (its scripted reference). A policy of another task
    is a ValueError naming both."""
    declared = TOOL_TASKS[check_one_of(task, TASKS, "task")]
    if str(policy) == SCRIPTED:
        return ScriptedPolicy(declared.env_id)
    shipped = declared.policy
    if isinstance(tool, GeneratedTool) and declared.shapes_policy is not None:
        shipped = declared.shapes_policy
    learned = LearnedPolicy(policy or POLICIES_DIR / shipped, trust_pickle=trust_pickle)
    ours, theirs = declaration(declared.env_id), declaration(learned.env_id)
    if ours != theirs:
        raise ValueError(
            f"{policy} is a policy of {learned.env_id} (the {theirs.name} task), not of the "
            f"{task} task ({declared.env_id})"
        )
    return learned


def run_demo(
    out_dir,
    task: str = "push",
    policy_dir=None,
    tool=None,
    scenario_path=None,
    seed: int = 0,
    max_steps: int = MAX_STEPS,
    progress: bool = True,
    trust_pickle: bool = False,
    meshcat=None,
) -> dict:
    """Runs the demo of `task` (see the module docstring) and returns its metrics (also in
    `out_dir/metrics.json`). `tool`: a tool or its text (`straight:L`, `hook:H,K,A`; default
    the task's `demo_tool`), a GeneratedTool, or RANDOM; `policy_dir`: default the task's shipped policy, `scripted` its
    scripted reference; `scenario_path`: reality (default the task's, as it declares it);
    `trust_pickle` lets `policy_dir` be of the older pickle format. The run is recorded in
    `meshcat` (default: a new one on a free loopback port), and the recording published there
    to play again. Bad input fails before anything is written."""
    start = time.perf_counter()
    log = stderr_log if progress else quiet_log
    check_seed(seed, "seed")
    out = Path(out_dir)
    check_output_dir(out, "the demo's directory")
    if not isinstance(max_steps, int) or not 1 <= max_steps <= 1000:
        raise ValueError(f"max_steps={max_steps!r} must be an integer in [1, 1000]")
    declared = TOOL_TASKS[check_one_of(task, TASKS, "task")]
    tool = declared.demo_tool if tool is None else tool
    if tool == RANDOM:
        tool = generate_tool(HELD_OUT_FAMILY, seed)
    tool = parse_tool(tool) if isinstance(tool, str) else tool
    why_not = no_policy_reason(task, tool)
    if why_not is not None:
        raise ValueError(f"tool {label(tool)}: {why_not}")
    controller = demo_controller(task, policy_dir, trust_pickle, tool)
    if scenario_path is None:
        reality = task_scenarios(task)[1]
        scenario_path = (
            REALITY_SCENARIO if declared.reality_world else SCENARIOS_DIR / declared.world
        )
    else:
        reality = load_scenario(scenario_path)
    base = holding(reality, tool)
    draw = draw_randomization(base, np.random.default_rng(seed))
    scenario = apply_draw(base, draw)
    object_name = declaration(declared.env_id).object_name
    times = {}
    # Written into a staging directory that becomes `out` only when everything is there.
    with atomic_dir(out) as work:
        log(
            f"[1/3] measuring the tool with the head camera ({label(tool)}, unknown to the robot) …"
        )
        t0 = time.perf_counter()
        belief, measurement = measure(scenario, tool, seed, save_images_dir=work / "camera")
        times["measure_s"] = time.perf_counter() - t0
        if isinstance(tool, GeneratedTool):
            true = {"family": tool.family, **tool.params}
            best = measurement.shape.best
            measured = {"family": measurement.family, **best.params}
            measured_grasp = {"across_m": best.grasp_across, "along_m": best.grasp_along}
            text, clamped_figures = shape_text(measurement.as_dict()), {}
        else:
            true = _tool_figures(tool.dimensions(), scenario.tool.grasp_offset_along)
            # As measured: a value just past its range, which the belief holds at the range's
            # end, is shown as it was (and `clamped` says so).
            measured = _tool_figures(measurement.measured_dimensions(), belief.grasp_offset[1])
            text, clamped_figures = tool_text(true, measured), clamped(belief, measurement)
        log(f"      {text} in {times['measure_s']:.1f} s")

        log(
            f"[2/3] {task}: the {object_name} with the {controller.name}, IK on the measured tool …"
        )
        t0 = time.perf_counter()
        meshcat = start_meshcat() if meshcat is None else meshcat
        with progress_bar(max_steps, "      control steps", "step", progress) as bar:
            run = controller.run(
                scenario,
                belief,
                recording_path=work / "recording.html",
                max_steps=max_steps,
                meshcat=meshcat,
                scene_camera=True,
                on_step=lambda step: bar.update(1),
            )
        times["run_s"] = time.perf_counter() - t0
        log(f"      {run_text(run.as_dict(), object_name)} in {times['run_s']:.1f} s")

        log("[3/3] writing figures and metrics …")
        figures = write_figures(work, run, scenario, measurement, object_name)
        times["total_s"] = time.perf_counter() - start
        where = out.resolve()

        def final(path) -> str:  # where a file will be once the directory is in place
            return str(where / Path(path).relative_to(work))

        metrics = {
            "task": task,
            "object": object_name,
            "controller": controller.name,
            "policy": SCRIPTED
            if isinstance(controller, ScriptedPolicy)
            else str(controller.directory.resolve()),
            "scenario": str(Path(scenario_path).resolve()),
            "seed": seed,
            "tool": {
                "given": label(tool),
                "true": true,
                "measured": measured,
                **({"measured_grasp": measured_grasp} if isinstance(tool, GeneratedTool) else {}),
                "clamped": clamped_figures,
                "measurement": _without_files(measurement.as_dict()),
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


def _without_files(measurement: dict) -> dict:
    """A measurement's figures without its image paths (the run's `files` name them where
    they end up)."""
    return {k: v for k, v in measurement.items() if k != "image_files"}


def _value(key: str, value) -> str:
    """One of a tool's figures (named with its unit, `length_m`) in words: "12.50 cm"."""
    if value is None:
        return "n/a"
    if key.endswith("_deg"):
        return f"{value:.1f}°"
    if key == "grasp_along_m":
        return f"{value * 1000:+.1f} mm"
    return f"{value * 100:.2f} cm"


def tool_text(true: dict, measured: dict) -> str:
    """The tool as measured, each figure beside the truth."""
    return "; ".join(
        f"{key.rpartition('_')[0].replace('_', ' ')} {_value(key, measured[key])} "
        f"(truth {_value(key, true[key])})"
        for key in true
    )


def run_text(run: dict, object_name: str = "object") -> str:
    """Where the run left the object, and when it first reached the goal."""
    first = run["first_success_step"]
    arrived = "never at the goal" if first is None else f"first at the goal at step {first}"
    end = "at the goal" if run["success"] else "not at the goal"
    return (
        f"{object_name} {end} after {run['steps']} steps, "
        f"{run['final_object_to_goal_m'] * 100:.1f} cm from it ({arrived}); it moved "
        f"{run['object_travel_m'] * 100:.1f} cm"
    )


def shape_text(measurement: dict) -> str:
    """A shape measurement (`ShapeMeasurementResult.as_dict`) in words: the family named and
    each working frame's distance from the truth."""
    frames = ", ".join(f"{n} {e * 1000:.1f} mm" for n, e in measurement["frame_errors_m"].items())
    return (
        f"a {measurement['family']} (truth: {measurement['truth_family']}); working frames off "
        f"the truth by {frames}"
    )


def label(tool) -> str:
    """A tool in words: `robot.tool.tool_label`'s, or a generated tool's (`rake#3`)."""
    return tool.label() if isinstance(tool, GeneratedTool) else tool_label(tool)


def format_demo(m: dict) -> str:
    tool = m["tool"]
    measured = (
        shape_text(tool["measurement"])
        if "family" in tool["true"]
        else tool_text(tool["true"], tool["measured"])
    )
    return "\n".join(
        [
            f"tool: {tool['given']}, measured {measured}",
            f"{m['task']} ({m['controller']}): {run_text(m['run'], m['object'])}",
            f"open {m['files']['recording']} in a browser; figures: {m['files']['summary']}",
            f"({m['times']['total_s']:.0f} s)",
        ]
    )
