"""The sim-to-"reality" transfer experiment: a skill learned with one tool, used with others.

For each tool and each run (seeded), one draw of `diagrams/reality.yaml`'s randomization makes
two worlds:

- **nominal**: the simulation the policy knows (`diagrams/push.yaml`) with the run's box start
  pose and the true tool length given to the robot;
- **reality**: the same box start, plus the draw's grasp shift, box mass and friction, the
  reality's actuation delay, conservative joint limits and noisy camera. The robot measures the
  tool with the head camera — its length and where the hand holds it along its axis (or the
  length only, `use_grasp_estimate=False`, the paper's measurement) — and its IK holds that
  model; it knows nothing else.

Both run in one of two modes:

- `closed-loop`: the policy inside the diagram (`tasks.deploy.build_policy_diagram`), until
  its env's step limit (100 control steps for the push and the pull);
- `open-loop` (the paper's): a tool-tip trajectory averaged from the policy's episodes in the
  nominal simulation (`experiments.trajectory_extraction.extract`), replayed through a TrajectorySource
  and the IK with the measured length (`builders.trajectory_diagram`), in full, then 1 s to settle.
  How the trajectory is made (`extraction`): by default `line-contact` — the commanded tip
  poses of each episode in its box's frame, averaged, the tool tilted per tool so that its
  shaft pushes (`experiments.line_contact`), and each run's replay moved to its box's start,
  which the robot measures in reality with its hand camera (`builders.box_measurement`; the
  nominal world's robot knows it); or `paper`, the paper's own: the per-step mean of where the
  tip got, one trajectory for every tool and run, replayed as it is. A trajectory given as a
  file is replayed for every tool, moved to each run's box start as a line-contact one is
  (`extraction` `line-contact`) or as it is (`paper`).

The result has per tool and world the box travel (mean, std, each run) and the final box–goal
distance, the reality/nominal travel ratio and the two tools' travel difference (the
experiment's criteria, `goals`: ratio ≥ 0.9, difference ≤ 1 cm; not the env's success, the box
at the goal), and a box plot like the paper's.

A policy of another tool task (`tasks.contract.ToolTask`: the pull's hook policy) transfers the
same way, closed loop, to the tools its task uses (hooks, each `hook:HANDLE,HOOK,ANGLE`, the
camera measuring each as `choose-tool` does) in its task's worlds (`task_worlds`), by default
to the tools its task declares (`ToolTask.transfer_tools`). Open loop replays a straight
tool's tip trajectory: hooks are refused there.

A run that fails (the simulation fails, or the camera finds no tool) is recorded with its
error and counted (`failed_runs`, `sim_errors`); the experiment goes on, and the travel
figures are those of the runs that completed.
"""

from __future__ import annotations

import dataclasses as dc
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from drake_tooluse.builders.box_measurement import measure_box_start
from drake_tooluse.experiments.choices import (
    ALIGNMENTS,
    CALIBRATION_DRAWS,
    EXTRACTION_RECORDS,
    EXTRACTIONS,
    MODES,
    RECORDS,
    check_tool_kinds,
    hook_text,
    task_tools,
    tool_text,
    transfer_tool,
)
from drake_tooluse.experiments.line_contact import describe_choice, line_contact_for_task
from drake_tooluse.experiments.runs import stderr_log
from drake_tooluse.experiments.task_worlds import measure, task_scenarios
from drake_tooluse.experiments.trajectory_extraction import (
    extract,
    filter_reachable,
    plot_extraction,
    shifted,
)
from drake_tooluse.files import (
    atomic_dir,
    atomic_write_figure,
    atomic_write_json,
    check_output_dir,
)
from drake_tooluse.learning.policy_dir import check_policy_env, load_policy
from drake_tooluse.limits import MAX_CALIBRATION_DRAWS, MAX_RUNS
from drake_tooluse.paths import DEFAULT_SCENARIO, REALITY_SCENARIO, SCENARIOS_DIR
from drake_tooluse.progress import progress_bar
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import HookTool, StraightTool, tool_label
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.tasks.contract import declaration, tool_task_of
from drake_tooluse.tasks.deploy import deploy, step_limit
from drake_tooluse.tasks.push.diagram import run_open_loop
from drake_tooluse.tasks.rollout import Rollout
from drake_tooluse.validation import check_int, check_one_of, check_seed
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import Scenario, load_scenario, with_tool
from drake_tooluse.world.scene import initial_box_pose

