"""Gymnasium environments of the push task (the paper's Env1, Env2, Env3) on DrakeGymEnv.

```
action ──► TipTargetSystem ──X_WT*──► ToolTipIKSystem ──q*──► plant (in-plant PD) ──state──►
           (tool-tip space)           (robot model)                                 ToolPushObservation ──► observation
```

Registered ids (on `import drake_tooluse`), each truncated at 100 steps of 40 ms:

| id | paper | reward |
| --- | --- | --- |
| `drake_tooluse/ToolPush-v0` | Env1 | −(d(x, x*) + d(x, y)) |
| `drake_tooluse/ToolPushBoxReward-v0` | Env2 | −d(x, x*) |
| `drake_tooluse/ToolPushFar-v0` | Env3 | as Env1, the goal 0.10 m further |

x: box centre, x*: goal, y: the true tool tip. Success (terminated) when d(x, x*) + d(x, y)
≤ 0.05 m. The box starts at (0.70, −0.25) on the table and is pushed along +y: the goal is
0.20 m away (Env3: 0.30 m).
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

import gymnasium as gym
import numpy as np
from pydrake.gym import DrakeGymEnv
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.actions import ACTION_MODES, check_action
from drake_tooluse.control import IK_MODES, add_tip_control, add_world_at_home
from drake_tooluse.scenario import (
    Scenario,
    draw_randomization,
    load_scenario,
    tool_length_or_none,
    with_tool_length,
)
from drake_tooluse.scene import GRASP_FRAME, goal_position, initial_box_pose
from drake_tooluse.task import OBSERVATION_SIZES, PushMetricsReader, ToolPushObservation
from drake_tooluse.validation import check_in_range, check_one_of

REWARD_TYPES = ("tool_and_box", "box")


@dc.dataclass
class EnvConfig:
    """The keyword arguments of `ToolPushEnv` (and of `gym.make`)."""

    scenario: object = None  # a Scenario, a YAML path, or None for diagrams/push.yaml defaults
    tool_length: float | None = None  # overrides the scenario's (m)
    reward_type: str = "tool_and_box"
    goal_extra: float = 0.0  # m added to the goal distance along y
    action_mode: str = "paper"
    include_tool_length: bool = False
    observation_mode: str = "paper"  # "paper" or "tip" (see task.py)
    randomize: bool = False  # ranges: the scenario's `randomization`
    render_mode: str | None = None
    # "full": Drake InverseKinematics on the tool tip, warm-started, every control period;
    # "differential": Drake's differential IK integrator (first order, cheaper; for training).
    ik_mode: str = "full"
    meshcat: object = None  # a Meshcat instance to draw the episode in (for recordings)


def _config(kwargs) -> EnvConfig:
    allowed = [f.name for f in dc.fields(EnvConfig)]
    unknown = sorted(set(kwargs) - set(allowed))
    if unknown:
        raise TypeError(f"unknown argument(s) {unknown} for a drake_tooluse env; allowed: "
                        f"{allowed}")
    config = EnvConfig(**kwargs)
    check_one_of(config.reward_type, REWARD_TYPES, "reward_type")
    check_one_of(config.action_mode, tuple(ACTION_MODES), "action_mode")
    check_one_of(config.render_mode, (None, "rgb_array", "human"), "render_mode")
    check_one_of(config.ik_mode, IK_MODES, "ik_mode")
    check_one_of(config.observation_mode, tuple(OBSERVATION_SIZES), "observation_mode")
    check_in_range(config.goal_extra, -0.15, 0.25, "goal_extra", unit="m")
    return config


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


class ToolPushEnv(DrakeGymEnv):
    """The push task as a Gymnasium env (see the module docstring for ids and rewards).

    Keyword arguments (`EnvConfig`): scenario, tool_length, reward_type ("tool_and_box" or
    "box"), goal_extra, action_mode ("paper", "pose", "position"), include_tool_length,
    observation_mode ("paper", "tip"),
    randomize, render_mode (None, "rgb_array", "human"), meshcat.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 25}

    def __init__(self, **kwargs):
        config = _config(kwargs)
        self.config = config
        self.scenario = _scenario(config)
        self._build(config)
        n_obs = OBSERVATION_SIZES[config.observation_mode] + int(config.include_tool_length)
        # DrakeGymEnv writes into `self.metadata`: give it an instance copy, not the class's.
        self.metadata = dict(type(self).metadata)
        super().__init__(
            simulator=self._simulator, time_step=self.scenario.control.control_period,
            action_space=gym.spaces.Box(-1.0, 1.0, (ACTION_MODES[config.action_mode],),
                                        np.float32),
            observation_space=gym.spaces.Box(-np.inf, np.inf, (n_obs,), np.float32),
            reward=lambda system, context: self._last_reward, action_port_id="action",
            observation_port_id="observation",
            render_rgb_port_id="color_image" if config.render_mode == "rgb_array" else None,
            render_mode=config.render_mode or "human", reset_handler=self._reset_handler)
        self.render_mode = config.render_mode
        self.metadata = dict(type(self).metadata)
        self._last_reward = 0.0
        self._episode = {}

    # -- the diagram ----------------------------------------------------------------------
    def _build(self, config: EnvConfig) -> None:
        s = self.scenario
        believed = tool_length_or_none(s)
        builder = DiagramBuilder()
        world, ik, q0 = add_world_at_home(builder, s, believed)
        self.control = add_tip_control(builder, world, ik, q0, config.action_mode,
                                       config.ik_mode)
        self.ik_system = self.control.ik_system
        observation = builder.AddNamedSystem("observation", ToolPushObservation(
            world, ik.plant, goal_position(s), config.include_tool_length, believed,
            config.observation_mode))
        builder.Connect(world.plant.get_state_output_port(), observation.get_input_port())
        builder.ExportInput(self.control.target.GetInputPort("action"), "action")
        builder.ExportOutput(observation.get_output_port(), "observation")
        if config.render_mode == "rgb_array":
            from drake_tooluse.viz import add_render_camera

            add_render_camera(builder, world)
        self.visualizer = None
        if config.meshcat is not None:
            from drake_tooluse.viz import add_meshcat_visualizer

            self.visualizer = add_meshcat_visualizer(builder, world.scene_graph, config.meshcat)
        diagram = builder.Build()
        diagram.set_name("tool_push_env")
        self.world, self.target_system = world, self.control.target
        self.observation_system = observation
        self.diagram = diagram
        self._metrics = PushMetricsReader(world)
        self._simulator = Simulator(diagram)

    # -- Gymnasium API --------------------------------------------------------------------
    def _reset_handler(self, simulator, context, seed) -> None:
        s = self.scenario
        plant = self.world.plant
        plant_context = plant.GetMyMutableContextFromRoot(context)
        X_WB = initial_box_pose(s)
        if self.config.randomize:
            d = draw_randomization(s, self.np_random)
            X_WB = RigidTransform(RotationMatrix.MakeZRotation(s.box.yaw + d.box_dyaw),
                                  X_WB.translation() + np.array([*d.box_dxy, 0.0]))
            self.world.box.SetMass(plant_context, s.box.mass * d.box_mass_scale)
            self._set_box_friction(context, s.box.friction * d.box_friction_scale)
            if self.world.tool is not None:
                plant.GetFrameByName(GRASP_FRAME).SetPoseInParentFrame(
                    plant_context, RigidTransform([s.tool.grasp_offset_across + d.grasp_across,
                                                   0.0, s.tool.grasp_offset_along + d.grasp_along]))
        plant.SetFreeBodyPose(plant_context, self.world.box, X_WB)
        self.control.reset(context)
        box_start = X_WB.translation()
        goal = box_start + np.asarray(s.goal_offset, float)
        self.observation_system.set_goal(
            self.observation_system.GetMyMutableContextFromRoot(context), goal)
        self._episode = {"goal": goal, "box_start": box_start, "tool_touched": False,
                         "gripper_touched": False}

    def _set_box_friction(self, context, friction: float) -> None:
        from pydrake.geometry import ProximityProperties, RoleAssign
        from pydrake.multibody.plant import CoulombFriction

        sg = self.world.scene_graph
        sg_context = sg.GetMyMutableContextFromRoot(context)
        inspector = sg.model_inspector()
        for gid in self.world.plant.GetCollisionGeometriesForBody(self.world.box):
            props = ProximityProperties(inspector.GetProximityProperties(gid))
            props.UpdateProperty("material", "coulomb_friction",
                                 CoulombFriction(friction, friction))
            sg.AssignRole(sg_context, self.world.plant.get_source_id(), gid, props,
                          RoleAssign.kReplace)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if options:
            raise ValueError(f"reset options {options!r} are not supported; pass none")
        observation, _ = super().reset(seed=seed)
        info = self._info(self._read_metrics(), sim_error=False)
        return np.asarray(observation, np.float32), info

    def step(self, action):
        action = check_action(action, self.config.action_mode)
        context = self.simulator.get_mutable_context()
        self.action_port.FixValue(context, action)
        sim_error = False
        try:
            self.simulator.AdvanceTo(context.get_time() + self.time_step)
        except RuntimeError:  # a simulation failure truncates the episode, with a flag
            sim_error = True
        observation = np.asarray(self.observation_port.Eval(context), np.float32)
        m = self._read_metrics()
        if self.config.reward_type == "box":
            reward = -m.box_to_goal
        else:
            reward = -(m.box_to_goal + m.tip_to_box)
        self._last_reward = reward
        return observation, float(reward), bool(m.is_success), sim_error, self._info(
            m, sim_error)

    def render(self):
        """`rgb_array`: the fixed scene camera's colour image, (H, W, 3) uint8."""
        frame = super().render()
        if self.render_mode == "rgb_array":
            return np.asarray(frame)[:, :, :3].copy()
        return frame

    # -- Meshcat recordings ---------------------------------------------------------------
    def start_recording(self) -> None:
        """Records what follows in Meshcat (the env must be made with `meshcat=`)."""
        if self.visualizer is None:
            raise ValueError("this env has no Meshcat; make it with meshcat=start_meshcat()")
        self.visualizer.StartRecording(False)

    def save_recording(self, path) -> Path:
        """Writes the recording so far as one standalone HTML file."""
        from drake_tooluse.viz import save_recording

        return save_recording(self.config.meshcat, self.visualizer, path)

    def believed_poses(self):
        """(X_WT, X_WG): the tool tip's and the gripper's poses in W on the robot model (the
        believed tool) at the arm's current joint angles — what the robot thinks."""
        plant_context = self.world.plant.GetMyContextFromRoot(self.simulator.get_context())
        q = [joint.get_angle(plant_context) for joint in self.world.arm_joints()]
        return self.control.ik.fk(q), self.control.ik.fk_gripper(q)

    def _read_metrics(self):
        plant_context = self.world.plant.GetMyContextFromRoot(self.simulator.get_context())
        m = self._metrics.read(plant_context, self._episode["goal"], self._episode["box_start"])
        self._episode["tool_touched"] |= m.tool_touches_box
        self._episode["gripper_touched"] |= m.gripper_touches_box
        return m

    def _info(self, m, sim_error: bool) -> dict:
        return {"is_success": bool(m.is_success), "box_to_goal": m.box_to_goal,
                "tip_to_box": m.tip_to_box, "box_travel": m.box_travel,
                "tool_touches_box": m.tool_touches_box,
                "gripper_touches_box": m.gripper_touches_box,
                "tool_touched_box_in_episode": self._episode["tool_touched"],
                "gripper_touched_box_in_episode": self._episode["gripper_touched"],
                "ik_ok": self.control.ik_ok(self.simulator.get_context()), "sim_error": sim_error}
