"""The pull task as a Gymnasium env on DrakeGymEnv: `drake_tooluse/ToolPull-v1`.

```
action ──► TipTargetSystem ──X_WC*──► ToolTipIKSystem ──q*──► plant (in-plant PD) ──state──►
           (hook-corner space)        (robot model: the believed hook)        ToolPullObservation ──► observation
```
"""

from __future__ import annotations

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.task_gym_env import TaskGymEnv, ViewOptions, check_views, has_views
from drake_tooluse.paths import PULL_SCENARIO
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import HookTool
from drake_tooluse.robot.tool_generator import SPLITS, equivalent_hook, generate_tool, split_draw
from drake_tooluse.systems.tip_target import ACTION_MODES
from drake_tooluse.tasks.contract import TaskEnv, env_config
from drake_tooluse.tasks.pull.diagram import add_pull_task
from drake_tooluse.tasks.pull.hook import check_hook, draw_hook
from drake_tooluse.tasks.pull.metrics import PULL_EPISODE_METRICS, PullMetricsReader, reward
from drake_tooluse.tasks.pull.observation import OBSERVATION_SIZE
from drake_tooluse.tasks.pull.registration import SHAPE_FAMILIES, TASK
from drake_tooluse.tasks.rollout import step_info
from drake_tooluse.tasks.sanity import PHYSICAL_LIMITS, PhysicalSanityReader
from drake_tooluse.validation import all_finite, check_bool, check_mapping, check_one_of
from drake_tooluse.world.scenario import (
    Scenario,
    check_delay_range,
    delay_choices,
    load_scenario,
    validate_scenario,
    with_drawn_delay,
    with_tool,
)

ACTION_SIZE = ACTION_MODES["position"]


@dc.dataclass
class PullEnvConfig(ViewOptions):
    """The keyword arguments of `ToolPullEnv` (and of `gym.make`): the views every task's env
    takes (`ViewOptions`), then the pull task's."""

    scenario: object = None  # a Scenario, a YAML path, or None for diagrams/pull.yaml
    # (handle length m, hook length m, angle °): every episode's hook; None: drawn per episode.
    hook: tuple | None = None
    randomize: bool = True  # the cube's start, mass, friction and the grasp (`randomization`)
    # "training" or "held_out": each episode's tool a hook or an arc the tool generator draws
    # from that split, held as its equivalent hook (not with `hook`).
    generated_tools: str | None = None
    # [lo, hi] s: each episode's actuation delay (joint targets reaching the motors late)
    # drawn uniformly among the plant-step multiples in it, replacing the scenario's
    # `control.actuation_delay`: domain randomization for a robot whose delay is not known.
    actuation_delay_range: list | None = None


def _scenario(config: PullEnvConfig) -> Scenario:
    """The env's world before its hook: diagrams/pull.yaml, or the `scenario` given."""
    if config.scenario is None:
        return load_scenario(PULL_SCENARIO)
    if isinstance(config.scenario, Scenario):
        return validate_scenario(config.scenario)
    return load_scenario(Path(config.scenario))


def _config(kwargs, name: str = "env kwargs") -> PullEnvConfig:
    kwargs = dict(check_mapping(kwargs, name))
    config = env_config(PullEnvConfig, kwargs, name, "the pull env")
    if config.hook is not None:
        config.hook = check_hook(config.hook, "hook")
    check_bool(config.randomize, "randomize")
    if config.generated_tools is not None:
        check_one_of(config.generated_tools, SPLITS, "generated_tools")
        if config.hook is not None:
            raise ValueError("give generated_tools or a hook, not both")
    if config.actuation_delay_range is not None:
        config.actuation_delay_range = check_delay_range(config.actuation_delay_range)
    check_views(config, (None, "rgb_array"))
    if config.scenario is not None and not isinstance(config.scenario, (Scenario, str, Path)):
        raise ValueError(
            f"scenario={config.scenario!r} must be a Scenario, a YAML file name or None"
        )
    return config


