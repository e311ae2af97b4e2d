"""The robot chooses its tool (Brown & Sammut's "choose the tool"): given a task instance and
a rack of tools, it measures each tool with the head camera, predicts how well each would do
by rolling out that tool's policy in its own nominal simulation of the measured tool, takes
the best, and does the task with it in the perturbed "reality".

- **Task instances** (`TaskInstance`, seeded), of the tasks the task packages declare
  (`tasks.contract.ToolTask`, read by `task_worlds.task_scenarios`, `no_policy_reason`, `Policies`): `push` (the push world, `diagrams/push.yaml`,
  goal 0.20 m along y), `push-far` (the same, goal 0.10 m further: ToolPushFar-v1's) and
  `pull` (`diagrams/pull.yaml`: a cube beyond the bare gripper's reach, pulled 0.20 m
  back). The seed draws the instance's randomization (`world.randomization`): the box's
  start, and in reality its mass, friction and the grasp of whichever tool is held.
- **Reality** is the transfer experiment's (`experiments.transfer.run_worlds`): for a push,
  `diagrams/reality.yaml`; for the pull, `diagrams/pull.yaml` with what reality.yaml changes
  (actuation delay, conservative joint limits, camera noise) — `pull_reality`.
- **Policies per (task, tool kind)** (`ToolPolicy`, the interface a learned policy plugs
  into; `Policies`): a straight tool pushes with the shipped tool-tip policy
  (`paths.TRANSFER_POLICY`), and to the far goal with that policy fine-tuned on
  ToolPushFar-v1 (`paths.FAR_PUSH_POLICY`); a hook pulls with the shipped hook policy
  (`paths.PULL_POLICY`, `LearnedPolicy`; `ScriptedPolicy` runs a task's scripted
  reference). No policy exists for a hook pushing or a straight tool pulling (the pull's
  control acts on a hook's inner corner, which a straight tool lacks): such a candidate is
  predicted 0 with that reason, and the oracle counts it 0 too (the robot has no way to use
  it).
- **Prediction**: the tool measured in reality (`measure_belief`, `measure_hook_belief`),
  then K rollouts in the nominal world holding the *measured* tool (the instance's box start;
  each rollout its own draw of the nominal mass, friction and grasp) → predicted success rate
  and mean final distance. The robot does not know reality's actuation delay; with a
  `delay_margin` (default DELAY_MARGIN) its rollouts span delays from 0 to the margin
  (`rollout_delays`), so a tool whose success hangs on prompt actuation is predicted to
  fail sometimes (measured: the long J-hook's scripted pull succeeds without a delay and
  fails with reality's 40 ms). `delay_margin=0` predicts in the plain nominal world. The
  choice is the highest rate, ties broken by the nearer mean final distance.
- **The oracle** runs every tool in reality on the same instance (the same draw); the chosen
  tool's reality run is the oracle's run of that tool (the worlds are deterministic).
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from pathlib import Path
from typing import NamedTuple, Protocol

import numpy as np

from drake_tooluse.builders.shape_measurement import measure_shape_belief
from drake_tooluse.experiments.choices import DEFAULT_ROLLOUTS
from drake_tooluse.experiments.parallel import map_forked
from drake_tooluse.experiments.task_worlds import (
    TASKS,
    TOOL_TASKS,
    holding,
    measure,
    task_scenarios,
)
from drake_tooluse.experiments.transfer import attempt, run_worlds
from drake_tooluse.learning.policy_dir import check_policy_env, load_policy
from drake_tooluse.limits import MAX_ROLLOUTS, MAX_WORKERS
from drake_tooluse.paths import POLICIES_DIR
from drake_tooluse.progress import progress_bar
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import HookTool, StraightTool, parse_tool, tool_label
from drake_tooluse.robot.tool_generator import (
    FAMILIES,
    GeneratedTool,
    equivalent_hook,
    generate_tool,
    held_out_region,
    measured_tool,
)
from drake_tooluse.tasks.contract import declaration, scripted_reference
from drake_tooluse.tasks.deploy import deploy, run_controller
from drake_tooluse.validation import check_in_range, check_int, check_one_of, check_seed
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import Scenario, validate_scenario

MIN_TOOLS, MAX_TOOLS = 1, 5
# Which tool succeeds depends on the task and the instance: a very short straight tool
# (misses some pushes), a long one, an L-hook, and a long J-hook the scripted pull succeeds
# with in the nominal simulation but not in reality (benchmarks/tool_choice.py).
DEFAULT_RACK = (
    StraightTool(0.03),
    StraightTool(0.30),
    HookTool(0.25, 0.05, 90.0),
    HookTool(0.35, 0.08, 60.0),
)
# The nominal rollouts' draws: seeded apart from the instance seeds (which draw reality).
ROLLOUT_SEED_STRIDE = 1000
ROLLOUT_SEED_BASE = 10_000_000
# s: the actuation delay the robot budgets for in its rollouts (1.5 control periods; it
# does not know reality's).
DELAY_MARGIN = 0.06
MAX_DELAY_MARGIN = 0.2  # s, the scenario's limit


@dc.dataclass(frozen=True)
class TaskInstance:
    """One task to do: its kind (TASKS) and the seed of its draw."""

    task: str
    seed: int = 0

    def __post_init__(self):
        check_one_of(self.task, TASKS, "task")
        check_seed(self.seed, "seed")


def check_rack(rack) -> tuple:
    rack = tuple(parse_tool(t) if isinstance(t, str) else t for t in rack)
    if not MIN_TOOLS <= len(rack) <= MAX_TOOLS:
        raise ValueError(f"the rack holds {len(rack)} tools; give {MIN_TOOLS} to {MAX_TOOLS}")
    for tool in rack:
        if not isinstance(tool, (StraightTool, HookTool, GeneratedTool)):
            raise ValueError(f"tool {tool!r} must be a StraightTool, a HookTool or a GeneratedTool")
    return rack


def generated_rack(seed: int, size: int = MAX_TOOLS) -> tuple:
    """`size` tools the policies never trained with, each of another family: the held-out
    family drawn anywhere in its ranges, every other family in its corner
    (`robot.tool_generator.split_draw`'s "held_out" split), drawn with `seed`."""
    check_int(size, MIN_TOOLS, min(MAX_TOOLS, len(FAMILIES)), "rack size")
    rng = np.random.default_rng(check_seed(seed, "rack seed"))
    families = rng.choice(list(FAMILIES), size, replace=False)
    return tuple(generate_tool(f, int(rng.integers(2**32)), held_out_region(f)) for f in families)


# -- the policies ------------------------------------------------------------------------


@dc.dataclass
class Outcome:
    """One run of a tool on a task: from the world's truth."""

    success: bool
    final_distance: float  # m, the object (box or cube) from the goal
    error: str | None = None

    def as_dict(self) -> dict:
        return {
            "success": self.success,
            "final_distance_m": self.final_distance,
            **({"error": self.error} if self.error else {}),
        }


class ToolPolicy(Protocol):
    """A way to do a task with a kind of tool: `run(scenario, belief)` in a world holding the
    true tool, the robot's IK holding `belief`, gives the run (`tasks.rollout.Rollout`:
    `success`, `final_object_to_goal`, `error`, …); `run(..., recording_path=FILE)` also writes
    the run's Meshcat recording as a standalone HTML file (asked of the chosen tool's run)."""

    def run(self, scenario: Scenario, belief: RobotBelief, recording_path=None): ...


class LearnedPolicy:
    """A task's learned policy (a policy directory), deployed inside its task's diagram as its
    env wired it (`tasks.deploy.deploy`), run to the step limit and judged where the object
    ends."""

    def __init__(self, policy_dir, trust_pickle: bool = False):
        self.policy = load_policy(policy_dir, trust_pickle=trust_pickle)
        env_id, _ = check_policy_env(self.policy)
        self.env_id = env_id
        self.directory = Path(policy_dir)
        self.name = f"policy {self.directory.name}"

    def run(self, scenario: Scenario, belief: RobotBelief, recording_path=None, **options):
        """The run (`tasks.rollout.Rollout`); `options`: `tasks.deploy.deploy`'s `max_steps`
        (default the envs' step limit), `meshcat`, `scene_camera` and `on_step`."""
        return deploy(scenario, self.policy, belief, recording_path=recording_path, **options)


class ScriptedPolicy:
    """A task's scripted reference (`tasks.contract.scripted_reference`), on the control of
    `env_id` (one of the task's ids)."""

    def __init__(self, env_id: str):
        scripted_reference(env_id, 0.0)  # a task that declares none fails here
        self.env_id = env_id
        self.name = f"scripted {declaration(env_id).name}"

    def run(self, scenario: Scenario, belief: RobotBelief, recording_path=None, **options):
        """The run (`tasks.rollout.Rollout`); `options` as `LearnedPolicy.run`'s."""
        controller, kwargs = scripted_reference(self.env_id, scenario.table.top_z)
        return run_controller(
            self.env_id,
            scenario,
            controller,
            belief,
            recording_path=recording_path,
            env_kwargs=kwargs,
            **options,
        )


def no_policy_reason(task: str, tool) -> str | None:
    """Why the robot has no way to do `task` with `tool` (its policy uses another kind of
    tool: `ToolTask.tool_kind`), or None when it has one. A generated tool
    (`robot.tool_generator`) serves a task whose policy is a straight tool's (it acts through
    the tip frame or the push point, which every tool has) and a hook's where its family is
    one the task's policy serves (`ToolTask.shape_families`)."""
    declared = TOOL_TASKS[task]
    if isinstance(tool, GeneratedTool):
        families = declared.shape_families
        if families is None or tool.family in families:
            return None
        return (
            f"no {task} policy for a tool of the {tool.family} family (it serves the "
            f"{' and '.join(families)} families)"
        )
    kind = "hook" if isinstance(tool, HookTool) else "straight"
    if kind == declared.tool_kind:
        return None
    what = "a hook" if kind == "hook" else "a straight tool"
    return f"no {task} policy for {what} ({declared.why_not})"


class Policies:
    """The policy for each task (by its name in TASKS, `-` written `_`: `push_far=`): a
    ToolPolicy, a policy directory, or None for the shipped one (`ToolTask.policy`, or for a
    generated tool `ToolTask.shapes_policy` where the task has one); a directory is loaded
    once, on first use."""

    def __init__(self, **by_task):
        self._policies = {name.replace("_", "-"): policy for name, policy in by_task.items()}
        unknown = sorted(set(self._policies) - set(TASKS))
        if unknown:
            raise ValueError(f"no task {unknown[0]!r}; the tasks: {list(TASKS)}")
        self._loaded = {}

    def for_task(self, task: str, generated: bool = False) -> ToolPolicy:
        """`task`'s policy, for a generated tool where `generated`."""
        given = self._policies.get(task)
        if given is not None and not isinstance(given, (str, Path)):
            return given
        declared = TOOL_TASKS[task]
        name = declared.shapes_policy if generated and declared.shapes_policy else declared.policy
        directory = Path(given or POLICIES_DIR / name)
        if directory not in self._loaded:
            self._loaded[directory] = LearnedPolicy(directory)
        return self._loaded[directory]


# -- measuring, predicting, choosing -----------------------------------------------------


def believed_tool_label(belief: RobotBelief) -> str:
    return tool_label(belief.tool)


def clamped(belief: RobotBelief, measurement) -> dict:
    """The figures the camera measured just past their range, which the belief holds at the
    range's end: {name: [measured, believed]} (empty where none was)."""
    believed = belief.tool.dimensions()
    return {
        name: [float(value), float(believed[name])]
        for name, value in measurement.measured_dimensions().items()
        if abs(value - believed[name]) > 1e-9
    }


def rack_label(tool) -> str:
    """A rack tool's name: `straight:0.3`, `hook:0.25,0.05,90`, `rake#3` (`robot.tool_generator`)."""
    return tool.label() if isinstance(tool, GeneratedTool) else tool_label(tool)


def believed_tool(task: str, measured: GeneratedTool):
    """The tool the robot's IK holds for `task` after measuring a generated tool: the measured
    tool, or for a task of hooks (`ToolTask.tool_kind`) its equivalent hook
    (`robot.tool_generator.equivalent_hook`), the `robot.tool.HookTool` the pull's control
    needs."""
    if TOOL_TASKS[task].tool_kind != "hook":
        return measured.tool
    return equivalent_hook(measured)


def measure_generated(reality: Scenario, seed: int, family: str | None = None):
    """(the tool held in `reality` as the head camera measures it, `measure_shape_belief`: a
    GeneratedTool of the fitted family and parameters; the grasp measured, (across, along)
    m). `family`, where an earlier measurement named it, is the only one fitted. Raises
    ValueError where the tool fits no family."""
    belief, result = measure_shape_belief(
        reality, seed=seed, families=None if family is None else (family,)
    )
    best = result.shape.best
    return measured_tool(best.family, best.params), belief.grasp_offset


def measured_belief(task: str, reality: Scenario, seed: int, family: str | None = None):
    """(what the robot believes for `task` of the generated tool it holds in `reality`, once
    the head camera measured it (`measure_generated`; `family` as there); the measured
    tool). A chosen tool is measured so again in the hand, its family known from the rack's
    measurement, for the grasp it is held at."""
    measured, grasp = measure_generated(reality, seed, family)
    return RobotBelief(believed_tool(task, measured), grasp), measured


def measure_rack(task: str, rack, seed: int = 0) -> dict:
    """Each generated tool of `rack` measured once by the head camera (`measure_generated`),
    held in `task`'s reality with the grasp of `seed`'s draw: the robot knows its rack's
    shapes before it chooses. {rack index: (the measured tool or None, the error or None)}."""
    nominal, reality = task_scenarios(task)
    shapes = {}
    for i, tool in enumerate(check_rack(rack)):
        if isinstance(tool, GeneratedTool):
            world = run_worlds(nominal, reality, tool, seed)[1]
            measured, error = attempt(measure_generated, world, seed)
            shapes[i] = (None if measured is None else measured[0], error)
    return shapes


def run_outcome(policy: ToolPolicy, scenario: Scenario, belief: RobotBelief) -> Outcome:
    """The outcome of `policy.run(scenario, belief)`; a run that raises (RuntimeError,
    ValueError) is a failure with its error, and the caller goes on."""
    run, error = attempt(policy.run, scenario, belief)
    if run is None:
        return Outcome(False, math.nan, error)
    return Outcome(run.success, run.final_object_to_goal, run.error)


def rollout_delays(rollouts: int, delay_margin: float, time_step: float) -> list[float]:
    """The actuation delay of each rollout (s): evenly from 0 to `delay_margin` (the margin
    alone for one rollout), each the nearest multiple of the plant's `time_step`, never past
    the margin (a margin of 0.03 s with 0.02 s steps gives delays up to 0.02 s, not 0.04)."""
    fractions = np.linspace(0.0, 1.0, rollouts) if rollouts > 1 else [1.0]
    most = math.floor(delay_margin / time_step + 1e-9)
    return [min(round(f * delay_margin / time_step), most) * time_step for f in fractions]


def prediction_worlds(
    nominal: Scenario,
    belief: RobotBelief,
    rollouts: int,
    seed: int,
    delay_margin: float = DELAY_MARGIN,
    held=None,
) -> list[tuple[Scenario, float]]:
    """The worlds of K rollouts in the nominal world holding the believed tool (`held`, where
    it is not the belief's: a measured GeneratedTool) where the robot believes it holds it,
    each with its own draw of the nominal mass, friction and grasp (the box's start is the
    instance's) and its own actuation delay (`rollout_delays`): [(world, delay s)]."""
    world = holding(nominal, held or belief.tool, belief.grasp_offset[1])
    worlds = []
    for k, delay in enumerate(rollout_delays(rollouts, delay_margin, world.plant.time_step)):
        rng = np.random.default_rng(ROLLOUT_SEED_BASE + seed * ROLLOUT_SEED_STRIDE + k)
        draw = draw_randomization(world, rng)
        draw.box_dxy, draw.box_dyaw = [0.0, 0.0], 0.0  # the instance's box start
        rollout = apply_draw(world, draw)
        rollout = validate_scenario(
            dc.replace(rollout, control=dc.replace(rollout.control, actuation_delay=delay))
        )
        worlds.append((rollout, delay))
    return worlds


class PredictedRollout(NamedTuple):
    """One rollout of a choice's predictions: the rack candidate it predicts, the policy, the
    world (`prediction_worlds`), the robot's belief and the world's actuation delay (s)."""

    candidate: int
    policy: ToolPolicy
    world: Scenario
    belief: RobotBelief
    delay: float


def prediction(outcomes: list[Outcome], delays: list[float]) -> dict:
    """The predicted success rate and mean final distance of a tool's rollouts."""
    finals = [o.final_distance for o in outcomes if math.isfinite(o.final_distance)]
    return {
        "predicted_success": float(np.mean([o.success for o in outcomes])),
        "predicted_final_distance_m": float(np.mean(finals)) if finals else None,
        "rollouts": [{**o.as_dict(), "actuation_delay_s": d} for o, d in zip(outcomes, delays)],
    }


def _rank_key(candidate: dict):
    final = candidate["predicted_final_distance_m"]
    return (-candidate["predicted_success"], math.inf if final is None else final)


def choose_tool(
    instance: TaskInstance | str = "pull",
    rack=DEFAULT_RACK,
    rollouts: int = DEFAULT_ROLLOUTS,
    seed: int = 0,
    oracle: bool = False,
    policies: Policies | None = None,
    delay_margin: float = DELAY_MARGIN,
    recording_path=None,
    progress: bool = True,
    rack_shapes: dict | None = None,
    workers: int = 1,
) -> dict:
    """Measures each tool of the rack, predicts its success (`rollouts` rollouts each,
    `prediction_worlds`: actuation delays up to `delay_margin` s, run by up to `workers`
    processes, `experiments.parallel.map_forked`), chooses the best and does the instance with
    it in reality. `instance` is a TaskInstance or a task kind (TASKS, then drawn with `seed`).

    A rod or a hook is measured on the instance, by its marker bands. A generated tool's
    shape comes from `rack_shapes` (`measure_rack`: the rack measured once, before any
    choice; measured here with the instance's seed where not given, its time apart from the
    choice's) and is predicted at the nominal grasp; the chosen one is measured again in the
    hand, its family known, for the grasp it is held at.

    With `oracle`, every tool is also run in reality (`oracle_success`: whether any tool
    succeeds). With `recording_path`, the chosen tool's run in reality is recorded in Meshcat
    and written there as a standalone HTML file. `progress`: a bar on stderr (a terminal
    only) over the tools' predictions and reality runs. Returns a dict (see `format_choice`)."""
    if not isinstance(instance, TaskInstance):
        instance = TaskInstance(instance, seed)
    rack = check_rack(rack)
    check_int(rollouts, 1, MAX_ROLLOUTS, "rollouts")
    check_int(workers, 1, MAX_WORKERS, "workers")
    check_in_range(delay_margin, 0.0, MAX_DELAY_MARGIN, "delay_margin", unit="s")
    policies = policies or Policies()
    nominal, reality = task_scenarios(instance.task)
    for tool in rack:  # a tool the world cannot hold is refused before any work
        if no_policy_reason(instance.task, tool) is None:
            holding(nominal, tool)
    rack_measure_time = 0.0
    if rack_shapes is None and any(isinstance(t, GeneratedTool) for t in rack):
        start = time.perf_counter()
        rack_shapes = measure_rack(instance.task, rack, instance.seed)
        rack_measure_time = time.perf_counter() - start
    start = time.perf_counter()
    candidates = []
    worlds = {}
    runs: list[PredictedRollout] = []
    bar = progress_bar(len(rack) * (2 if oracle else 1) + int(not oracle), "tools", "", progress)
    for i, tool in enumerate(rack):
        bar.update(1)
        candidate = {"tool": rack_label(tool)}
        candidates.append(candidate)
        if isinstance(tool, GeneratedTool):
            held, error = rack_shapes[i]
            reason = no_policy_reason(instance.task, held) if error is None else error
        else:
            held, reason = None, no_policy_reason(instance.task, tool)
        if reason is not None:
            candidate.update(predicted_success=0.0, predicted_final_distance_m=None, reason=reason)
            continue
        nominal_world, reality_world = run_worlds(nominal, reality, tool, instance.seed)[:2]
        worlds[i] = (nominal_world, reality_world)
        if held is not None:
            belief = RobotBelief(believed_tool(instance.task, held), (0.0, 0.0))
            candidate["believed"] = f"{held.family} {_params_text(held.params)}"
            candidate["_held"] = held
        else:
            measured, error = attempt(measure, reality_world, tool, instance.seed)
            if measured is None:
                candidate.update(
                    predicted_success=0.0,
                    predicted_final_distance_m=None,
                    reason=f"measurement failed: {error}",
                )
                continue
            belief = measured[0]
            candidate["clamped"] = clamped(*measured)
            candidate["believed"] = believed_tool_label(belief)
            candidate["believed_grasp_along_m"] = belief.grasp_offset[1]
            candidate["_belief"] = belief
        policy = policies.for_task(instance.task, generated=held is not None)
        for world, delay in prediction_worlds(
            nominal_world, belief, rollouts, instance.seed, delay_margin, held=held
        ):
            runs.append(PredictedRollout(i, policy, world, belief, delay))
    # Every tool's rollouts, on the cores given (each seeded: the same for any `workers`).
    outcomes = map_forked(lambda r: run_outcome(r.policy, r.world, r.belief), runs, workers)
    for i, candidate in enumerate(candidates):
        mine = [(o, r.delay) for o, r in zip(outcomes, runs) if r.candidate == i]
        if mine:
            candidate.update(prediction([o for o, _ in mine], [d for _, d in mine]))
    choice_time = time.perf_counter() - start
    chosen = min(range(len(candidates)), key=lambda i: _rank_key(candidates[i]))
    for i, candidate in enumerate(candidates):
        if oracle or i == chosen:
            bar.update(1)
            candidate["reality"] = _reality_run(
                instance,
                candidate,
                worlds.get(i),
                policies,
                recording_path if i == chosen else None,
            )
    bar.close()
    result = {
        "task": instance.task,
        "seed": instance.seed,
        "rollouts": rollouts,
        "delay_margin_s": delay_margin,
        # The delays the rollouts ran with (multiples of the plant step, up to the margin).
        "rollout_delays_s": rollout_delays(rollouts, delay_margin, nominal.plant.time_step),
        "chosen": candidates[chosen]["tool"],
        "chosen_index": chosen,
        "success": candidates[chosen]["reality"]["success"],
        "final_distance_m": candidates[chosen]["reality"]["final_distance_m"],
        "choice_time_s": choice_time,
        "rack_measure_time_s": rack_measure_time,
        "wall_time_s": time.perf_counter() - start,
        "candidates": [{k: v for k, v in c.items() if not k.startswith("_")} for c in candidates],
    }
    if candidates[chosen]["reality"].get("recording"):
        result["recording"] = candidates[chosen]["reality"]["recording"]
    if oracle:
        result["oracle_success"] = any(c["reality"]["success"] for c in candidates)
        result["oracle_tools"] = [c["tool"] for c in candidates if c["reality"]["success"]]
    return result


def _params_text(params: dict) -> str:
    return ", ".join(f"{k} {v:.3g}" for k, v in params.items() if k != "radius")


def _reality_run(instance, candidate, worlds, policies: Policies, recording_path=None) -> dict:
    """The candidate's run in reality, with the belief the camera gave (recorded to
    `recording_path` if given); a tool the robot has no way to use (or could not measure) is
    not run and counts as a failure."""
    belief, held = candidate.get("_belief"), candidate.get("_held")
    if worlds is None or (belief is None and held is None):
        return {"success": False, "final_distance_m": None, "run": False}
    if held is not None:
        measured, error = attempt(
            measured_belief, instance.task, worlds[1], instance.seed, held.family
        )
        if measured is None:
            return {**Outcome(False, math.nan, error).as_dict(), "run": False}
        belief = measured[0]
    recording = {} if recording_path is None else {"recording_path": recording_path}
    policy = policies.for_task(instance.task, generated=held is not None)
    run, error = attempt(policy.run, worlds[1], belief, **recording)
    if run is None:  # the run raised: nothing was written
        return {**Outcome(False, math.nan, error).as_dict(), "run": True}
    outcome = Outcome(run.success, run.final_object_to_goal, run.error)
    recorded = {} if recording_path is None else {"recording": str(recording_path)}
    return {**outcome.as_dict(), "run": True, **recorded}


def _clamped_text(figures: dict) -> str:
    """ ", the angle measured 61.3 and taken as 60" for each figure clamped to its range."""
    return "".join(
        f", {name.rpartition('_')[0].replace('_', ' ')} measured {measured:.4g} and taken as "
        f"{believed:g}"
        for name, (measured, believed) in figures.items()
    )


def format_choice(out: dict) -> str:
    lines = [
        f"{out['task']} (seed {out['seed']}), {out['rollouts']} predicted rollouts per tool "
        f"(actuation delays up to {max(out['rollout_delays_s']) * 1000:.0f} ms):"
    ]
    for i, c in enumerate(out["candidates"]):
        mark = "*" if i == out["chosen_index"] else " "
        final = c["predicted_final_distance_m"]
        text = f" {mark} {c['tool']:<24} predicted success {c['predicted_success'] * 100:3.0f} %"
        if final is not None:
            text += f", final distance {final * 100:.1f} cm"
        if "believed" in c:
            text += f" (measured {c['believed']}{_clamped_text(c.get('clamped', {}))})"
        if "reason" in c:
            text += f" ({c['reason']})"
        if "reality" in c and c["reality"]["run"]:
            text += f"; reality: {'success' if c['reality']['success'] else 'failed'}"
        lines.append(text)
    measuring = out.get("rack_measure_time_s") or 0.0
    lines.append(
        f"chosen: {out['chosen']}; in reality "
        f"{'succeeded' if out['success'] else 'failed'} ({out['choice_time_s']:.0f} s to choose"
        + (f", after {measuring:.0f} s measuring the rack's shapes)" if measuring else ")")
    )
    if "oracle_success" in out:
        lines.append(f"oracle: {', '.join(out['oracle_tools']) or 'no tool'} succeeds")
    if "recording" in out:
        lines.append(f"the chosen tool's run: open {out['recording']} in a browser")
    return "\n".join(lines)
