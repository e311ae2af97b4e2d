"""Gymnasium environments of the push task (the paper's Env1, Env2, Env3) on DrakeGymEnv.

```
action ──► TipTargetSystem ──X_WT*──► ToolTipIKSystem ──q*──► plant (in-plant PD) ──state──►
           (tool-tip space)           (robot model)                                 ToolPushObservation ──► observation
```

`ToolPushEnv`'s docstring is the envs' spec: spaces per mode, rewards per registered id, starting
state, episode end, arguments and `info` (tests/tasks/push/test_env_spec.py holds it to the code).
"""

from __future__ import annotations

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.task_gym_env import TaskGymEnv, ViewOptions, check_views, has_views
from drake_tooluse.robot.model import TIP_FRAME
from drake_tooluse.robot.tool import check_tool_length
from drake_tooluse.robot.tool_generator import PUSH_POINT, SPLITS, generate_tool, split_draw
from drake_tooluse.systems.tip_target import ACTION_MODES
from drake_tooluse.tasks.contract import RETIRED_VERSIONS, TaskEnv, env_config
from drake_tooluse.tasks.push.diagram import add_push_task
from drake_tooluse.tasks.push.metrics import (
    PUSH_EPISODE_METRICS,
    REWARD_TYPES,
    PushMetricsReader,
    reward,
)
from drake_tooluse.tasks.push.observation import OBSERVATION_SIZES
from drake_tooluse.tasks.push.registration import TASK
from drake_tooluse.tasks.rollout import step_info
from drake_tooluse.tasks.sanity import PHYSICAL_LIMITS, PhysicalSanityReader
from drake_tooluse.validation import (
    all_finite,
    check_bool,
    check_in_range,
    check_interval,
    check_mapping,
    check_one_of,
)
from drake_tooluse.world.scenario import (
    Scenario,
    check_delay_range,
    delay_choices,
    load_scenario,
    with_drawn_delay,
    with_tool,
    with_tool_length,
)


@dc.dataclass
class EnvConfig(ViewOptions):
    """The keyword arguments of `ToolPushEnv` (and of `gym.make`): the views every task's env
    takes (`ViewOptions`), then the push task's."""

    scenario: object = None  # a Scenario, a YAML path, or None for diagrams/push.yaml defaults
    tool_length: float | None = None  # overrides the scenario's (m)
    # [lo, hi] m: each episode's tool length drawn uniformly from it (the world's true tool and
    # the robot's belief both; `include_tool_length` puts it in the observation). None: one tool.
    tool_length_range: list | None = None
    # "training" or "held_out": each episode's tool drawn by the tool generator from that split
    # (`robot.tool_generator.SPLITS`), the world's and the robot's belief alike. None: one tool.
    generated_tools: str | None = None
    # [lo, hi] s: each episode's actuation delay (joint targets reaching the motors late)
    # drawn uniformly from the plant-step multiples in it, over the scenario's
    # `control.actuation_delay`: domain randomization for a robot whose delay is not known.
    actuation_delay_range: list | None = None
    reward_type: str = "tool_and_box"
    goal_extra: float = 0.0  # m added to the goal distance along y
    action_mode: str = "position_quaternion"  # see systems.tip_target
    include_tool_length: bool = False
    observation_mode: str = "gripper_joints"  # "tip", "tip_geometry" (tasks.push.observation)
    randomize: bool = False  # ranges: the scenario's `randomization`
    # The tool frame the IK places and the observation's "tip" is: `tool_tip`, or a generated
    # tool's `push_point` (robot.tool_generator: the point it pushes with).
    working_frame: str = TIP_FRAME


WORKING_FRAMES = (TIP_FRAME, PUSH_POINT)

