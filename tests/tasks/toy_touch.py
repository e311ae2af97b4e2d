"""A toy task, written as docs/ARCHITECTURE.md's "Add a task" walks through it: touch a point
in the air with the tool tip. Nothing outside this file changes for it: it wires itself into a
builder from the world and the robot's belief, gives the contract's ports, and registers an id
in the project's namespace, so learning/ trains and evaluates it like the push task.

Task description: the tool tip starts at the scenario's home pose; a target point hangs 5 cm
to its left and 3 cm below it (`target_offset` changes it). Action: tool-tip position changes
(3, the push task's `position` mode). Observation: the target and the tip (6, m, W).
The world is the push task's scenario (`diagrams/push.yaml`) or `scenario` (a YAML file),
whatever tool it holds (tests/tasks/test_add_a_tool.py gives it a toy L-shaped tool).
Reward: minus the tip's distance from the target (m). Success: the tip within 2 cm of the
target; the episode ends there (a simulator monitor, the Drake way) or after 20 steps.
Views: `render_mode="rgb_array"` (the project's scene camera) and `meshcat` (a Meshcat to draw
in), so it declares `record-video` and `evaluate --meshcat` (`TASK`). Its one builder
(`ToyTouchEnv.add_task`, what the env is made of) and its metrics reader (`TouchReader`: the
object a touch moves is the tip itself) let a policy deploy outside its env, so it declares
`transfer` too: closed loop, with straight tools of other lengths, in the push task's world and
in reality. The commands that need more of a task (a box to push: `trajectory`, `distill`)
refuse it, saying what it lacks.
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, EventStatus, LeafSystem

from drake_tooluse.builders.control import add_tip_control, add_world_at_home
from drake_tooluse.builders.task_gym_env import CountedClockGymEnv
from drake_tooluse.builders.visualization import add_meshcat_visualizer
from drake_tooluse.learning.task_envs import task_env_ids
from drake_tooluse.systems.camera import add_scene_camera
from drake_tooluse.tasks.contract import EpisodeMetric, TaskDeclaration, TaskEnv, TaskParts
from drake_tooluse.world.scenario import Scenario, load_scenario
from drake_tooluse.world.scene import home_tip_pose

ENV_ID = "drake_tooluse/ToyTouch-v1"
SUCCESS_DISTANCE = 0.02  # m


@dataclass(frozen=True)
class TouchMetrics:
    """A touch's figures, named as a deployed rollout reads any task's (`tasks.rollout`): the
    object the touch moves is the tip, its goal the target."""

    object_to_goal: float  # m, the tip from the target
    object_travel: float  # m, the tip from where it started
    is_success: bool
    tool_touches_object: bool = False  # nothing to touch: the target hangs in the air
    gripper_touches_object: bool = False


class TouchReader:
    """The touch's metrics from the plant (`read`, as `tasks.rollout.roll_out` calls it). The
    target and the tip's start are the task's own, not the scenario's goal and box start
    (which a rollout passes and this task does not use)."""

    def __init__(self, world, target, start):
        self._tip_frame = world.tip_frame
        self.target, self._start = np.asarray(target, float), np.asarray(start, float)

    def read(self, plant_context, goal=None, start=None) -> TouchMetrics:
        return self.at(self._tip_frame.CalcPoseInWorld(plant_context).translation())

    def at(self, p_WT) -> TouchMetrics:
        """The metrics of the tip at `p_WT` (m, W): what `read` and `TouchOutcome` give."""
        distance = float(np.linalg.norm(p_WT - self.target))
        travel = float(np.linalg.norm(p_WT - self._start))
        return TouchMetrics(distance, travel, distance <= SUCCESS_DISTANCE)


class TouchOutcome(LeafSystem):
    """The tip's distance from the target as the observation, the reward and the success.

    .. pydrake_system::

        name: TouchOutcome
        input_ports:
        - body_poses
        output_ports:
        - observation
        - reward
        - success
    """

    def __init__(self, world, target, start):
        super().__init__()
        self.reader = TouchReader(world, target, start)
        self._tip_body = int(world.tip_frame.body().index())
        self._X_BT = world.tip_frame.GetFixedPoseInBodyFrame()
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", world.plant.get_body_poses_output_port().Allocate()
        )
        self.DeclareVectorOutputPort("observation", 6, self._observation)
        self.DeclareVectorOutputPort("reward", 1, self._reward)
        self.DeclareVectorOutputPort("success", 1, self._success)

    def tip(self, context) -> np.ndarray:
        return self._poses.Eval(context)[self._tip_body].multiply(self._X_BT).translation()

    def metrics(self, context) -> TouchMetrics:
        return self.reader.at(self.tip(context))

    def _observation(self, context, output: BasicVector) -> None:
        output.SetFromVector(np.concatenate([self.reader.target, self.tip(context)]))

    def _reward(self, context, output: BasicVector) -> None:
        output.SetAtIndex(0, -self.metrics(context).object_to_goal)

    def _success(self, context, output: BasicVector) -> None:
        output.SetAtIndex(0, float(self.metrics(context).is_success))


@dataclass
class TouchParts(TaskParts):
    """The contract's parts, with the outcome system (whose `reader` a deployed rollout reads)."""

    outcome: object = None


