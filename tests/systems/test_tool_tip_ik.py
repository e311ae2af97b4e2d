"""The tool-tip IK system: in a diagram with the world, and on an unreachable target."""

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_tooluse.robot.ik import ToolTipIK, pose_to_vector
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tool_tip_ik import ToolTipIKSystem
from drake_tooluse.world.scenario import Scenario
from drake_tooluse.world.scene import add_world

DOWN = RollPitchYaw(*TOOL_DOWN_RPY)


def test_ik_system_in_a_diagram_reaches_a_target():
    scenario = Scenario()
    target = RigidTransform(DOWN, [0.68, -0.15, -0.13])
    builder = DiagramBuilder()
    world = add_world(builder, scenario)
    ik = ToolTipIK(scenario.tool.length)
    q0 = ik.solve(RigidTransform(DOWN, [0.62, -0.3, -0.1]), scenario.robot.posture_seed).q
    for joint, q in zip(world.arm_joints(), q0):
        joint.set_default_angle(q)
    ik_system = builder.AddSystem(ToolTipIKSystem(ik, q0, scenario.control.control_period))
    source = builder.AddSystem(ConstantVectorSource(pose_to_vector(target)))
    builder.Connect(source.get_output_port(), ik_system.GetInputPort("tip_pose_desired"))
    builder.Connect(
        ik_system.GetOutputPort("desired_state"),
        world.plant.get_desired_state_input_port(world.baxter),
    )
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(2.0)
    plant_context = world.plant.GetMyContextFromRoot(simulator.get_context())
    p_WT = world.tip_frame.CalcPoseInWorld(plant_context).translation()
    assert np.linalg.norm(p_WT - target.translation()) < 1e-3
    status = ik_system.GetOutputPort("status").Eval(
        ik_system.GetMyContextFromRoot(simulator.get_context())
    )
    assert status[0] == 1.0 and status[1] < 1e-5


def test_ik_system_holds_last_solution_on_unreachable_target():
    scenario = Scenario()
    ik = ToolTipIK(scenario.tool.length, max_attempts=2)
    q0 = np.array(scenario.robot.posture_seed)
    system = ToolTipIKSystem(ik, q0, 0.04)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    pose = system.GetInputPort("tip_pose_desired")
    pose.FixValue(context, pose_to_vector(RigidTransform(DOWN, [0.68, -0.15, -0.13])))
    simulator.AdvanceTo(0.01)  # one update, at t = 0: a reachable target
    solved = system.GetOutputPort("q_desired").Eval(context).copy()
    assert system.GetOutputPort("status").Eval(context)[0] == 1.0
    assert np.abs(solved - q0).max() > 1e-3  # it moved: holding it is not holding q0
    pose.FixValue(context, pose_to_vector(RigidTransform(DOWN, [3.0, 0.0, 0.0])))
    simulator.AdvanceTo(0.09)  # two more updates (t = 0.04, 0.08), both unreachable
    np.testing.assert_array_equal(system.GetOutputPort("q_desired").Eval(context), solved)
    desired = system.GetOutputPort("desired_state").Eval(context)
    np.testing.assert_array_equal(desired, np.concatenate([solved, np.zeros(7)]))
    status = system.GetOutputPort("status").Eval(context)
    assert status[0] == 0.0 and status[1] > 1.0 and status[3] == 2.0  # failures counted