# Keyword arguments of the earlier version that the push envs no longer take: each behaviour
# they chose between is now the one behaviour (the integer control clock, episodes to the step
# limit, `builders.control.add_tip_control`). Each with what the envs do instead.
RETIRED_OPTIONS = {
    "end_at_success": "every episode runs to its step limit",
    "bound_joint_speed": "joint targets always move at most at Baxter's rated speeds",
    "continuous_quaternion": "the quaternion action is always kept in one hemisphere",
    "target_from_observed_state": "the target always moves from the observed arm state",
    "ik_mode": "the exact tool-tip IK always runs",
}
# Mode names of the earlier version's policy files, with today's name of the same mode.
RETIRED_VALUES = {
    "action_mode": {"paper": "position_quaternion"},
    "observation_mode": {"paper": "gripper_joints"},
}


def check_retired(kwargs: dict) -> None:
    """A ValueError naming the first option of `RETIRED_OPTIONS` or value of `RETIRED_VALUES`
    in `kwargs`, and the git tag whose code takes it."""
    tag = RETIRED_VERSIONS[0]  # the version that took them
    for name, instead in RETIRED_OPTIONS.items():
        if name in kwargs:
            raise ValueError(
                f"{name}={kwargs[name]!r} is not an option of the push envs ({instead}); the "
                f"earlier version that took it, and its figures, are at git tag {tag}"
            )
    for name, renamed in RETIRED_VALUES.items():
        value = kwargs.get(name)
        if isinstance(value, str) and value in renamed:
            raise ValueError(
                f"{name}={value!r} is the earlier version's name of {renamed[value]!r}: what "
                f"holds it was made on that version, which runs at git tag {tag}"
            )


def _config(kwargs, name: str = "env kwargs") -> EnvConfig:
    """`kwargs` as an `EnvConfig`, names and values checked."""
    kwargs = dict(check_mapping(kwargs, name))
    check_retired(kwargs)
    config = env_config(EnvConfig, kwargs, name, "a drake_tooluse env")
    check_one_of(config.reward_type, REWARD_TYPES, "reward_type")
    check_one_of(config.action_mode, tuple(ACTION_MODES), "action_mode")
    check_views(config)
    check_one_of(config.observation_mode, tuple(OBSERVATION_SIZES), "observation_mode")
    check_one_of(config.working_frame, WORKING_FRAMES, "working_frame")
    check_in_range(config.goal_extra, -0.15, 0.25, "goal_extra", unit="m")
    check_bool(config.include_tool_length, "include_tool_length")
    check_bool(config.randomize, "randomize")
    if config.tool_length is not None:
        check_tool_length(config.tool_length, "tool_length")
    if config.tool_length_range is not None:
        config.tool_length_range = _check_length_range(config)
    if config.generated_tools is not None:
        check_one_of(config.generated_tools, SPLITS, "generated_tools")
        if config.tool_length is not None or config.tool_length_range is not None:
            raise ValueError("give generated_tools or a tool length (range), not both")
    if config.actuation_delay_range is not None:
        config.actuation_delay_range = check_delay_range(config.actuation_delay_range)
    if config.scenario is not None and not isinstance(config.scenario, (Scenario, str, Path)):
        raise ValueError(
            f"scenario={config.scenario!r} must be a Scenario, a YAML file name or None"
        )
    return config


def _check_length_range(config: EnvConfig) -> list[float]:
    if config.tool_length is not None:
        raise ValueError("give tool_length or tool_length_range, not both")
    return check_interval(config.tool_length_range, "tool_length_range", "m", check_tool_length)


def _scenario(config: EnvConfig) -> Scenario:
    if config.scenario is None:
        scenario = Scenario()
    elif isinstance(config.scenario, Scenario):
        scenario = config.scenario
    else:
        scenario = load_scenario(Path(config.scenario))
    if config.tool_length is not None:
        scenario = with_tool_length(scenario, config.tool_length)
    goal = list(scenario.goal_offset)
    goal[1] += config.goal_extra
    return dc.replace(scenario, goal_offset=goal)


