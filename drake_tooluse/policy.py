"""A trained policy inside a Drake diagram, not through the Gym wrapper.

```
plant ──state──► ToolPushObservation ──► PolicySystem ──action──► tip control (control.py) ──► plant
```
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from drake_tooluse.control import TipControl, add_tip_control, add_world_at_home
from drake_tooluse.scenario import Scenario, check_tool_length, tool_length_or_none
from drake_tooluse.scene import World, goal_position, initial_box_pose
from drake_tooluse.task import OBSERVATION_SIZES, PushMetricsReader, ToolPushObservation
from drake_tooluse.train import LoadedPolicy, load_policy


class PolicySystem(LeafSystem):
    """Observation in, action out: a saved stable-baselines3 policy, deterministic, with its
    observation normalisation.

    The action is computed when it is evaluated (direct feedthrough, cached on the
    observation): the IK evaluates it once per control period, so the policy acts at the
    control period on the observation of that instant, exactly as in the Gym env.

    Input ports:
        observation: the task observation (see `task.py`), size of the policy's.
    Output ports:
        action: the policy's action (see `actions.py`), in [-1, 1].
    """

    def __init__(self, policy: LoadedPolicy):
        super().__init__()
        self._policy = policy
        self._obs = self.DeclareVectorInputPort("observation",
                                                policy.meta.observation_shape[0])
        self.DeclareVectorOutputPort("action", policy.meta.action_shape[0], self._calc,
                                     prerequisites_of_calc={self._obs.ticket()})

    def _calc(self, context, output):
        output.SetFromVector(np.asarray(self._policy.act(self._obs.Eval(context)), float))


@dataclass
class PolicyDiagram:
    diagram: object
    world: World
    control: TipControl
    observation: ToolPushObservation
    policy_system: PolicySystem
    visualizer: object = None


def build_policy_diagram(scenario: Scenario, policy_dir, believed_tool_length=None,
                         ik_mode: str = "full", meshcat=None,
                         scene_camera: bool = False, believed_grasp=(0.0, 0.0)) -> PolicyDiagram:
    """World (truth) + the policy closed-loop through tool-tip control on a robot model with
    `believed_tool_length` (default: the scenario's true length) held at `believed_grasp`
    (across, along) m. With `scene_camera`, the diagram exports the `color_image` of a camera
    looking at the work area."""
    policy = load_policy(policy_dir)
    kwargs = policy.meta.env_kwargs
    believed = tool_length_or_none(scenario) if believed_tool_length is None else (
        check_tool_length(believed_tool_length, "believed tool length"))
    n_obs = policy.meta.observation_shape[0]
    mode = kwargs.get("observation_mode", "paper")
    size = OBSERVATION_SIZES.get(mode)
    if size is None or n_obs not in (size, size + 1):
        raise ValueError(f"the policy in {str(policy_dir)!r} observes {n_obs} values with "
                         f"observation_mode={mode!r}; the push task gives "
                         f"{OBSERVATION_SIZES} (one more with the tool length)")
    include_length = n_obs == size + 1
    builder = DiagramBuilder()
    world, ik, q0 = add_world_at_home(builder, scenario, believed,
                                      believed_grasp=believed_grasp)
    control = add_tip_control(builder, world, ik, q0, kwargs.get("action_mode", "paper"), ik_mode)
    observation = builder.AddNamedSystem("observation", ToolPushObservation(
        world, ik.plant, goal_position(scenario), include_length, believed, mode))
    builder.Connect(world.plant.get_state_output_port(), observation.get_input_port())
    if control.target.GetInputPort("action").size() != policy.meta.action_shape[0]:
        raise ValueError(f"the policy's actions {policy.meta.action_shape} do not fit the "
                         f"action mode {kwargs.get('action_mode')!r}")
    policy_system = builder.AddNamedSystem("policy", PolicySystem(policy))
    builder.Connect(observation.get_output_port(), policy_system.get_input_port())
    builder.Connect(policy_system.get_output_port(), control.target.GetInputPort("action"))
    visualizer = None
    if meshcat is not None:
        from drake_tooluse.viz import add_meshcat_visualizer

        visualizer = add_meshcat_visualizer(builder, world.scene_graph, meshcat)
    if scene_camera:
        from drake_tooluse.viz import add_render_camera

        add_render_camera(builder, world)
    diagram = builder.Build()
    diagram.set_name("policy_control")
    return PolicyDiagram(diagram, world, control, observation, policy_system, visualizer)


@dataclass
class PushRun:
    """What happened in one push, from the world's truth."""

    steps: int  # control steps simulated
    success: bool  # the box ended at the goal (within the env's threshold)
    final_box_to_goal: float  # m
    box_travel: float  # m, from its start to where it ended
    tool_touched: bool
    gripper_touched: bool
    tip_path: np.ndarray  # (steps + 1, 3) true tool-tip positions at each control step
    box_path: np.ndarray  # (steps + 1, 3) box centre
    final_image: np.ndarray | None = None  # RGBA at the end, if the diagram has a scene camera

    def as_dict(self) -> dict:
        return {"steps": self.steps, "success": self.success,
                "final_box_to_goal_m": self.final_box_to_goal, "box_travel_m": self.box_travel,
                "tool_touched": self.tool_touched, "gripper_touched": self.gripper_touched}


def run_push(diagram, world: World, control: TipControl, max_steps: int,
             stop_at_success: bool = True, visualizer=None, on_step=None) -> PushRun:
    """Simulates a push diagram from its default state one control period at a time, for
    `max_steps` or until the box reaches the goal (as the env terminates) if
    `stop_at_success`. With a `visualizer`, the run is recorded. `on_step(step)` is called
    after each control step (progress displays)."""
    s = world.scenario
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    control.reset(root)
    if visualizer is not None:
        visualizer.StartRecording(False)
    simulator.Initialize()
    plant_context = world.plant.GetMyContextFromRoot(root)
    reader = PushMetricsReader(world)
    goal = goal_position(s)
    box_start = initial_box_pose(s).translation()
    tips, boxes = [], []
    tool_touched = gripper_touched = False
    period = s.control.control_period
    metrics = reader.read(plant_context, goal, box_start)
    step = 0
    for step in range(1, max_steps + 1):
        tips.append(world.tip_frame.CalcPoseInWorld(plant_context).translation())
        boxes.append(world.box.EvalPoseInWorld(plant_context).translation())
        simulator.AdvanceTo(step * period)
        metrics = reader.read(plant_context, goal, box_start)
        tool_touched |= metrics.tool_touches_box
        gripper_touched |= metrics.gripper_touches_box
        if on_step is not None:
            on_step(step)
        if stop_at_success and metrics.is_success:
            break
    tips.append(world.tip_frame.CalcPoseInWorld(plant_context).translation())
    boxes.append(world.box.EvalPoseInWorld(plant_context).translation())
    image = None
    if diagram.HasOutputPort("color_image"):
        image = diagram.GetOutputPort("color_image").Eval(root).data.copy()
    return PushRun(step, bool(metrics.is_success), float(metrics.box_to_goal),
                   float(metrics.box_travel), bool(tool_touched), bool(gripper_touched),
                   np.array(tips), np.array(boxes), image)


def run_policy(built: PolicyDiagram, max_steps: int = 100, record: bool = False,
               on_step=None) -> PushRun:
    """Runs the policy diagram from its default state until success (as the env terminates)
    or `max_steps`; recorded if `record` and the diagram has a visualizer."""
    return run_push(built.diagram, built.world, built.control, max_steps,
                    visualizer=built.visualizer if record else None, on_step=on_step)
