"""What every task's Gymnasium env does the same on `pydrake.gym.DrakeGymEnv`: `TaskGymEnv`.

A task's env class is `class MyEnv(TaskEnv, TaskGymEnv)` (`tasks.contract.TaskEnv`: the
class-level contract). TaskGymEnv gives it the Gym setup (`_start_gym`), the reset and its
episode start (`_start_episode`: the randomized state, the goal and the box's start set in
the task's systems and kept in `_episode`), the checked action fixed on the diagram's input and one control period
advanced (`_advance`), a world built again per episode (`_release_world`), and `close`.

The env builds its diagram itself and keeps, as attributes: `config` (with `randomize`),
`scenario`, `world`, `control`, `ik_system` and `task` (the task's
`tasks.contract.GoalTaskParts`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from pydrake.geometry import Meshcat
from pydrake.gym import DrakeGymEnv
from pydrake.systems.analysis import SimulatorStatus

from drake_tooluse.builders.failures import advance, finite_state_vector, object_diverged
from drake_tooluse.builders.visualization import (
    GOAL_RADIUS,
    add_meshcat_visualizer,
    save_recording,
    show_task,
)
from drake_tooluse.systems.camera import (
    SCENE_CAMERA_POSITION,
    SCENE_CAMERA_SIZE,
    SCENE_CAMERA_TARGET,
    SceneView,
    add_scene_camera,
    check_scene_camera,
    draw_goal,
)
from drake_tooluse.systems.lifetime import release_diagram
from drake_tooluse.systems.tip_target import check_action
from drake_tooluse.validation import check_one_of, check_seed
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scene import initial_box_pose, set_randomized_state

# What `close` lets go of (each where the env has it): the diagram and what holds into it.
RELEASED_ATTRIBUTES = (
    "diagram",
    "simulator",
    "_simulator",
    "action_port",
    "observation_port",
    "render_rgb_port",
    "_scene_depth",
    "world",
    "control",
    "ik_system",
    "target_system",
    "observation_system",
    "visualizer",
    "_metrics_reader",
    "_sanity_reader",
    "_context",
    "_plant_context",
    "_ik_context",
    "_action_value",
    "task",
)


class CountedClockGymEnv(DrakeGymEnv):
    """`DrakeGymEnv` whose every step ends at exactly k · time_step, k the steps since the
    reset counted in integers. DrakeGymEnv's own step (1.51.1) advances to
    `context.get_time() + time_step`, a sum that drifts: about 1 step in 20 ends a few 1e-15 s
    short of its period, so that period's controller update falls into the next step and one
    action never acts (docs/CLOCK.md). An env made the Drake way (a reward port, a monitor,
    DrakeGymEnv's `step`) subclasses this in its place."""

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._steps_done = 0
        return super().reset(seed=seed, options=options)

    def _next_step_time(self) -> float:
        """The time the next step ends at (the step is counted)."""
        self._steps_done += 1
        return self._steps_done * self.time_step

    def step(self, action):
        """DrakeGymEnv's `step` (1.51.1), advancing to `_next_step_time()`: the action fixed
        on the action port, one step simulated; a RuntimeError from Drake truncates the
        episode with the observation before the step, reward 0 and an empty info."""
        assert self.simulator, "You must call reset() first"
        context = self.simulator.get_context()
        self.action_port.FixValue(context, action)
        prev_observation = self.observation_port.Eval(context)
        try:
            status = self.simulator.AdvanceTo(self._next_step_time())
        except RuntimeError:
            return prev_observation, 0, False, True, {}
        observation = self.observation_port.Eval(context)
        reward = self.reward(self.simulator.get_system(), context)
        terminated = status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition
        return observation, reward, terminated, False, self.info_handler(self.simulator)


@dataclass
class ViewOptions:
    """The view options every task's env takes (the first fields of its config dataclass)."""

    render_mode: str | None = None
    # `rgb_array`'s image: (width, height) px, each in [32, 2048], and the camera's position
    # and the point it looks at (W, m); by default the whole task is in view.
    render_size: tuple = SCENE_CAMERA_SIZE
    render_camera_position: tuple = SCENE_CAMERA_POSITION
    render_camera_target: tuple = SCENE_CAMERA_TARGET
    meshcat: object = None  # a Meshcat instance to draw the episode in (for recordings)


def has_views(config) -> bool:
    """Whether `config` asks for a view (a render mode or Meshcat): what its world is drawn
    in. A world without views needs no visual geometry."""
    return config.render_mode is not None or config.meshcat is not None


def check_views(config, render_modes=(None, "rgb_array", "human")) -> None:
    """The view options every task's env takes, checked (each a ValueError naming it):
    `render_mode` (one of `render_modes`), `rgb_array`'s `render_size`,
    `render_camera_position` and `render_camera_target`, and `meshcat`."""
    check_one_of(config.render_mode, render_modes, "render_mode")
    check_scene_camera(
        config.render_size, config.render_camera_position, config.render_camera_target
    )
    if config.meshcat is not None and not isinstance(config.meshcat, Meshcat):
        raise ValueError(
            f"meshcat={config.meshcat!r} must be a pydrake.geometry.Meshcat (e.g. "
            "start_meshcat()) or None"
        )


class TaskGymEnv(CountedClockGymEnv):
    """DrakeGymEnv with what every task's env does the same (see the module docstring)."""

    def _start_gym(self, simulator, time_step, action_size, observation_size, render_mode) -> None:
        """DrakeGymEnv's setup: `simulator` (a Simulator, or a function making each episode's),
        actions in [-1, 1]^action_size, observations of `observation_size`, the `action`
        input and `observation` and `reward` outputs, `render_mode` None or "rgb_array" (the
        `color_image` output) or "human"."""
        # DrakeGymEnv writes into `self.metadata`: give it an instance copy, not the class's.
        self.metadata = dict(type(self).metadata)
        DrakeGymEnv.__init__(
            self,
            simulator=simulator,
            time_step=time_step,
            action_space=gym.spaces.Box(-1.0, 1.0, (action_size,), np.float32),
            observation_space=gym.spaces.Box(-np.inf, np.inf, (observation_size,), np.float32),
            reward="reward",
            action_port_id="action",
            observation_port_id="observation",
            render_rgb_port_id="color_image" if render_mode == "rgb_array" else None,
            render_mode=render_mode or "human",
            reset_handler=self._reset_handler,
        )
        self.render_mode = render_mode
        self.metadata = dict(type(self).metadata)
        # DrakeGymEnv 1.51 drops an `info_handler` argument (its check compares the handler
        # with `callable(handler)`), so it is set here, where its `step` and `reset` find it.
        self.info_handler = self._info_handler
        self._episode = {}
        self._last = None  # the last finite state's figures (the task's `step` keeps them)
        self._closed = False

    def _release_world(self) -> None:
        """Lets the last episode's diagram go, before a new one is built for the next."""
        if self.diagram is not None:
            release_diagram(self.diagram)

    def _add_views(self, builder, config) -> None:
        """The views `config` asks for (`check_views`), added to the episode's diagram: the
        `rgb_array` scene camera of `render_size` at `render_camera_position` looking at
        `render_camera_target`, and Meshcat (`meshcat`: a live view, and recordings)."""
        self._scene_view = None  # the rgb_array camera's, to draw the goal on its images
        if config.render_mode == "rgb_array":
            sensor = add_scene_camera(
                builder,
                self.world,
                *config.render_size,
                position=config.render_camera_position,
                target=config.render_camera_target,
            )
            self._scene_view = SceneView.of_sensor(sensor)
            self._scene_depth = sensor.depth_image_32F_output_port()  # what hides the goal
        self.visualizer = None
        if config.meshcat is not None:
            self.visualizer = add_meshcat_visualizer(
                builder, self.world.scene_graph, config.meshcat, self.scenario
            )

    def _reset_handler(self, simulator, context, seed) -> None:
        s = self._start_episode(context)
        if self.visualizer is not None:  # the goal marker where this episode's goal is
            show_task(self.config.meshcat, s)

    def render(self):
        """`rgb_array`: the scene camera's colour image, (H, W, 3) uint8, of `render_size`
        (W, H), seen from `render_camera_position` looking at `render_camera_target` (by
        default robot, tool, table, object and goal in view), with this episode's goal drawn
        on it: a translucent green disc of radius GOAL_RADIUS on the table, behind what
        stands in front of it (by the camera's depth image). The goal is drawn on the image
        (`systems.camera.draw_goal`), not put in the scene graph, so an env renders or not
        with the same physics. Without a render mode it warns and returns None, as
        Gymnasium's own envs do."""
        if self.render_mode is None:
            gym.logger.warn(
                "render() without a render mode: make the env with render_mode='rgb_array' "
                "(or 'human', where the env offers it)"
            )
            return None
        frame = super().render()
        if self.render_mode != "rgb_array":
            return frame
        frame = np.asarray(frame)[:, :, :3]
        goal = self._episode.get("goal")
        if goal is None or self._scene_view is None:  # before the first reset
            return frame.copy()
        p_WG = [goal[0], goal[1], self.scenario.table.top_z]
        depth = self._scene_depth.Eval(
            self._scene_depth.get_system().GetMyContextFromRoot(self._context)
        )
        return draw_goal(frame, self._scene_view, p_WG, GOAL_RADIUS, depth.data)

    def start_recording(self) -> None:
        """Records what follows in Meshcat (the env must be made with `meshcat=`)."""
        if self.visualizer is None:
            raise ValueError("this env has no Meshcat; make it with meshcat=start_meshcat()")
        self.visualizer.StartRecording(False)

    def save_recording(self, path) -> Path:
        """Writes the recording so far as one standalone HTML file."""
        return save_recording(self.config.meshcat, self.visualizer, path)

    def believed_poses(self):
        """(X_WT, X_WG): the tool's working frame's pose (the push task's tip, the pull
        task's hook corner) and the gripper's, in W, on the robot model (the believed tool)
        at the arm's current joint angles — what the robot thinks."""
        plant_context = self.world.plant.GetMyContextFromRoot(self.simulator.get_context())
        q = [joint.get_angle(plant_context) for joint in self.world.arm_joints()]
        return self.control.ik.fk(q), self.control.ik.fk_gripper(q)

    def commanded_tip_pose(self):
        """X_WT: where the IK's joint targets put the tool's working frame on the robot
        model — the pose the last step commanded (the arm lags it; `believed_poses` is where
        it got)."""
        context = self.ik_system.GetMyContextFromRoot(self.simulator.get_context())
        return self.control.ik.fk(self.ik_system.q_desired(context))

    def _start_episode(self, context):
        """The start of an episode (DrakeGymEnv's reset calls `_reset_handler`, which calls
        it): the contexts each step reads, looked up once (the simulator may be new), the
        scenario's state (drawn from its `randomization` with the env's seeded generator if
        `config.randomize`), the control at home, the goal and the box's start set in the
        task's systems and kept in `_episode` with its touches so far. Returns the episode's
        scenario."""
        self._context = context
        self._plant_context = self.world.plant.GetMyContextFromRoot(context)
        self._ik_context = self.ik_system.GetMyContextFromRoot(context)
        self._action_value = None  # the action input's fixed value, made by the first step
        s = self.scenario
        if self.config.randomize:
            s = apply_draw(s, draw_randomization(s, self.np_random))
        set_randomized_state(self.world, context, s)
        self.control.reset(context)
        start = initial_box_pose(s).translation()
        goal = start + np.asarray(s.goal_offset, float)
        self.task.set_episode(context, goal, start)
        self._object_position = start.tolist()
        self._episode = {
            "goal": goal,
            "start": start,
            "tool_touched": False,
            "gripper_touched": False,
        }
        return s

    def _check_open(self) -> None:
        if self._closed:
            raise gym.error.Error("this env is closed; make a new one")

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._check_open()
        if options:
            raise ValueError(f"reset options {options!r} are not supported; pass none")
        if seed is not None:
            seed = check_seed(seed, "seed")
        observation, info = super().reset(seed=seed)
        return np.asarray(observation, np.float32), info

    def _advance(self, action, action_mode: str):
        """Checks `action` (of `action_mode`), fixes it on the `action` input and advances one
        control period. Returns the plant's state vector, or None where the simulation failed
        (Drake raised, the state is no longer finite, or the object flew off:
        `builders.failures`)."""
        self._check_open()
        if self._last is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        values = np.asarray(action)
        kind = values.dtype.kind
        if kind not in "biuf":
            what = "complex" if kind == "c" else f"{values.dtype} (not numbers)"
            raise ValueError(f"action {action!r} is {what}; actions are real numbers in [-1, 1]")
        action = check_action(values, action_mode)
        context = self._context
        if self._action_value is None:
            fixed = self.action_port.FixValue(context, action)
            self._action_value = (fixed, fixed.GetMutableData().get_mutable_value())
        else:  # the same fixed value rewritten, not a new one each step (FixValue makes one)
            fixed, vector = self._action_value
            fixed.GetMutableData()  # tells its dependents that it changes
            vector.SetFromVector(action)
        if advance(self.simulator, self._next_step_time()) is not None:
            return None
        x = finite_state_vector(self.world.plant, self._plant_context)
        if x is None:
            return None
        p_object = self.world.box.EvalPoseInWorld(self._plant_context).translation().tolist()
        before, self._object_position = self._object_position, p_object
        if object_diverged(before, p_object, self.time_step, self._steps_done) is not None:
            return None
        return x

    def close(self) -> None:
        """Frees the diagram (pydrake would keep its Python systems, and with them the whole
        diagram, alive: `systems.lifetime`). The env cannot be used after."""
        if self._closed:
            return
        self._closed = True
        super().close()
        diagram = getattr(self, "diagram", None)
        if diagram is not None:
            release_diagram(diagram)
        for name in RELEASED_ATTRIBUTES:
            if hasattr(self, name):
                setattr(self, name, None)