WORLDS = ("nominal", "reality")

TRAVEL_RATIO_GOAL = 0.9
TOOL_DIFFERENCE_GOAL = 0.01  # m


@dc.dataclass
class TransferRun:
    world: str  # "nominal" or "reality"
    tool_length: float | None  # m, the truth (a straight tool; None for a hook)
    believed_length: float  # m, what the robot's IK holds (measured in reality)
    believed_grasp_along: float  # m, where it believes the hand holds the tool (measured or 0)
    seed: int
    push: Rollout | None  # None: the run failed before its push (see `error`)
    draw: dict  # the reality's perturbation (the nominal world uses only the box pose)
    error: str | None = None
    believed_box_xy: tuple | None = None  # where the replay took the box to start (box frame)
    box_xy_error: float | None = None  # m, from where it started
    tool: str = ""  # the true tool, as `robot.tool.tool_label` writes it

    @property
    def failed(self) -> bool:
        return self.push is None or self.push.sim_error

    def as_dict(self) -> dict:
        push = self.push.as_dict() if self.push is not None else {"success": False}
        error = self.error or (self.push.error if self.push is not None else None)
        return {
            "world": self.world,
            "seed": self.seed,
            "tool": self.tool,
            "tool_length_m": self.tool_length,
            "believed_length_m": self.believed_length,
            "believed_grasp_along_m": self.believed_grasp_along,
            **(
                {
                    "believed_box_xy_m": list(self.believed_box_xy),
                    "box_xy_error_m": self.box_xy_error,
                }
                if self.believed_box_xy is not None
                else {}
            ),
            **push,
            "failed": self.failed,
            **({"error": error} if error else {}),
            "perturbation": self.draw,
        }


def run_worlds(nominal: Scenario, reality: Scenario, tool, seed: int):
    """The run's two worlds holding `tool` (a length in m, or a `robot.tool` Tool), with the
    draw of `seed`: (nominal, reality, draw). The nominal world takes only the box's start."""
    reality = with_tool(reality, tool)
    draw = draw_randomization(reality, np.random.default_rng(seed))
    return (
        apply_draw(with_tool(nominal, tool), draw, box_pose_only=True),
        apply_draw(reality, draw),
        draw,
    )


def run_closed_loop(
    scenario: Scenario, policy, belief: RobotBelief, recording_path=None
) -> Rollout:
    """The loaded policy inside the diagram, for its env's step limit (`tasks.deploy.deploy`,
    `step_limit`); with `recording_path`, recorded in a new Meshcat and written there as a
    standalone HTML file."""
    return deploy(scenario, policy, belief, step_limit(policy.meta.env_id), recording_path)


def _stats(runs: list[TransferRun]) -> dict:
    """Travel and distance over the runs that completed; success over all (a failed run is
    not a success); the failures counted."""
    done = [r for r in runs if not r.failed]
    travel = np.array([r.push.object_travel for r in done])
    final = np.array([r.push.final_object_to_goal for r in done])

    def stat(values, f):
        return float(f(values)) if len(values) else None

    return {
        "runs": len(runs),
        "completed_runs": len(done),
        "failed_runs": len(runs) - len(done),
        "sim_errors": sum(r.push is not None and r.push.sim_error for r in runs),
        "object_travel_mean_m": stat(travel, np.mean),
        "object_travel_std_m": stat(travel, np.std),
        "final_object_to_goal_mean_m": stat(final, np.mean),
        "final_object_to_goal_std_m": stat(final, np.std),
        "success_rate": float(np.mean([r.push is not None and r.push.success for r in runs])),
        "per_run": [r.as_dict() for r in runs],
    }


def attempt(run, *args, **kwargs) -> tuple[object, str | None]:
    """`run(*args, **kwargs)`'s result, or (None, the error) when it fails: one run's failure
    is recorded, and the experiment goes on."""
    try:
        return run(*args, **kwargs), None
    except (RuntimeError, ValueError) as e:
        return None, f"{type(e).__name__}: {str(e).splitlines()[0][:300]}"


def _travel_text(run: TransferRun) -> str:
    if run.push is None:
        return "failed"
    return f"{run.push.object_travel * 100:.1f} cm" + (" (sim error)" if run.push.sim_error else "")


