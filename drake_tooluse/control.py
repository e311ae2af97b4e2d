"""Tool-tip control wired into a world: action → desired tool-tip pose → IK → joint targets.

```
action ──► TipTargetSystem ──X_WT*──► ToolTipIKSystem (full)            ──q*──► [q*, 0] ──► (delay) ──► plant
              ▲                     └► DifferentialIKIntegrator (differential)                             │
              └───────────────────────── measured arm state ◄──────────────────────────────────────────────┘

TrajectorySource (tool-tip poses) ──X_WT*──► ToolTipIKSystem ──q*──► [q*, 0] ──► (delay) ──► plant
```

Tip control is used by the Gymnasium envs and by the policy diagram, so both run the same
controller; trajectory control is the paper's open-loop transfer. The optional delay is the
scenario's `control.actuation_delay`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.primitives import (
    ConstantValueSource,
    ConstantVectorSource,
    DiscreteTimeDelay,
    Multiplexer,
)

from drake_tooluse.actions import TipTargetSystem, Workspace
from drake_tooluse.ik import (
    ToolTipIK,
    ToolTipIKSystem,
    add_differential_ik,
    home_configuration,
    joint_limit_kwargs,
    pose_to_vector,
)
from drake_tooluse.scene import World, add_world, home_tip_pose
from drake_tooluse.validation import check_one_of

IK_MODES = ("full", "differential")


@dataclass
class TipControl:
    target: TipTargetSystem | None  # None under trajectory control
    ik: ToolTipIK
    q0: np.ndarray
    ik_system: ToolTipIKSystem | None = None  # ik_mode "full"
    differential: object = None  # ik_mode "differential"
    delay: DiscreteTimeDelay | None = None  # the actuation delay, if any

    def reset(self, root_context) -> None:
        """Puts the IK's state back at the home configuration (episode start), and fills the
        actuation delay's buffer with the home target (not zeros: the arm would jump)."""
        if self.differential is not None:
            self.differential.SetPositions(
                self.differential.GetMyMutableContextFromRoot(root_context), self.q0)
        if self.delay is not None:
            delay_context = self.delay.GetMyMutableContextFromRoot(root_context)
            size = delay_context.get_discrete_state_vector().size()
            delay_context.SetDiscreteState(np.resize(np.concatenate([self.q0, np.zeros(7)]),
                                                     size))

    def ik_ok(self, root_context) -> bool:
        if self.ik_system is None:  # differential IK: its QP always returns a (scaled) step
            return True
        status = self.ik_system.GetOutputPort("status").Eval(
            self.ik_system.GetMyContextFromRoot(root_context))
        return bool(status[0] > 0.5)


def add_world_at_home(builder, scenario, believed_tool_length: float | None,
                      ik_attempts: int = 3, believed_grasp=(0.0, 0.0)):
    """The world, started at the home configuration the robot computes for the tool it
    believes it holds (length, and grasp (across, along) offset, m), and the IK on that
    belief. Returns (world, ik, q0)."""
    world = add_world(builder, scenario)
    q0 = home_configuration(scenario, believed_tool_length, believed_grasp)
    for joint, q in zip(world.arm_joints(), q0):
        joint.set_default_angle(q)
    return world, ToolTipIK(believed_tool_length, grasp_offset=believed_grasp,
                            max_attempts=ik_attempts,
                            **joint_limit_kwargs(scenario.robot.conservative_limits)), q0


def add_joint_command(builder, world: World, q_commanded, control: "TipControl") -> None:
    """Desired state [q*, 0] (joint targets held over the control period, zero velocity) to
    the plant's PD controllers, through the actuation delay if the scenario has one."""
    s = world.scenario
    zeros = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
    desired_state = builder.AddNamedSystem("desired_state", Multiplexer([7, 7]))
    builder.Connect(q_commanded, desired_state.get_input_port(0))
    builder.Connect(zeros.get_output_port(), desired_state.get_input_port(1))
    command = desired_state.get_output_port()
    steps = round(s.control.actuation_delay / s.plant.time_step)
    if steps > 0:
        # A DiscreteTimeDelay of N updates, sampled on the plant's own ticks, reaches the
        # plant's step N + 1 ticks late (its update reads the delay's output from before the
        # same tick): N = steps - 1 gives `actuation_delay` exactly (tested).
        control.delay = builder.AddNamedSystem(
            "actuation_delay", DiscreteTimeDelay(s.plant.time_step, steps - 1, 14))
        builder.Connect(command, control.delay.get_input_port())
        command = control.delay.get_output_port()
    builder.Connect(command, world.plant.get_desired_state_input_port(world.baxter))


def add_tip_control(builder, world: World, ik: ToolTipIK, q0, action_mode: str,
                    ik_mode: str) -> TipControl:
    """Adds the tip target, the IK (full or differential) and the desired-state mux, connected
    to the world's plant. The target's `action` input is left for the caller to connect."""
    check_one_of(ik_mode, IK_MODES, "ik_mode")
    s = world.scenario
    period = s.control.control_period
    target = builder.AddNamedSystem("tip_target", TipTargetSystem(
        action_mode, ik.plant, pose_to_vector(home_tip_pose(s)),
        Workspace.above_table(s.table.top_z)))
    arm_state = world.plant.get_state_output_port(world.baxter)
    builder.Connect(arm_state, target.GetInputPort("arm_state"))
    control = TipControl(target, ik, np.asarray(q0, float))
    if ik_mode == "full":
        control.ik_system = builder.AddNamedSystem("tool_tip_ik", ToolTipIKSystem(ik, q0, period))
        builder.Connect(target.GetOutputPort("tip_pose_desired"),
                        control.ik_system.GetInputPort("tip_pose_desired"))
        q_commanded = control.ik_system.GetOutputPort("q_desired")
    else:
        # Drake logs every switch of the differential IK into and out of "no solution" (a
        # target it cannot reach in one step: the arm holds); too chatty for training.
        logging.getLogger("drake").setLevel(logging.ERROR)
        control.differential = add_differential_ik(builder, ik, q0, period)
        builder.Connect(target.GetOutputPort("X_WT_desired"),
                        control.differential.GetInputPort("X_AE_desired"))
        # Linearize about the measured arm, as the full IK starts from it; integrating open
        # loop instead would let the target (measured + action) run away.
        builder.Connect(arm_state, control.differential.GetInputPort("robot_state"))
        use_measured = builder.AddSystem(ConstantValueSource(AbstractValue.Make(True)))
        builder.Connect(use_measured.get_output_port(),
                        control.differential.GetInputPort("use_robot_state"))
        q_commanded = control.differential.GetOutputPort("joint_positions")
    add_joint_command(builder, world, q_commanded, control)
    return control


def add_trajectory_control(builder, world: World, ik: ToolTipIK, q0, tip_source) -> TipControl:
    """Open loop: the 7-vector [p_WT, quaternion wxyz] output of `tip_source` (a Drake
    TrajectorySource, see `trajectory.tip_trajectory_source`) through the full tool-tip IK to
    the plant."""
    control = TipControl(None, ik, np.asarray(q0, float))
    period = world.scenario.control.control_period
    control.ik_system = builder.AddNamedSystem("tool_tip_ik", ToolTipIKSystem(ik, q0, period))
    builder.Connect(tip_source.get_output_port(),
                    control.ik_system.GetInputPort("tip_pose_desired"))
    add_joint_command(builder, world, control.ik_system.GetOutputPort("q_desired"), control)
    return control
