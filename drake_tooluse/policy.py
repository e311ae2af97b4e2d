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
from drake_tooluse.task import PushMetricsReader, ToolPushObservation
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
                         ik_mode: str = "full", meshcat=None) -> PolicyDiagram:
    """World (truth) + the policy closed-loop through tool-tip control on a robot model with
    `believed_tool_length` (default: the scenario's true length)."""
    policy = load_policy(policy_dir)
    kwargs = policy.meta.env_kwargs
    believed = tool_length_or_none(scenario) if believed_tool_length is None else (
        check_tool_length(believed_tool_length, "believed tool length"))
    include_length = policy.meta.observation_shape[0] == 31
    builder = DiagramBuilder()
    world, ik, q0 = add_world_at_home(builder, scenario, believed)
    control = add_tip_control(builder, world, ik, q0, kwargs.get("action_mode", "paper"), ik_mode)
    observation = builder.AddNamedSystem("observation", ToolPushObservation(
        world, ik.plant, goal_position(scenario), include_length, believed))
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
    diagram = builder.Build()
    diagram.set_name("policy_control")
    return PolicyDiagram(diagram, world, control, observation, policy_system, visualizer)


@dataclass
class PolicyRun:
    steps: int
    success: bool
    final_box_to_goal: float
    box_travel: float
    tool_touched: bool
    gripper_touched: bool
    tip_path: np.ndarray  # (steps + 1, 3) true tool-tip positions at each control step
    box_path: np.ndarray


def run_policy(built: PolicyDiagram, max_steps: int = 100, record: bool = False) -> PolicyRun:
    """Simulates the policy diagram from its default state, one control period at a time, and
    stops at success (as the env terminates) or after `max_steps`."""
    s = built.world.scenario
    simulator = Simulator(built.diagram)
    if record and built.visualizer is not None:
        built.visualizer.StartRecording(False)
    simulator.Initialize()
    root = simulator.get_context()
    plant_context = built.world.plant.GetMyContextFromRoot(root)
    reader = PushMetricsReader(built.world)
    goal = built.observation.goal(built.observation.GetMyContextFromRoot(root))
    box_start = initial_box_pose(s).translation()
    tips, boxes = [], []
    tool_touched = gripper_touched = False
    period = s.control.control_period
    metrics = reader.read(plant_context, goal, box_start)
    for step in range(1, max_steps + 1):
        tips.append(built.world.tip_frame.CalcPoseInWorld(plant_context).translation())
        boxes.append(built.world.box.EvalPoseInWorld(plant_context).translation())
        simulator.AdvanceTo(step * period)
        metrics = reader.read(plant_context, goal, box_start)
        tool_touched |= metrics.tool_touches_box
        gripper_touched |= metrics.gripper_touches_box
        if metrics.is_success:
            break
    tips.append(built.world.tip_frame.CalcPoseInWorld(plant_context).translation())
    boxes.append(built.world.box.EvalPoseInWorld(plant_context).translation())
    return PolicyRun(step, metrics.is_success, metrics.box_to_goal, metrics.box_travel,
                     tool_touched, gripper_touched, np.array(tips), np.array(boxes))