def check_same_task(nominal: Scenario, reality: Scenario) -> None:
    """The two worlds must pose the same task (box, goal, table, robot home) for their
    comparison to mean anything; raises ValueError naming what differs."""
    differ = []
    for name in (
        "box.size",
        "box.position",
        "box.yaw",
        "box.on_table",
        "goal_offset",
        "table",
        "robot.home_tip_xy",
        "robot.home_tip_height",
        "randomization.box_xy",
        "randomization.box_yaw",
    ):
        a, b = nominal, reality
        for part in name.split("."):
            a, b = getattr(a, part), getattr(b, part)
        if a != b:
            differ.append(f"{name}: nominal {a!r}, reality {b!r}")
    if differ:
        raise ValueError(
            "the nominal and reality scenarios pose different tasks: " + "; ".join(differ)
        )


def check_transfer_args(tools, runs: int, mode: str, seed: int = 0) -> list:
    """The experiment's arguments, checked; its tools as `transfer_tool` gives them."""
    check_one_of(mode, MODES, "mode")
    check_int(runs, 1, MAX_RUNS, "runs")
    check_seed(seed, "seed", runs)
    tools = [transfer_tool(t) for t in tools]
    if not tools:
        raise ValueError("give at least one tool")
    hooks = [tool_label(t) for t in tools if isinstance(t, HookTool)]
    if mode == "open-loop" and hooks:
        raise ValueError(
            f"open-loop transfer replays a straight tool's tip trajectory; {hooks[0]} is a hook "
            "(give straight tools, or --mode closed-loop)"
        )
    return tools


def task_worlds(env_id: str) -> tuple[Scenario, Scenario, Path, Path, str | None]:
    """(nominal, reality, their files, how reality differs from its file) of a transfer of
    `env_id`'s policy: its tool task's worlds (`task_worlds.task_scenarios`), else
    diagrams/push.yaml and diagrams/reality.yaml."""
    task = tool_task_of(env_id)
    if task is None:
        nominal, reality = load_scenario(DEFAULT_SCENARIO), load_scenario(REALITY_SCENARIO)
        return nominal, reality, DEFAULT_SCENARIO, REALITY_SCENARIO, None
    nominal, reality = task_scenarios(task.name)
    world = SCENARIOS_DIR / task.world
    if not task.reality_world:
        note = f"the {task.name} task's world with the reality's delay, limits and noise"
        return nominal, reality, world, REALITY_SCENARIO, note
    note = f"with the {task.name} task's goal" if task.goal_extra else None
    return nominal, reality, world, REALITY_SCENARIO, note


def run_transfer(
    policy_dir,
    tools=None,
    runs: int = 10,
    mode: str = "closed-loop",
    seed: int = 0,
    nominal_scenario: Scenario | None = None,
    reality_scenario: Scenario | None = None,
    trajectory: TipTrajectory | dict | None = None,
    log=stderr_log,
    use_grasp_estimate: bool = True,
    trust_pickle: bool = False,
    box_frame: bool = False,
) -> dict:
    """The experiment (see the module docstring). `trajectory` is the open-loop one (required
    in open-loop mode), or one per tool length ({length: trajectory}); with `box_frame` it is
    for the nominal box start, and each run's replay is moved to where that run's box starts
    (in reality as the hand camera measures it). With `use_grasp_estimate` the robot's model
    holds the camera's estimate of where the hand holds the tool along it as well as the
    length; without, the length only (the paper's measurement). `log(text)` receives a line
    per run.
    `trust_pickle` lets `policy_dir` be of the older pickle format. `tools`: straight
    tools' lengths (m) or hooks (`transfer_tool`), of the kind the policy uses; default its
    task's (`task_tools`). The worlds default to the policy's task's (`task_worlds`)."""
    policy = load_policy(policy_dir, trust_pickle=trust_pickle)
    env_id, tools = _checked_policy_and_tools(policy, tools, runs, mode, seed)
    return _run_transfer(
        policy, policy_dir, env_id, tools, runs, mode, seed, nominal_scenario,
        reality_scenario, trajectory, log, use_grasp_estimate, box_frame,
    )  # fmt: skip


def _checked_policy_and_tools(policy, tools, runs: int, mode: str, seed: int):
    """(the policy's env id, its tools) after every check of a transfer's policy and
    arguments (`check_policy_env`, `check_transfer_args`, `check_tool_kinds`)."""
    env_id, _ = check_policy_env(policy)  # as every command checks a policy and its env
    tools = check_transfer_args(task_tools(env_id) if tools is None else tools, runs, mode, seed)
    check_tool_kinds(env_id, tools)
    return env_id, tools


