"""`drake-tooluse demo --task pull`: the pull's whole loop once, in the perturbed "reality".

1. The pull world as reality meets it (`tool_choice.pull_reality`: actuation delay,
   conservative joint limits, camera noise), holding a hook the robot is not told about,
   off-centre in the hand.
2. Measure the hook with the head camera (`measure_hook_belief`).
3. Pull the cube to the goal closed loop on the measured hook (`run_pull`) with the shipped
   hook policy (`paths.PULL_POLICY`; another policy directory, or `scripted` for the scripted
   reference `ScriptedPull`), recorded in Meshcat.
4. Write `runs/demo-pull-<time>/`: `recording.html`, `metrics.json`, `summary.png` (the
   annotated head-camera view and the pull's figures in words) and `camera/` (every view).
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure

from drake_tooluse.builders.control import BEHAVIOUR_V1
from drake_tooluse.builders.hook_measurement import measure_hook_belief
from drake_tooluse.builders.visualization import start_meshcat
from drake_tooluse.experiments.demo import FIGURE_DPI, mark_goal
from drake_tooluse.experiments.runs import quiet_log, stderr_log
from drake_tooluse.experiments.tool_choice import (
    TOOL_TASKS,
    LearnedPolicy,
    holding,
    task_scenarios,
)
from drake_tooluse.files import atomic_dir, atomic_write_figure, atomic_write_json, check_output_dir
from drake_tooluse.paths import PULL_POLICY
from drake_tooluse.robot.tool import HookTool
from drake_tooluse.tasks.contract import declaration, env_class
from drake_tooluse.tasks.pull.registration import MAX_EPISODE_STEPS
from drake_tooluse.tasks.pull.run import run_pull
from drake_tooluse.tasks.pull.scripted import ScriptedPull
from drake_tooluse.validation import check_seed

DEMO_HANDLE_LENGTH = 0.25  # m
DEMO_HOOK_LENGTH = 0.05  # m
DEMO_HOOK_ANGLE = 75.0  # deg
DEMO_GRASP_ALONG = 0.015  # m, the hand holds the hook off-centre (unknown to the robot)
SCRIPTED = "scripted"  # the `policy` that is the scripted reference pull


def _finite(x) -> float | None:
    return float(x) if np.isfinite(x) else None  # NaN: no view accepted


def _cm(x) -> str:
    return "n/a" if x is None else f"{x * 100:.2f} cm"


def _mm(x) -> str:
    return "n/a" if x is None else f"{x * 1000:+.1f} mm"


def _deg(x) -> str:
    return "n/a" if x is None else f"{x:.1f}°"


def _summary(out: Path, measurement, metrics: dict, pull, scenario) -> Path:
    """summary.png: a head-camera view of the hook (annotated), the scene at the end of the
    pull (the goal in green) and the figures in words."""
    fig = Figure(figsize=(15, 4.5))
    ax_image, ax_scene, ax_text = fig.subplots(1, 3, width_ratios=[1.3, 1.3, 1.0])
    for ax in (ax_image, ax_scene, ax_text):
        ax.axis("off")
    if pull.final_image is not None and pull.scene_view is not None:
        ax_scene.imshow(mark_goal(pull.final_image, pull.scene_view, scenario)[:, :, :3])
        ax_scene.set_title("the pull, at the end (green: the goal)", fontsize=9)
    files = [f for v, f in zip(measurement.views, measurement.image_files) if v.accepted]
    # A view of the hook's end first: it shows the bend the robot measured.
    files.sort(key=lambda f: not Path(f).stem.startswith("measure_hook"))
    if files:
        ax_image.imshow(cv2.cvtColor(cv2.imread(str(files[0])), cv2.COLOR_BGR2RGB))
        ax_image.set_title("head camera, the hook measured (annotated)", fontsize=9)
    text = format_demo_pull(metrics, files=False).replace("; it moved", ";\n  it moved")
    text = text.replace(" (first at", "\n  (first at")
    ax_text.text(0.0, 0.9, text, va="top", fontsize=8.5)
    fig.tight_layout()
    return atomic_write_figure(out / "summary.png", fig, dpi=FIGURE_DPI)


def _controller(policy, scenario):
    """(the observation → action callable, its name in the metrics, how its action reaches
    the joints) of `policy`: a policy directory, or "scripted"."""
    if str(policy) == SCRIPTED:
        return ScriptedPull(scenario.table.top_z), "scripted pull", BEHAVIOUR_V1
    learned = LearnedPolicy(policy)
    pull = TOOL_TASKS["pull"]
    if declaration(learned.env_id) != declaration(pull.env_id):
        raise ValueError(f"{policy} is a policy of {learned.env_id}, not of the pull task")
    meta = learned.policy.meta
    behaviour = env_class(meta.env_id).control_behaviour(meta.env_kwargs)
    return learned.policy.act, f"policy {Path(policy).name}", behaviour


def run_demo_pull(
    out_dir,
    handle_length: float = DEMO_HANDLE_LENGTH,
    hook_length: float = DEMO_HOOK_LENGTH,
    hook_angle: float = DEMO_HOOK_ANGLE,
    seed: int = 0,
    max_steps: int = MAX_EPISODE_STEPS,
    progress: bool = True,
    meshcat=None,
    policy=PULL_POLICY,
) -> dict:
    """Runs the pull demo (see the module docstring) and returns its metrics (also in
    `out_dir/metrics.json`)."""
    start = time.perf_counter()
    log = stderr_log if progress else quiet_log
    check_seed(seed, "seed")
    out = Path(out_dir)
    check_output_dir(out, "the demo's directory")
    if not isinstance(max_steps, int) or not 1 <= max_steps <= 1000:
        raise ValueError(f"max_steps={max_steps!r} must be an integer in [1, 1000]")
    _, reality = task_scenarios("pull")
    tool = HookTool(handle_length, hook_length, hook_angle)  # checks the sizes
    scenario = holding(reality, tool, DEMO_GRASP_ALONG)
    controller, controller_name, behaviour = _controller(policy, scenario)
    truth = {
        "handle_length": handle_length,
        "hook_length": hook_length,
        "angle": hook_angle,
        "grasp_along": DEMO_GRASP_ALONG,
    }
    times = {}
    with atomic_dir(out) as work:
        log("[1/3] measuring the hook with the head camera (unknown to the robot) …")
        t0 = time.perf_counter()
        belief, measurement = measure_hook_belief(
            scenario, save_images_dir=work / "camera", seed=seed
        )
        times["measure_s"] = time.perf_counter() - t0
        log(f"[2/3] pulling the cube with the {controller_name} on the measured hook …")
        t0 = time.perf_counter()
        meshcat = start_meshcat() if meshcat is None else meshcat
        pull = run_pull(
            scenario,
            controller,
            belief,
            max_steps,
            meshcat=meshcat,
            recording_path=work / "recording.html",
            scene_camera=True,
            behaviour=behaviour,
        )
        times["pull_s"] = time.perf_counter() - t0
        log("[3/3] writing figures and metrics …")
        where = out.resolve()

        def final(path) -> str:  # where a file will be once the directory is in place
            return str(where / Path(path).relative_to(work))

        metrics = {
            "task": "pull",
            "controller": controller_name,
            "seed": seed,
            "hook": {
                "true": truth,
                "measured": {q: _finite(getattr(measurement, q)) for q in truth},
                "views": measurement.as_dict()["views"],
                "dropped_views": measurement.dropped,
            },
            "run": pull.as_dict(),
            "times": times,
            "files": {
                "recording": final(work / "recording.html"),
                "metrics": final(work / "metrics.json"),
                "summary": final(work / "summary.png"),
                "camera_views": [final(f) for f in measurement.image_files],
            },
        }
        times["total_s"] = time.perf_counter() - start
        _summary(work, measurement, metrics, pull, scenario)
        atomic_write_json(work / "metrics.json", metrics)
    return metrics


def format_demo_pull(m: dict, files: bool = True) -> str:
    true, measured, pull = m["hook"]["true"], m["hook"]["measured"], m["run"]
    first = pull["first_success_step"]
    arrived = "never at the goal" if first is None else f"first at the goal at step {first}"
    end = "at the goal" if pull["success"] else "not at the goal"
    lines = [
        f"hook: true handle {true['handle_length'] * 100:.1f} cm, hook "
        f"{true['hook_length'] * 100:.1f} cm, {true['angle']:.0f}°, held "
        f"{true['grasp_along'] * 1000:+.1f} mm along it",
        f"  measured handle {_cm(measured['handle_length'])}, hook "
        f"{_cm(measured['hook_length'])}, {_deg(measured['angle'])}, held "
        f"{_mm(measured['grasp_along'])} along it",
        f"pull ({m['controller']}): cube {end} after {pull['steps']} steps, "
        f"{pull['final_object_to_goal_m'] * 100:.1f} cm from it ({arrived}); "
        f"it moved {pull['object_travel_m'] * 100:.1f} cm",
    ]
    if files:
        lines.append(
            f"open {m['files']['recording']} in a browser; figures: {m['files']['summary']}"
        )
    lines.append(f"({m['times']['total_s']:.0f} s)")
    return "\n".join(lines)