def add_touch_task(
    builder,
    scenario: Scenario,
    belief=None,
    target_offset=(0.0, 0.05, -0.03),
    visuals: bool = True,
) -> TouchParts:
    """The contract's wiring: the world at home, tool-tip position control, the outcome."""
    world, ik, q0 = add_world_at_home(builder, scenario, belief, visuals=visuals)
    control = add_tip_control(builder, world, ik, q0, "position")
    p_WT0 = home_tip_pose(scenario).translation()
    target = p_WT0 + np.asarray(target_offset, float)
    outcome = builder.AddNamedSystem("touch", TouchOutcome(world, target, p_WT0))
    builder.Connect(world.plant.get_body_poses_output_port(), outcome.get_input_port())
    return TouchParts(
        world,
        ik,
        control,
        outcome.GetOutputPort("observation"),
        outcome.GetOutputPort("reward"),
        outcome.GetOutputPort("success"),
        outcome=outcome,
    )


class ToyTouchEnv(TaskEnv, CountedClockGymEnv):
    """The toy task as a Gymnasium env, made the Drake way: a reward port, a simulator monitor
    for the episode's end, an info handler; DrakeGymEnv's `reset` and its `step` on a counted clock
    (`CountedClockGymEnv`: one control update per step)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 25}  # 1 / its 40 ms step
    EPISODE_METRICS = (EpisodeMetric("final_distance_m", "distance"),)
    TASK = TaskDeclaration(
        "touch",
        object_name="tip",
        serves=frozenset({"record-video", "evaluate --meshcat", "transfer"}),
    )

    @classmethod
    def check_kwargs(cls, kwargs, name: str = "env kwargs") -> dict:
        kwargs = dict(kwargs or {})
        unknown = sorted(set(kwargs) - {"target_offset", "scenario", "render_mode", "meshcat"})
        if unknown:
            raise ValueError(f"unknown argument(s) {unknown} for {ENV_ID} ({name})")
        if kwargs.get("render_mode") not in (None, "rgb_array"):
            raise ValueError(f"render_mode={kwargs['render_mode']!r} must be None or 'rgb_array'")
        offset = np.asarray(kwargs.get("target_offset", (0, 0, 0)), float)
        if offset.shape != (3,) or np.abs(offset).max() > 0.1:
            raise ValueError(f"target_offset={offset.tolist()} must be 3 values within 0.1 m")
        return kwargs

    @classmethod
    def spaces(cls, kwargs) -> tuple[list, list]:
        return [6], [3]

    @classmethod
    def add_task(cls, builder, scenario, belief=None, kwargs=None, visuals: bool = True):
        """The touch wired into `builder` as the env these keyword arguments make wires it, in
        `scenario` (the env's own scenario and views aside)."""
        kwargs = cls.check_kwargs(kwargs)
        offset = {k: v for k, v in kwargs.items() if k == "target_offset"}
        return add_touch_task(builder, scenario, belief, visuals=visuals, **offset)

    def __init__(self, scenario=None, render_mode=None, meshcat=None, **kwargs):
        self.check_kwargs({**kwargs, "render_mode": render_mode})
        scenario = Scenario() if scenario is None else load_scenario(scenario)
        builder = DiagramBuilder()
        parts = self.add_task(builder, scenario, None, kwargs)
        self._outcome = parts.outcome
        parts.export(builder)
        if render_mode == "rgb_array":  # the project's scene camera: its `color_image` output
            add_scene_camera(builder, parts.world)
        if meshcat is not None:
            add_meshcat_visualizer(builder, parts.world.scene_graph, meshcat, scenario)
        self._control = parts.control
        diagram = builder.Build()
        simulator = Simulator(diagram)
        success = diagram.GetOutputPort("success")

        def monitor(context):
            if success.Eval(context)[0] > 0.5:
                return EventStatus.ReachedTermination(diagram, "the tip touched the target")
            return EventStatus.Succeeded()

        simulator.set_monitor(monitor)
        self.metadata = dict(type(self).metadata)  # DrakeGymEnv writes into it
        super().__init__(
            simulator=simulator,
            time_step=scenario.control.control_period,
            action_space=gym.spaces.Box(-1.0, 1.0, (3,), np.float32),
            observation_space=gym.spaces.Box(-10.0, 10.0, (6,), np.float64),
            reward="reward",
            action_port_id="action",
            observation_port_id="observation",
            render_rgb_port_id="color_image" if render_mode == "rgb_array" else None,
            render_mode=render_mode or "human",
            reset_handler=lambda simulator, context, seed: self._control.reset(context),
        )
        self.render_mode = render_mode
        # DrakeGymEnv 1.51 drops its `info_handler` argument (see tasks.push.env): set it here.
        self.info_handler = self._info

    def _info(self, simulator) -> dict:
        context = self._outcome.GetMyContextFromRoot(simulator.get_context())
        metrics = self._outcome.metrics(context)
        return {
            "is_success": metrics.is_success,
            "sim_error": False,
            "distance": metrics.object_to_goal,
        }


# A few hundred steps of PPO: enough to show learning/ trains the toy task, not to learn it.
TINY_PPO = {
    "n_steps": 64,
    "batch_size": 32,
    "n_epochs": 1,
    "eval_freq": 10_000_000,
    "checkpoint_freq": 128,
    "eval_episodes": 1,
}


def register() -> None:
    if ENV_ID not in task_env_ids():
        gym.register(ENV_ID, entry_point=f"{__name__}:ToyTouchEnv", max_episode_steps=20)


register()  # on import: DRAKE_TOOLUSE_TASKS=tests.tasks.toy_touch makes every process know it