def _run_transfer(
    policy, policy_dir, env_id: str, tools: list, runs: int, mode: str, seed: int,
    nominal_scenario, reality_scenario, trajectory, log, use_grasp_estimate: bool,
    box_frame: bool,
) -> dict:  # fmt: skip
    """`run_transfer` of a loaded `policy` (of `policy_dir`) whose arguments are checked."""
    if mode == "open-loop" and trajectory is None:
        raise ValueError(
            "open-loop transfer needs a trajectory (experiments.trajectory_extraction.extract "
            "or TipTrajectory.load)"
        )
    task_nominal, task_reality, *_ = task_worlds(env_id)
    nominal_scenario = nominal_scenario or task_nominal
    reality_scenario = reality_scenario or task_reality
    check_same_task(nominal_scenario, reality_scenario)
    if isinstance(trajectory, dict) and not set(tools) <= set(trajectory):
        missing = sorted(set(tools) - set(trajectory))
        raise ValueError(f"no trajectory for the tool length(s) {missing} m")
    p_WB_nominal = initial_box_pose(nominal_scenario).translation()
    start = time.perf_counter()
    per_tool = []
    bar = progress_bar(len(tools) * runs, "runs", "run")  # (a terminal's stderr only)
    thing = declaration(env_id).object_name
    for tool in tools:
        label = tool_label(tool if isinstance(tool, HookTool) else StraightTool(tool))
        results = {w: [] for w in WORLDS}
        measured, grasp_errors = [], []
        tool_trajectory = trajectory.get(tool) if isinstance(trajectory, dict) else trajectory
        for i in range(runs):
            bar.update(1)
            run_seed = seed + i
            nominal, reality, draw = run_worlds(nominal_scenario, reality_scenario, tool, run_seed)
            t0 = time.perf_counter()
            measurement, measure_error = attempt(
                measure, reality, tool, run_seed, use_grasp_estimate=use_grasp_estimate
            )
            believed = None
            if measurement is not None:
                believed, measurement = measurement
                measured.append(measurement.measured_dimensions())
                grasp_errors.append(believed.grasp_offset[1] - reality.tool.grasp_offset_along)
            # The nominal world's robot knows its true tool, grasp included, and its box.
            knows = RobotBelief(tool, (0.0, nominal.tool.grasp_offset_along))
            box_xy = {"nominal": initial_box_pose(nominal).translation()[:2]}
            if mode == "open-loop" and box_frame and believed is not None:
                box, box_error = attempt(measure_box_start, reality, believed)
                if box is None:
                    believed, measure_error = None, f"box: {box_error}"
                else:
                    box_xy["reality"] = box.p_WB_xy
            for world, scenario, belief in (
                ("nominal", nominal, knows),
                ("reality", reality, believed),
            ):
                replay = tool_trajectory
                if mode == "open-loop" and box_frame and belief is not None:
                    replay = shifted(tool_trajectory, box_xy[world] - p_WB_nominal[:2])
                if belief is None:
                    push, error = None, f"measurement failed: {measure_error}"
                elif mode == "closed-loop":
                    push, error = attempt(run_closed_loop, scenario, policy, belief)
                else:
                    push, error = attempt(run_open_loop, scenario, replay, belief)
                # The nominal world takes only the box's start from the draw.
                perturbation = (
                    dc.asdict(draw)
                    if world == "reality"
                    else {"box_dxy": draw.box_dxy, "box_dyaw": draw.box_dyaw}
                )
                believed_box = box_xy.get(world) if box_frame and belief is not None else None
                truth = initial_box_pose(scenario).translation()[:2]
                results[world].append(
                    TransferRun(
                        world,
                        None if isinstance(tool, HookTool) else tool,
                        belief.tool_length if belief is not None else float("nan"),
                        belief.grasp_offset[1] if belief is not None else float("nan"),
                        run_seed,
                        push,
                        perturbation,
                        error,
                        None if believed_box is None else tuple(map(float, believed_box)),
                        None
                        if believed_box is None
                        else float(np.linalg.norm(believed_box - truth)),
                        tool=label,
                    )
                )
            n, r = results["nominal"][-1], results["reality"][-1]
            if believed is None:
                seen = f"measurement failed ({measure_error})"
            elif isinstance(tool, HookTool):
                seen = f"measured {hook_text(measurement.measured_dimensions())}"
            else:
                seen = (
                    f"measured {measurement.length:.4f} m, grasp "
                    f"{believed.grasp_offset[1] * 1000:+.1f} mm along (truth "
                    f"{reality.tool.grasp_offset_along * 1000:+.1f})"
                )
            log(
                f"tool {tool_text(tool)}, run {i + 1}/{runs}: {seen}; {thing} travel nominal "
                f"{_travel_text(n)}, reality {_travel_text(r)} ({time.perf_counter() - t0:.1f} s)"
            )
        lengths = [m["length_m"] for m in measured if "length_m" in m]
        entry = {
            "tool": label,
            "tool_length_m": None if isinstance(tool, HookTool) else tool,
            # each dimension the camera measured (`measured_dimensions`), its mean over runs
            "measured_mean": {
                name: float(np.mean([m[name] for m in measured])) for name in measured[0]
            }
            if measured
            else None,
            "measured_length_mean_m": float(np.mean(lengths)) if lengths else None,
            "measured_length_std_m": float(np.std(lengths)) if lengths else None,
            # what the robot believes of the grasp along the tool minus the truth
            "grasp_along_error_max_m": (
                float(np.max(np.abs(grasp_errors))) if grasp_errors else None
            ),
            **{w: _stats(results[w]) for w in WORLDS},
        }
        nominal_travel = entry["nominal"]["object_travel_mean_m"]
        reality_travel = entry["reality"]["object_travel_mean_m"]
        entry["travel_ratio"] = (
            reality_travel / nominal_travel
            if nominal_travel is not None and reality_travel is not None and nominal_travel > 0
            else None
        )
        per_tool.append(entry)
    bar.close()
    ratios = [t["travel_ratio"] for t in per_tool]
    travels = [t["reality"]["object_travel_mean_m"] for t in per_tool]
    difference = (
        float(max(travels) - min(travels)) if len(travels) > 1 and None not in travels else None
    )
    goals = {
        "travel_ratio_min": None if None in ratios else float(min(ratios)),
        "travel_ratio_goal": TRAVEL_RATIO_GOAL,
        "tool_travel_difference_m": difference,
        "tool_travel_difference_goal_m": TOOL_DIFFERENCE_GOAL,
    }
    goals["travel_ratio_met"] = (
        goals["travel_ratio_min"] is not None and goals["travel_ratio_min"] >= TRAVEL_RATIO_GOAL
    )
    goals["tool_difference_met"] = difference is not None and difference <= TOOL_DIFFERENCE_GOAL
    return {
        "policy": str(Path(policy_dir).absolute()),
        "env_id": env_id,
        "object_name": thing,
        "mode": mode,
        "runs": runs,
        "seed": seed,
        "use_grasp_estimate": use_grasp_estimate,
        "box_frame": box_frame,
        "tools": per_tool,
        "goals": goals,
        "failed_runs": sum(t[w]["failed_runs"] for t in per_tool for w in WORLDS),
        "sim_errors": sum(t[w]["sim_errors"] for t in per_tool for w in WORLDS),
        "wall_time_s": time.perf_counter() - start,
    }