def with_hook(scenario: Scenario, hook) -> Scenario:
    """A copy of `scenario` holding the hook (handle length m, hook length m, angle °)."""
    return with_tool(scenario, HookTool(*check_hook(hook)))


class ToolPullEnv(TaskEnv, TaskGymEnv):
    """Pull a cube from beyond the bare gripper's reach to a goal near the robot with a hook.

    ## Description

    Baxter holds a hook (`robot.tool.HookTool`: a handle, and at its end a hook at an angle)
    in its right hand. A 4 cm cube rests on the table beyond where the bare gripper reaches:
    its centre 1.17 m out, no point of it nearer than 1.131 m, where the gripper frame (in
    any orientation) reaches 1.106 m at the cube's mid-height and 1.117 m at its top
    (tests/tasks/pull/test_reach.py). The robot reaches over and behind the cube
    with the hook, its inner corner behind the cube's far face, and pulls the cube 0.20 m
    towards itself, to the goal. The hook is held as a rake (`tasks.pull.hook`): the handle
    pointing away from the robot, tilted 30° down, the hook hanging below it. Each episode
    holds a hook drawn from HookTool's ranges (handle 0.15–0.35 m, hook 0.03–0.08 m, angle
    60–120°) with the env's seeded generator, unless `hook` fixes it; the robot knows its
    hook's geometry (its belief is the truth; the grasp is not: `randomize` shifts it).

    ## Action Space

    `Box(-1.0, 1.0, (3,), float32)`: the change of the hook corner's position (x, y, z in W)
    per step, 0.02 m at an action of ±1, from where the corner is now (the push envs' `position`
    mode); the orientation is held. The exact IK on the robot model of the believed hook
    turns the corner's target into joint targets. The target stays over the table, and high
    enough that the believed hook's end clears the table top (`diagram.corner_workspace`).

    ## Observation Space

    `Box(-inf, inf, (16,), float32)`:

    | index | observation | unit |
    | --- | --- | --- |
    | 0–2 | goal x* of the cube's centre | m |
    | 3–5 | cube centre x | m |
    | 6 | cube yaw, folded into [−π/4, π/4) | rad |
    | 7–9 | hook corner c (the believed hook, on the measured joint angles) | m |
    | 10–12 | hook corner velocity | m/s |
    | 13 | believed handle length | m |
    | 14 | believed hook length | m |
    | 15 | believed hook angle | rad |

    Positions in W (Baxter's base frame: x forward, y left, z up).

    ## Rewards

    Dense: r = −(d(x, x*) + d(c, p_b)) per step (m), where c is the true hook's inner corner
    and p_b = x + (w/2 + r_h) ê the point just behind the cube's far face (w the cube's side,
    r_h the hook's radius, ê the horizontal unit vector from the goal to the cube's start):
    the push task's reward (the paper's) with the hook's corner, behind the cube, as the
    tool point.

    ## Starting State

    The hook's corner 0.12 m above the table at (1.05, −0.25) m, between the goal and the
    cube; the cube's
    centre at (1.17, −0.25) m ± 0.015 m in x and y, its yaw ± 0.2 rad, its mass 0.2 kg and
    friction 0.4 each scaled by a draw in [0.7, 1.3], the true grasp shifted ± 0.01 m along
    the handle and ± 0.005 m across it (`randomize=True`, the default; `randomize=False`:
    the nominal start). The goal is the cube's start moved 0.20 m towards the robot (−x).

    ## Episode End

    Truncation at 100 steps of 40 ms (the registered `max_episode_steps`); there is no early
    termination: an episode is judged where it ends, so a policy must pull the cube to the
    goal and leave it there. Success (`info["is_success"]`, every step): d(x, x*) ≤ 0.05 m
    and the cube moved at least 0.10 m from its start; every start lies 0.20 m from its goal,
    so no episode succeeds unless the cube moves. A simulation failure truncates the episode
    with `info["sim_error"] = True` and the last finite observation and reward.

    ## Arguments

    `gym.make("drake_tooluse/ToolPull-v1", hook=None, randomize=True, scenario=None,
    generated_tools=None, actuation_delay_range=None, render_mode=None, meshcat=None)`:
    `hook` = (handle length m, hook length m, angle °) fixes every episode's hook (each in
    HookTool's range);
    `generated_tools` = "training" or "held_out" holds instead a hook or an arc the tool
    generator draws from that split each episode (`robot.tool_generator.split_draw` with
    the task's shape families), the robot believing its equivalent hook (the observation's
    hook geometry is that hook's); `randomize` draws the start (above);
    `actuation_delay_range` = [lo, hi] s, in [0, 0.2], draws each episode's actuation delay
    uniformly among the plant-step multiples in it (the robot is not told; as the push env's);
    `scenario` replaces diagrams/pull.yaml (a Scenario or a YAML file); `render_mode`
    "rgb_array" renders a scene camera framed by `render_size`, `render_camera_position` and
    `render_camera_target` (as the push env's, with the goal drawn); `meshcat` draws the
    episodes in a Meshcat (a live view; `start_recording`, `save_recording`).

    ## Info

    `is_success`, `object_to_goal` (m), `object_travel` (m, horizontal), `corner_to_behind`
    (m, d(c, p_b)), `tool_touches_object`, `gripper_touches_object` (this step),
    `tool_touched_object_in_episode`, `gripper_touched_object_in_episode`, `hook` (handle m,
    hook m, angle °), `ik_ok` (the IK's last solve succeeded), `sim_error`, and the physical
    sanity every task reports (`tasks.sanity`): `tool_table_penetration`,
    `gripper_table_penetration` (m), `object_speed` (m/s), `arm_joint_speed` (rad/s) and their
    flags `tool_in_table`, `gripper_in_table`, `object_too_fast`, `arm_too_fast`.

    ## Version History

    - v1: every step advances to exactly the next multiple of the control period, counted in
      integers (docs/CLOCK.md); the joint targets move at most at Baxter's rated joint speeds;
      the action moves the target from the arm state the policy observed
      (`builders.control.add_tip_control`).
    - v0: the earlier behaviour (a summed clock, unbounded joint targets, the target from the
      next plant step's state), no longer registered: it and its figures are at git tag
      figures-v0.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 25}
    EPISODE_METRICS = PULL_EPISODE_METRICS
    TASK = TASK
    PHYSICAL_LIMITS = PHYSICAL_LIMITS

    @classmethod
    def check_kwargs(cls, kwargs, name: str = "env kwargs") -> dict:
        config = _config(kwargs, name)
        if config.actuation_delay_range is not None:  # its choices depend on the scenario's
            delay_choices(config.actuation_delay_range, _scenario(config).plant.time_step)
        return dict(kwargs or {})

    @classmethod
    def spaces(cls, kwargs) -> tuple[list, list]:
        _config(kwargs)
        return [OBSERVATION_SIZE], [ACTION_SIZE]

    @classmethod
    def add_task(cls, builder, scenario, belief=None, kwargs=None, visuals: bool = True):
        """The pull task wired into `builder` as the env these keyword arguments make wires
        it, in `scenario` holding its hook (the env's own hook and scenario options aside)."""
        _config(kwargs or {})
        return add_pull_task(builder, scenario, belief, visuals=visuals)

    def __init__(self, **kwargs):
        config = _config(kwargs)
        self.config = config
        scenario = _scenario(config)
        self._base_scenario = scenario
        self.diagram = None
        self._delays = None
        if config.actuation_delay_range is not None:
            self._delays = delay_choices(config.actuation_delay_range, scenario.plant.time_step)
        if config.hook is not None and self._delays is None:
            self._build(with_hook(scenario, config.hook))
            simulator = self._simulator
        else:  # DrakeGymEnv makes each episode's simulator (`_next_hook`) at its reset
            self.scenario = scenario
            simulator = self._next_hook
        self._start_gym(
            simulator,
            scenario.control.control_period,
            ACTION_SIZE,
            OBSERVATION_SIZE,
            config.render_mode,
        )

    # -- the diagram ----------------------------------------------------------------------
    def _build(self, scenario: Scenario, belief: RobotBelief | None = None) -> None:
        self.scenario = scenario
        builder = DiagramBuilder()
        task = self.add_task(builder, scenario, belief, {}, has_views(self.config))
        task.export(builder)
        self.task = task
        self.world, self.control = task.world, task.control
        self.ik_system = task.control.ik_system
        self.hook = task.belief.tool
        self._add_views(builder, self.config)
        self.diagram = builder.Build()
        self.diagram.set_name("tool_pull_env")
        self._metrics_reader = PullMetricsReader(self.world)
        self._sanity_reader = PhysicalSanityReader(self.world)
        self._simulator = Simulator(self.diagram)

    def _next_hook(self, generator) -> Simulator:
        """The next episode's world: a hook drawn with the env's seeded generator (`np_random`,
        which `reset(seed=...)` seeds before this is called; Drake's `generator` is not used),
        or the env's `hook`, or with `generated_tools` a generated hook or arc in the hand,
        the robot believing its equivalent hook (`robot.tool_generator.equivalent_hook`);
        then, with `actuation_delay_range`, an actuation delay drawn among its choices."""
        self._release_world()
        belief = None
        if self.config.generated_tools is not None:
            drawn = split_draw(self.config.generated_tools, self.np_random, SHAPE_FAMILIES)
            generated = generate_tool(*drawn)
            belief = RobotBelief(equivalent_hook(generated))
            scenario = with_tool(self._base_scenario, generated)
        else:
            hook = self.config.hook if self.config.hook is not None else draw_hook(self.np_random)
            scenario = with_hook(self._base_scenario, hook)
        if self._delays is not None:
            scenario = with_drawn_delay(scenario, self._delays, self.np_random)
        self._build(scenario, belief)
        return self._simulator

    # -- Gymnasium API --------------------------------------------------------------------
    def step(self, action):
        """Advances one control period. As the push env's step: the action is checked, the
        plant's state read once, and a simulation failure (Drake raises, or the state is no
        longer finite) truncates the episode with the last finite observation and reward."""
        x = self._advance(action, "position")
        sim_error = x is None
        if not sim_error:
            observation = np.asarray(
                self.task.observation.finite_observation(x, self._episode["goal"]), np.float32
            )
            m = self._read_metrics()
            sim_error = not (all_finite(observation) and _finite(m))
        if sim_error:
            observation, m, r = self._last
        else:
            r = reward(m)
            self._last = (observation, m, r)
            self._sanity = self._sanity_reader.read(self._plant_context, x)
        return observation, r, False, sim_error, self._info(m, sim_error)

    def _read_metrics(self):
        episode = self._episode
        m = self._metrics_reader.read(self._plant_context, episode["goal"], episode["start"])
        if _finite(m):
            episode["tool_touched"] |= m.tool_touches_object
            episode["gripper_touched"] |= m.gripper_touches_object
        return m

    def _info_handler(self, simulator) -> dict:
        """`info` of a reset state (DrakeGymEnv's reset calls it), which becomes the last
        finite state; `step` makes its own."""
        m = self._read_metrics()
        observation = np.asarray(self.observation_port.Eval(self._context), np.float32)
        self._last = (observation, m, reward(m))
        x = self.world.plant.GetPositionsAndVelocities(self._plant_context)
        self._sanity = self._sanity_reader.read(self._plant_context, x)
        return self._info(m, sim_error=False)

    def _info(self, m, sim_error: bool) -> dict:
        hook = self.hook
        return {
            "object_to_goal": m.object_to_goal,
            "object_travel": m.object_travel,
            "corner_to_behind": m.corner_to_behind,
            "hook": (hook.handle_length, hook.hook_length, hook.angle),
            **step_info(
                m, self._episode, self.ik_system.ok(self._ik_context), sim_error, self._sanity
            ),
        }


def _finite(m) -> bool:
    return (
        math.isfinite(m.object_to_goal)
        and math.isfinite(m.object_travel)
        and math.isfinite(m.corner_to_behind)
    )