class ToolPushEnv(TaskEnv, TaskGymEnv):
    """The push task as a Gymnasium env: Baxter's right arm, holding a tool, pushes a box
    across the table to a goal with the tool's tip.

    ### Description

    The paper's task (Kothavale & Boddepalli, arXiv 2510.26551): the robot holds a straight
    tool rigidly in its right gripper and pushes a wooden box (0.04 m cube) along +y on the
    table. The policy acts in tool-tip space: each action moves a desired tool-tip pose X_WT*
    from where the tip is now; the exact tool-tip IK on the robot's model (the believed tool
    length) turns it into joint targets, which the plant's joint PD controllers track. One
    step is one control period of 40 ms (the plant steps at 20 ms, SAP, point contact). The
    world holds the true tool; the metrics, the reward and `info` are the truth's.

    Notation: x the box centre, x* the goal, y the true tool tip (a generated tool's push
    point), all in W (Baxter's base frame, m). The tip target is kept in a box above the table
    (`systems.tip_target.Workspace`): x in [0.40, 1.00] m, y in [−0.70, 0.35] m, z from
    5 mm to 0.40 m above the table's top.

    ### Action Space

    `Box(-1.0, 1.0, (n,), float32)`, n by `action_mode`; values outside [-1, 1] are clipped,
    NaN or infinite values are a ValueError. Each moves the tool-tip target by, at `|a| = 1`:

    #### action_mode = position_quaternion

    The paper's action (a mocap change of position and quaternion); the default.

    | index | meaning | range | unit |
    | --- | --- | --- | --- |
    | 0 | change of the tip target's x | [-1, 1] × 0.02 | m |
    | 1 | change of the tip target's y | [-1, 1] × 0.02 | m |
    | 2 | change of the tip target's z | [-1, 1] × 0.02 | m |
    | 3 | change of the target quaternion's w (then normalized) | [-1, 1] × 0.05 | — |
    | 4 | change of the target quaternion's x (then normalized) | [-1, 1] × 0.05 | — |
    | 5 | change of the target quaternion's y (then normalized) | [-1, 1] × 0.05 | — |
    | 6 | change of the target quaternion's z (then normalized) | [-1, 1] × 0.05 | — |

    #### action_mode = pose

    | index | meaning | range | unit |
    | --- | --- | --- | --- |
    | 0 | change of the tip target's x | [-1, 1] × 0.02 | m |
    | 1 | change of the tip target's y | [-1, 1] × 0.02 | m |
    | 2 | change of the tip target's z | [-1, 1] × 0.02 | m |
    | 3 | rotation of the target about W's x (rotation vector) | [-1, 1] × 0.10 | rad |
    | 4 | rotation of the target about W's y (rotation vector) | [-1, 1] × 0.10 | rad |
    | 5 | rotation of the target about W's z (rotation vector) | [-1, 1] × 0.10 | rad |

    #### action_mode = position

    The orientation is held.

    | index | meaning | range | unit |
    | --- | --- | --- | --- |
    | 0 | change of the tip target's x | [-1, 1] × 0.02 | m |
    | 1 | change of the tip target's y | [-1, 1] × 0.02 | m |
    | 2 | change of the tip target's z | [-1, 1] × 0.02 | m |

    ### Observation Space

    `Box(-inf, inf, (n,), float32)`, n by `observation_mode`, one more with
    `include_tool_length` (the last index, marked "optional"). Rows of a slice a:b are
    indices a … b−1, in the order x, y, z or s0 … w2. The tool tip in the observation is on
    the robot's model (the believed length), not the truth.

    #### observation_mode = gripper_joints

    The paper's observation, in its order; the default.

    | index | meaning | range | unit |
    | --- | --- | --- | --- |
    | 0:3 | goal x* | (-inf, inf) | m |
    | 3:6 | box position x | (-inf, inf) | m |
    | 6:9 | tool-tip position (believed tool) | (-inf, inf) | m |
    | 9:12 | gripper position | (-inf, inf) | m |
    | 12:16 | gripper quaternion w, x, y, z | [-1, 1] | — |
    | 16:23 | right-arm joint angles s0 … w2 | Baxter's joint limits | rad |
    | 23:30 | right-arm joint velocities s0 … w2 | (-inf, inf) | rad/s |
    | 30 | believed tool length (optional) | (0, 0.60] | m |

    #### observation_mode = tip

    The task in tool-tip space only: the same for any tool the IK tracks.

    | index | meaning | range | unit |
    | --- | --- | --- | --- |
    | 0:3 | goal x* | (-inf, inf) | m |
    | 3:6 | box position x | (-inf, inf) | m |
    | 6:9 | tool-tip position (believed tool) | (-inf, inf) | m |
    | 9:12 | tool-tip velocity, J(q) v (believed tool) | (-inf, inf) | m/s |
    | 12 | believed tool length (optional) | (0, 0.60] | m |

    #### observation_mode = tip_geometry

    `tip`, then the believed tool's shape (`robot.tool_geometry`): one observation for tools
    of every family.

    | index | meaning | range | unit |
    | --- | --- | --- | --- |
    | 0:12 | as observation_mode = tip | | |
    | 12:15 | the tool's point farthest along W's +x, from the tip | (-inf, inf) | m |
    | 15:18 | the tool's point farthest along W's −x, from the tip | (-inf, inf) | m |
    | 18:21 | the tool's point farthest along W's +y, from the tip | (-inf, inf) | m |
    | 21:24 | the tool's point farthest along W's −y, from the tip | (-inf, inf) | m |
    | 24:27 | the tool's lowest point, from the tip | (-inf, inf) | m |
    | 27 | believed tool length (optional) | (0, 0.60] | m |

    ### Rewards

    Dense, every step, from the truth:

    | id | paper | reward_type | reward |
    | --- | --- | --- | --- |
    | `drake_tooluse/ToolPush-v1` | Env1 | tool_and_box | −(d(x, x*) + d(x, y)) |
    | `drake_tooluse/ToolPushBoxReward-v1` | Env2 | box | −d(x, x*) |
    | `drake_tooluse/ToolPushFar-v1` | Env3 | tool_and_box | −(d(x, x*) + d(x, y)), the goal 0.10 m further (`goal_extra`) |

    Success (`info["is_success"]`, every step, for every id): d(x, x*) + d(x, y) ≤ 0.05 m.

    ### Starting State

    The arm starts at the home configuration the robot's IK computes for the tool it believes
    it holds: the tip at (0.62, −0.30) m, 0.10 m above the table's top, pointing down. The
    box starts at (0.70, −0.25) m on the table, yaw 0; the goal is 0.20 m along +y from it
    (plus `goal_extra`: ToolPushFar-v1's 0.30 m). These are the scenario's (`scenario`;
    default diagrams/push.yaml's values, a 0.175 m tool).

    With `randomize=True`, each reset draws uniformly, from the env's generator seeded by
    `reset(seed=...)`, within the scenario's `randomization`: the box's start x and y each
    ±0.02 m and yaw ±0.2 rad, its mass × [0.7, 1.3] and friction × [0.7, 1.3], the true
    grasp ±0.01 m along the tool and ±0.005 m across it (the goal moves with the box). With
    `tool_length_range=[lo, hi]`, each reset draws the tool's length uniformly from it (the
    world's and the robot's belief alike); with `actuation_delay_range=[lo, hi]`, then the
    actuation delay, uniformly among the plant-step multiples in it (the robot is not told).
    With `generated_tools="training"` (or `"held_out"`), each reset draws a tool of the
    generator's training (or held-out) split (`robot.tool_generator.split_draw`), which the
    robot is told.
    Otherwise every reset starts the same.

    ### Episode End

    - Truncation: at the step limit of every registered id, 100 steps (4 s); episodes run
      to it and are judged where they end, as Gymnasium-Robotics' Fetch envs do — a policy
      must bring the box to the goal and hold it there.
    - Termination: none; an episode is judged where it ends.
    - A simulation failure (a `RuntimeError` from Drake, or a state no longer finite)
      truncates the episode with `info["sim_error"] = True` and finite values: the last
      finite observation, reward, metrics and physical figures.

    ### Arguments

    `gym.make(id, **kwargs)` or `ToolPushEnv(**kwargs)` (`EnvConfig`; a bad name or value is a
    ValueError naming it):

    | argument | default | meaning |
    | --- | --- | --- |
    | render_mode | None | None, "rgb_array" (a scene camera's colour image: the task in view, the goal drawn) or "human" |
    | render_size | (640, 480) | `rgb_array`'s image (width, height) px, each in [32, 2048] |
    | render_camera_position | (1.8, -1.1, 0.6) | `rgb_array`'s camera position (W, m) |
    | render_camera_target | (0.4, -0.1, 0.1) | the point `rgb_array`'s camera looks at (W, m) |
    | meshcat | None | a pydrake.geometry.Meshcat to draw the episodes in (recordings); else None |
    | scenario | None | a Scenario, or a scenario YAML file; None: the default scenario (diagrams/push.yaml's values) |
    | tool_length | None | the tool's length (m, in (0, 0.60]), over the scenario's |
    | tool_length_range | None | [lo, hi] m: each episode's tool length drawn uniformly (not with tool_length) |
    | generated_tools | None | "training" or "held_out": each episode's tool drawn by the tool generator from that split (not with a tool length) |
    | actuation_delay_range | None | [lo, hi] s, in [0, 0.2]: each episode's actuation delay drawn uniformly among the plant-step multiples in it |
    | reward_type | "tool_and_box" | "tool_and_box" (Env1, Env3) or "box" (Env2); set by the id |
    | goal_extra | 0.0 | m added to the goal's distance along y, in [-0.15, 0.25]; set by the id |
    | action_mode | "position_quaternion" | "position_quaternion", "pose" or "position" (Action Space) |
    | include_tool_length | False | the believed tool length as the observation's last value |
    | observation_mode | "gripper_joints" | "gripper_joints", "tip" or "tip_geometry" (Observation Space) |
    | randomize | False | draw the starting state per reset (Starting State) |
    | working_frame | "tool_tip" | the frame the IK places (the observed tip): "tool_tip" or a generated tool's "push_point" |

    ### Info

    Every step's `info` (and the reset's), from the truth:

    | key | meaning | unit |
    | --- | --- | --- |
    | object_to_goal | d(x, x*) | m |
    | tip_to_object | d(x, y), the true tip (a generated tool's push point) | m |
    | object_travel | the box centre's distance in the table's plane from where it started | m |
    | is_success | d(x, x*) + d(x, y) ≤ 0.05 m | bool |
    | tool_touches_object | the tool touches the box now | bool |
    | gripper_touches_object | the robot (not the tool) touches the box now | bool |
    | tool_touched_object_in_episode | the tool has touched the box in this episode | bool |
    | gripper_touched_object_in_episode | the robot has touched the box in this episode | bool |
    | ik_ok | the IK's last solve succeeded (and the step did not fail) | bool |
    | sim_error | the simulation failed in this step (the episode is truncated) | bool |
    | tool_table_penetration | how far the tool's lowest point lies below the table's top, over the table | m |
    | gripper_table_penetration | the same for the gripper (hand, gripper base and fingers) | m |
    | object_speed | the box centre's speed | m/s |
    | arm_joint_speed | the largest of the 7 right-arm joint speeds | rad/s |
    | tool_in_table | tool_table_penetration past 0.005 m | bool |
    | gripper_in_table | gripper_table_penetration past 0.005 m | bool |
    | object_too_fast | object_speed past 1 m/s | bool |
    | arm_too_fast | arm_joint_speed past 4 rad/s | bool |

    The last eight are the task's physical sanity (`tasks.sanity`: the limits and why);
    `drake-tooluse evaluate` counts the episodes with a step past each limit.

    ### Version History

    - v1: every step advances to exactly the next multiple of the control period, counted in
      integers (docs/CLOCK.md); the joint targets move at most at Baxter's rated joint speeds
      (shoulder, elbow 1.5 rad/s; wrist 4.0); the `position_quaternion` action is added in the
      initial quaternion's hemisphere (`systems.tip_target`); the action moves the target from
      the arm state the policy observed (`systems.tool_tip_ik`); episodes run to the step limit
      (`builders.control.add_tip_control`).
    - v0: the earlier behaviour (a summed clock, unbounded joint targets, Drake's quaternion
      sign, the target from the next plant step's state; an option for each fix), no longer
      registered: it and its figures are at git tag figures-v0.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 25}
    EPISODE_METRICS = PUSH_EPISODE_METRICS
    TASK = TASK
    PHYSICAL_LIMITS = PHYSICAL_LIMITS

    @classmethod
    def check_kwargs(cls, kwargs, name: str = "env kwargs") -> dict:
        config = cls._config(kwargs, name)
        if config.actuation_delay_range is not None:  # its choices depend on the scenario's
            delay_choices(config.actuation_delay_range, _scenario(config).plant.time_step)
        return dict(kwargs or {})

    @classmethod
    def _config(cls, kwargs, name: str = "env kwargs") -> EnvConfig:
        return _config(kwargs, name)

    @classmethod
    def add_task(cls, builder, scenario, belief=None, kwargs=None, visuals: bool = True):
        """The push task wired into `builder` as the env these keyword arguments make wires
        it, in `scenario` (the env's own scenario options aside)."""
        return cls._add_task(builder, scenario, belief, cls._config(kwargs), visuals)

    @classmethod
    def _add_task(cls, builder, scenario, belief, config: EnvConfig, visuals: bool = True):
        return add_push_task(
            builder,
            scenario,
            belief,
            config.action_mode,
            config.observation_mode,
            config.include_tool_length,
            config.reward_type,
            visuals=visuals,
            frame=config.working_frame,
        )

    @classmethod
    def spaces(cls, kwargs) -> tuple[list, list]:
        config = cls._config(kwargs)
        n_obs = OBSERVATION_SIZES[config.observation_mode] + int(config.include_tool_length)
        return [n_obs], [ACTION_MODES[config.action_mode]]

    def __init__(self, **kwargs):
        config = self._config(kwargs)
        self.config = config
        self.scenario = self._base_scenario = _scenario(config)
        self.diagram = None
        self._delays = None
        if config.actuation_delay_range is not None:
            self._delays = delay_choices(
                config.actuation_delay_range, self.scenario.plant.time_step
            )
        if (
            config.tool_length_range is None
            and config.generated_tools is None
            and self._delays is None
        ):
            self._build(config)
            simulator = self._simulator
        else:  # DrakeGymEnv makes each episode's simulator (`_next_world`) at its reset
            simulator = self._next_world
        n_obs = OBSERVATION_SIZES[config.observation_mode] + int(config.include_tool_length)
        self._start_gym(
            simulator,
            self.scenario.control.control_period,
            ACTION_MODES[config.action_mode],
            n_obs,
            config.render_mode,
        )
        self._last_reward = 0.0

    # -- the diagram ----------------------------------------------------------------------
    def _build(self, config: EnvConfig) -> None:
        builder = DiagramBuilder()
        task = self._add_task(builder, self.scenario, None, config, has_views(config))
        task.export(builder)
        self.task = task
        self.world, self.control = task.world, task.control
        self.ik_system, self.target_system = task.control.ik_system, task.control.target
        self.observation_system = task.observation
        self._add_views(builder, config)
        self.diagram = builder.Build()
        self.diagram.set_name("tool_push_env")
        # The step reads the task's metrics from the plant with the reader `task.outcome`
        # uses, and forms the reward and success from them as its ports do (`_read_metrics`).
        self._metrics_reader = PushMetricsReader(self.world)
        self._sanity_reader = PhysicalSanityReader(self.world)
        self._simulator = Simulator(self.diagram)

    def _next_world(self, generator) -> Simulator:
        """The next episode's world: a tool of a length drawn from `tool_length_range`, or a
        tool the generator draws from the `generated_tools` split, then an actuation delay
        drawn from `actuation_delay_range`'s choices, each where given, with the env's seeded
        generator (Drake's `generator` is not used: `np_random` is the
        one the env's `reset(seed=...)` seeds, before this is called)."""
        scenario = self._base_scenario
        if self.config.tool_length_range is not None:
            lo, hi = self.config.tool_length_range
            scenario = with_tool_length(scenario, float(self.np_random.uniform(lo, hi)))
        if self.config.generated_tools is not None:
            drawn = split_draw(self.config.generated_tools, self.np_random)
            scenario = with_tool(scenario, generate_tool(*drawn))
        if self._delays is not None:
            scenario = with_drawn_delay(scenario, self._delays, self.np_random)
        self._release_world()
        self.scenario = scenario
        self._build(self.config)
        return self._simulator

    # -- Gymnasium API --------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        observation, info = super().reset(seed=seed, options=options)
        self._last_reward = reward(self._last[1], self.config.reward_type)
        return observation, info

    def step(self, action):
        """DrakeGymEnv's step, but for three things it cannot do: it would evaluate the
        observation before advancing too (a second evaluation each step, for its failure
        path), it keeps no last finite state (NaN would reach the learner), and it checks no
        action. No episode terminates: each runs to its step limit.

        The plant's state is read once: its finiteness check and the observation (the
        `observation` port's, `ToolPushObservation` of the same state and goal) share it."""
        x = self._advance(action, self.config.action_mode)
        sim_error = x is None
        observation, m = self._last
        if not sim_error:
            observation = self.observation_system.finite_observation(x, self._episode["goal"])
            observation = np.asarray(observation, np.float32)
            m = self._read_metrics()
            # A finite dot product proves the observation finite in one C call (`all_finite`'s
            # sum goes through numpy's Python code); only where it is not does that decide.
            finite = math.isfinite(observation.dot(observation)) or all_finite(observation)
            sim_error = not (finite and _finite(m))
        if sim_error:  # the last finite state stands: no NaN reaches the learner
            observation, m = self._last
        else:
            self._last = (observation, m)
            self._sanity = self._sanity_reader.read(self._plant_context, x)
            self._last_reward = reward(m, self.config.reward_type)
        return observation, self._last_reward, False, sim_error, self._info(m, sim_error)

    def _read_metrics(self):
        """The task's metrics of the current state, the episode's touches kept. They are the
        `outcome` system's (`PushOutcome`: the same reader on the same plant state), read
        from the plant directly: its ports would copy every body's pose into Python. The
        reward and success are formed from them as its `reward` and `success` ports form them
        (`metrics.reward`, `PushMetrics.is_success`)."""
        episode = self._episode
        m = self._metrics_reader.read(self._plant_context, episode["goal"], episode["start"])
        if _finite(m):
            self._episode["tool_touched"] |= m.tool_touches_object
            self._episode["gripper_touched"] |= m.gripper_touches_object
        return m

    def _info_handler(self, simulator) -> dict:
        """`info` of a reset state (DrakeGymEnv's reset calls it), which becomes the last
        finite state; `step` makes its own from the metrics it read."""
        m = self._read_metrics()
        self._last = (np.asarray(self.observation_port.Eval(self._context), np.float32), m)
        x = self.world.plant.GetPositionsAndVelocities(self._plant_context)
        self._sanity = self._sanity_reader.read(self._plant_context, x)
        return self._info(m, sim_error=False)

    def _info(self, m, sim_error: bool) -> dict:
        ik_ok = self.ik_system.ok(self._ik_context)
        return {
            "object_to_goal": m.object_to_goal,
            "tip_to_object": m.tip_to_object,
            "object_travel": m.object_travel,
            **step_info(m, self._episode, ik_ok, sim_error, self._sanity),
        }


def _finite(m) -> bool:
    return (
        math.isfinite(m.object_to_goal)
        and math.isfinite(m.tip_to_object)
        and math.isfinite(m.object_travel)
    )