WORLD_COLORS = {"nominal": "tab:blue", "reality": "tab:orange"}
WORLD_LABELS = {"nominal": "nominal simulation", "reality": "reality"}
TOOL_MARKERS = ("o", "s", "^", "D", "v", "P")
MARKER_SYMBOLS = {"o": "●", "s": "■", "^": "▲", "D": "◆", "v": "▼", "P": "✚"}  # for the labels
TOOL_HATCHES = ("", "//", "..", "xx", "\\\\", "++")
MIN_RUNS_FOR_BOXES = 5  # fewer runs are drawn as points: a box of 1-4 values pretends a spread


def _runs(n: int) -> str:
    return f"{n} run" if n == 1 else f"{n} runs"


def transfer_figure(result: dict) -> Figure:
    """The box travel per tool, nominal simulation beside reality (the paper's figure 7): each
    run a point (the tool's marker), over a box (the tool's hatching) when there are at least
    MIN_RUNS_FOR_BOXES runs; colour is the world."""
    fig = Figure(figsize=(1.6 + 1.9 * len(result["tools"]), 3.8))
    ax = fig.subplots()
    rng = np.random.default_rng(0)  # the points' horizontal jitter, the same every time
    ticks, labels = [], []
    for i, tool in enumerate(result["tools"]):
        marker, hatch = TOOL_MARKERS[i % len(TOOL_MARKERS)], TOOL_HATCHES[i % len(TOOL_HATCHES)]
        for j, (world, color) in enumerate(WORLD_COLORS.items()):
            values = [r["object_travel_m"] * 100 for r in tool[world]["per_run"] if not r["failed"]]
            x = 3 * i + j
            if len(values) >= MIN_RUNS_FOR_BOXES:
                parts = ax.boxplot(
                    [values],
                    positions=[x],
                    widths=0.7,
                    patch_artist=True,
                    showfliers=False,
                    medianprops={"color": "0.15"},
                )
                for box in parts["boxes"]:
                    box.set(facecolor=color, alpha=0.35, hatch=hatch, edgecolor="0.3")
            if values:
                jitter = rng.uniform(-0.12, 0.12, len(values)) if len(values) > 1 else [0.0]
                ax.scatter(
                    x + np.asarray(jitter),
                    values,
                    color=color,
                    marker=marker,
                    edgecolor="0.2",
                    linewidth=0.5,
                    s=28,
                    zorder=3,
                )
        ticks.append(3 * i + 0.5)
        name = (
            tool["tool"]
            if tool.get("tool_length_m") is None
            else f"tool {tool['tool_length_m'] * 100:.1f} cm"
        )
        labels.append(f"{name} {MARKER_SYMBOLS[marker]}")
    ax.set_xticks(ticks, labels)
    ax.set_xlim(-0.8, 3 * len(result["tools"]) - 1.2)
    ax.set_ylabel(f"{result.get('object_name', 'box')} travel (cm)")
    shape = (
        "each run a point over its box"
        if result["runs"] >= MIN_RUNS_FOR_BOXES
        else "each run a point (too few for a box)"
    )
    ax.set_title(f"{result['mode']}, {_runs(result['runs'])} per tool; {shape}", fontsize=9)
    ax.legend(
        handles=[
            Patch(facecolor=c, alpha=0.6, label=WORLD_LABELS[w]) for w, c in WORLD_COLORS.items()
        ],
        fontsize=8,
        loc="best",
    )
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def plot_transfer(result: dict, path) -> Path:
    """`transfer_figure(result)` written to `path` (PNG)."""
    return atomic_write_figure(path, transfer_figure(result))


def transfer_experiment(
    out,
    policy_dir,
    tools=None,
    runs: int = 10,
    mode: str = "closed-loop",
    seed: int = 0,
    nominal_path=None,
    reality_path=None,
    trajectory_path=None,
    episodes: int = 100,
    align: str = "start",
    use_grasp_estimate: bool = True,
    log=stderr_log,
    trust_pickle: bool = False,
    record: str | None = None,
    extraction: str = "line-contact",
    calibration_draws: int = CALIBRATION_DRAWS,
) -> dict:
    """`run_transfer` written to a new directory `out`: `transfer.json`, the box plot and, open
    loop, the trajectory: `trajectory_path` (one for every tool: with `extraction`
    `line-contact` made for the nominal box start and replayed at each run's, with `paper`
    replayed as it is), or made of the policy's
    `episodes` episodes in the nominal simulation, aligned by `align`, of the tip poses each
    step commanded or reached (`record`; default the extraction's own, EXTRACTION_RECORDS),
    the way `extraction` says (see the module docstring): `line-contact`, one trajectory per
    tool (`trajectory-<mm>mm.npz`, moved across the push to where it pushes best over
    `calibration_draws` randomized replays in the nominal simulation), or `paper`, one kept
    to the poses every tool reaches under the conservative limits (`trajectory.npz`). Everything is written into a staging
    directory that becomes `out` only when complete. Every path in the result is absolute (as
    the demo's metrics.json). `tools` and the worlds (`nominal_path`, `reality_path`) default
    to the policy's task's (`task_tools`, `task_worlds`). Returns the result."""
    policy = load_policy(policy_dir, trust_pickle=trust_pickle)
    env_id, tools = _checked_policy_and_tools(policy, tools, runs, mode, seed)
    check_int(calibration_draws, 0, MAX_CALIBRATION_DRAWS, "calibration_draws")
    check_one_of(align, ALIGNMENTS, "align")
    check_one_of(extraction, EXTRACTIONS, "extraction")
    record = EXTRACTION_RECORDS[extraction] if record is None else record
    check_one_of(record, RECORDS, "record")
    out = check_output_dir(out, "the transfer's directory")
    given = None
    if trajectory_path is not None:  # read before any work; closed loop has no use for it
        if mode != "open-loop":
            raise ValueError(
                f"trajectory_path={str(trajectory_path)!r} is replayed in open loop only; "
                f"mode={mode!r}"
            )
        given = TipTrajectory.load(trajectory_path)
    nominal, reality, nominal_file, reality_file, reality_note = task_worlds(env_id)
    if nominal_path is not None:
        nominal, nominal_file = load_scenario(nominal_path), nominal_path
    if reality_path is not None:
        reality, reality_file, reality_note = load_scenario(reality_path), reality_path, None
    # A line-contact trajectory (extracted here, or a file `drake-tooluse trajectory` wrote) is
    # made for the nominal box start: each run replays it at its own box's start.
    box_frame = mode == "open-loop" and extraction == "line-contact"
    with atomic_dir(out) as work:
        trajectory, made = None, None
        if given is not None:
            trajectory = given
            made = {
                "file": str(Path(trajectory_path).absolute()),
                "poses": len(trajectory),
                "extraction": extraction,  # how it is replayed: at each box start, or as it is
            }
        elif mode == "open-loop":
            log(f"extracting the {extraction} trajectory from {episodes} episodes …")
            ex = extract(
                policy,
                episodes=episodes,
                seed=seed,
                tool_length=tools[0],
                align=align,
                trust_pickle=trust_pickle,
                record=record,
                box_frame=box_frame,
            )
            plot_extraction(ex, work / "trajectory.png")
            made = {
                "extraction": extraction,
                "episodes": episodes,
                "align": align,
                "record": record,
                "successes": ex.successes,
                "poses": ex.reachability.poses,
            }
            if box_frame:
                trajectory, made["by_tool"] = _line_contact_trajectories(
                    ex.smoothed, tools, nominal, work, out, log, calibration_draws
                )
            else:
                trajectory = ex.reachability.kept
                reachable = {tools[0]: ex.reachability.reachable}
                for tool in tools[1:]:
                    report = filter_reachable(trajectory, tool)
                    trajectory, reachable[tool] = report.kept, report.reachable
                trajectory.save(work / "trajectory.npz")
                made["reachable_by_tool"] = {f"{t:g}": n for t, n in reachable.items()}
                made["kept"] = len(trajectory)
                made["file"] = str(out.absolute() / "trajectory.npz")
        result = _run_transfer(
            policy, policy_dir, env_id, tools, runs, mode, seed, nominal, reality, trajectory,
            log, use_grasp_estimate, box_frame,
        )  # fmt: skip
        result["nominal_scenario"] = str(Path(nominal_file).absolute())
        result["reality_scenario"] = str(Path(reality_file).absolute())
        if reality_note:
            result["reality_note"] = reality_note
        if made is not None:
            result["trajectory"] = made
        plot_transfer(result, work / "transfer_boxplot.png")
        result["figure"] = str(out.absolute() / "transfer_boxplot.png")
        result["json"] = str(out.absolute() / "transfer.json")
        atomic_write_json(work / "transfer.json", result)
    return result


def trajectory_file_name(tool: float) -> str:
    return f"trajectory-{tool * 1000:g}mm.npz"


def _line_contact_trajectories(
    base: TipTrajectory, tools, nominal: Scenario, work, out, log, calibration_draws: int
):
    """Each tool's line-contact trajectory of `base` (for the nominal box start, calibrated
    over `calibration_draws` nominal draws), written to `work`: ({length: trajectory},
    {"<length>": how it was chosen, its file})."""
    trajectories, chosen = {}, {}
    for tool in tools:
        contact = line_contact_for_task(base, tool, nominal, calibration_draws=calibration_draws)
        trajectories[tool] = contact.trajectory
        contact.trajectory.save(work / trajectory_file_name(tool))
        chosen[f"{tool:g}"] = {
            **contact.as_dict(),
            "kept": len(contact.trajectory),
            "file": str(out.absolute() / trajectory_file_name(tool)),
        }
        log(
            f"tool {tool:.3f} m: tilt {contact.tilt_deg} deg, "
            + ("followed" if contact.followed else "NOT followed")
            + f" for every box start (worst joint step {contact.worst_joint_step:.2f} rad)"
            + describe_choice(contact.as_dict())
        )
    return trajectories, chosen


def format_transfer(out: dict) -> str:
    """The result as lines of text. Two kinds of target are kept apart in the words: the env's
    success ("box at the goal", per run) and the experiment's criteria (travel kept, tools
    alike)."""
    runs = out["runs"]
    hooks = all(t.get("tool_length_m") is None for t in out["tools"])
    what = "hook" if hooks else "length and grasp" if out["use_grasp_estimate"] else "length only"
    lines = [
        f"{out['mode']}, {_runs(runs)} per tool, the robot's model from the camera's measured "
        f"{what}:"
    ]

    def cm(x) -> str:
        return "n/a" if x is None else f"{x * 100:.1f} cm"

    def spread(mean, std, done: int) -> str:  # a spread only where there is one to speak of
        if mean is None or done < 2 or std is None:
            return cm(mean)
        return f"{mean * 100:.1f} ± {std * 100:.1f} cm"

    thing = out.get("object_name", "box")
    made = out.get("trajectory", {})
    by_tool = made.get("by_tool")
    if out.get("box_frame"):
        errors = [
            x["box_xy_error_m"]
            for t in out["tools"]
            for x in t["reality"]["per_run"]
            if x.get("box_xy_error_m") is not None
        ]
        what = (
            "line contact (the commanded tip poses in each box's frame"
            if by_tool
            else f"{made['file']} (made for the nominal box start"
        )
        lines.append(
            f"  the trajectory: {what}, replayed at each run's box start"
            + (f"; the hand camera's within {max(errors) * 1000:.1f} mm)" if errors else ")")
        )
    for t in out["tools"]:
        n, r = t["nominal"], t["reality"]
        done = {w: sum(not x["failed"] for x in t[w]["per_run"]) for w in ("nominal", "reality")}
        length = t.get("tool_length_m")
        contact = (by_tool or {}).get(f"{length:g}") if length is not None else None
        tilt = (
            f", tool tilted {contact['tilt_deg']} deg"
            + ("" if contact["followed"] else " (the IK jumps on it: no tilt is followed)")
            + describe_choice(contact)
            if contact
            else ""
        )
        if t.get("measured_mean") is None and t["measured_length_mean_m"] is None:
            measured = "not measured"
        elif length is None:  # a hook: each dimension's mean
            measured = f"measured {hook_text(t['measured_mean'])}"
        else:
            measured = f"measured {t['measured_length_mean_m'] * 1000:.1f} mm"
            if done["reality"] > 1 and t["measured_length_std_m"] is not None:
                measured += f" ± {t['measured_length_std_m'] * 1000:.2f} mm"
        ratio = "n/a" if t["travel_ratio"] is None else f"{t['travel_ratio'] * 100:.0f} %"
        failed = n["failed_runs"] + r["failed_runs"]
        name = t["tool"] if length is None else f"tool {length * 1000:.0f} mm"
        lines.append(
            f"  {name} (camera {measured}): {thing} travel nominal "
            f"{spread(n['object_travel_mean_m'], n['object_travel_std_m'], done['nominal'])}, reality "
            f"{spread(r['object_travel_mean_m'], r['object_travel_std_m'], done['reality'])} "
            f"({ratio} of nominal){tilt}"
            + (f"; {failed} run(s) failed (see per_run errors)" if failed else "")
        )
        lines.append(
            f"    {thing} at the goal (the env's success) in {n['success_rate'] * 100:.0f} % of "
            f"nominal and {r['success_rate'] * 100:.0f} % of reality runs; final {thing}-goal "
            f"distance in reality {cm(r['final_object_to_goal_mean_m'])}"
        )
    g = out["goals"]
    lines.append(f"  the experiment's criteria (the skill transfers; not the {thing} at the goal):")
    if g["travel_ratio_min"] is not None:
        lines.append(
            f"    reality keeps >= {g['travel_ratio_goal'] * 100:.0f} % of the nominal {thing} "
            f"travel for every tool: {'met' if g['travel_ratio_met'] else 'not met'} (lowest "
            f"{g['travel_ratio_min'] * 100:.0f} %)"
        )
    else:
        lines.append(f"    reality/nominal {thing} travel: n/a (no completed runs)")
    if g["tool_travel_difference_m"] is not None:
        lines.append(
            f"    the tools' mean reality travel within {g['tool_travel_difference_goal_m'] * 100:g}"
            f" cm of each other: {'met' if g['tool_difference_met'] else 'not met'} (they "
            f"differ by {g['tool_travel_difference_m'] * 100:.2f} cm)"
        )
    else:
        lines.append("    the tools' travel alike: n/a (needs two tools)")
    lines.append(f"  {out['json']}, {out['figure']} ({out['wall_time_s']:.0f} s)")
    return "\n".join(lines)
