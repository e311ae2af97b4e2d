"""Tool-tip control wired into a world: action → desired tool-tip pose → IK → joint targets.

```
action ──► TipTargetSystem ──X_WT*──► ToolTipIKSystem ──[q*, 0]──► (delay) ──► plant
              ▲                                                                   │
              └──────────────── measured arm state ◄──────────────────────────────┘

TrajectorySource (tool-tip poses) ──X_WT*──► ToolTipIKSystem ──[q*, 0]──► (delay) ──► plant
```

One IK runs in every loop: the exact tool-tip IK (`robot.ik`). (A first-order mode, Drake's
`DifferentialInverseKinematicsIntegrator`, was retired once the exact IK measured faster; see
docs/BENCHMARKS.md.) Tip control is used by the Gymnasium envs and by the policy diagram, so
both run the same controller; trajectory control serves the waypoint simulation and the paper's open-loop
transfer. Every path from a target to the plant goes through `add_joint_command`, so each
honours the scenario's `control.actuation_delay`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.primitives import ConstantVectorSource, DiscreteTimeDelay, Multiplexer

from drake_tooluse.robot.baxter_model import V_MAX
from drake_tooluse.robot.ik import ToolTipIK, joint_limit_kwargs, pose_to_vector
from drake_tooluse.robot.model import TIP_FRAME, RobotBelief
from drake_tooluse.systems.tip_target import TipTargetSystem, Workspace
from drake_tooluse.systems.tool_tip_ik import ToolTipIKSystem
from drake_tooluse.world.scenario import tool_length_or_none
from drake_tooluse.world.scene import World, add_world, home_tip_pose, true_tool

# The IK in the loop, per control step: the warm start (the last answer) nearly always holds;
# if not, a few fast-path starts from each seed library, then one SNOPT solve from the warm
# start (by then the target has usually left the arm's reach: in 3,000 random-action steps
# the fallback ran 17 times and never found an answer, at milliseconds each). The home pose,
# solved once per diagram, may take more.
IK_LIBRARY_STARTS = 4
IK_ATTEMPTS = 1
HOME_IK_ATTEMPTS = 16


@dataclass
class TipControl:
    target: TipTargetSystem | None  # None under trajectory control
    ik: ToolTipIK
    q0: np.ndarray
    ik_system: ToolTipIKSystem | None = None
    delay: DiscreteTimeDelay | None = None  # the actuation delay, if any

    def reset(self, root_context) -> None:
        """Puts the IK's state back at the home configuration (episode start), and fills the
        actuation delay's buffer with the home target (not zeros: the arm would jump)."""
        if self.delay is not None:
            delay_context = self.delay.GetMyMutableContextFromRoot(root_context)
            size = delay_context.get_discrete_state_vector().size()
            delay_context.SetDiscreteState(np.resize(np.concatenate([self.q0, np.zeros(7)]), size))

    def ik_ok(self, root_context) -> bool:
        """Whether the IK's last solve succeeded (it holds its last answer where not)."""
        return self.ik_system.ok(self.ik_system.GetMyContextFromRoot(root_context))


def nominal_belief(scenario) -> RobotBelief:
    """A robot told its tool's length (or, for a hook or a tool model file, its geometry) and
    nothing else (the nominal grasp)."""
    if scenario.tool.attached and (scenario.tool.model or scenario.tool.kind != "straight"):
        return RobotBelief(true_tool(scenario))
    return RobotBelief(tool_length_or_none(scenario))


def home_configuration(scenario, ik: ToolTipIK, home=None) -> np.ndarray:
    """Right-arm joint angles that put the IK's frame at `home` (X_WF; default the scenario's
    home pose, `home_tip_pose`) on the robot model of `ik` (the believed tool), warm-started
    from the scenario's posture seed. Raises if unreachable."""
    X_WT = home_tip_pose(scenario) if home is None else home
    result = ik.solve(X_WT, q_seed=scenario.robot.posture_seed, max_attempts=HOME_IK_ATTEMPTS)
    if not result.success:
        limits = (
            " within the conservative joint limits" if scenario.robot.conservative_limits else ""
        )
        raise ValueError(
            f"the scenario's home pose (tip at {X_WT.translation().tolist()} m) is unreachable "
            f"with tool length {ik.tool_length} m: residual {result.position_error:.3g} m, "
            f"{result.orientation_error:.3g} rad{limits}; move robot.home_tip_xy / "
            "home_tip_height"
        )
    return result.q


def robot_ik(scenario, belief: RobotBelief, frame: str = TIP_FRAME) -> ToolTipIK:
    """The IK on the robot model of `belief` for the tool's `frame` (default its tip), with the
    joint limits the scenario's robot keeps."""
    return ToolTipIK(
        belief.tool,
        frame=frame,
        grasp_offset=belief.grasp_offset,
        max_attempts=IK_ATTEMPTS,
        library_starts=IK_LIBRARY_STARTS,
        **joint_limit_kwargs(scenario.robot.conservative_limits),
    )


def add_world_at_home(
    builder,
    scenario,
    belief: RobotBelief | None = None,
    frame: str = TIP_FRAME,
    home=None,
    visuals: bool = True,
):
    """The world, started at the home configuration the robot computes for the tool it
    believes it holds (default: `nominal_belief`), and the IK on that belief for the tool's
    `frame` (default its tip), which the home configuration puts at `home` (X_WF; default
    `home_tip_pose`). `visuals`: as `world.scene.add_world`'s. Returns (world, ik, q0)."""
    belief = nominal_belief(scenario) if belief is None else belief
    world = add_world(builder, scenario, visuals)
    ik = robot_ik(scenario, belief, frame)
    q0 = home_configuration(scenario, ik, home)
    for joint, q in zip(world.arm_joints(), q0):
        joint.set_default_angle(q)
    return world, ik, q0


def add_joint_command(
    builder, world: World, command, control: TipControl, updated_before_plant: bool = False
) -> None:
    """Joint targets to the plant's PD controllers, through the actuation delay if the
    scenario has one. `command` is an output port of the desired state [q* (7), v* (7)], or
    of q* alone (7: held over the control period, zero velocity appended);
    `updated_before_plant`: it changes in the plant's own update batch (`ToolTipIKSystem`'s
    `solve_before_plant_step`), not after it."""
    s = world.scenario
    if command.size() == 7:
        zeros = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
        desired_state = builder.AddNamedSystem("desired_state", Multiplexer([7, 7]))
        builder.Connect(command, desired_state.get_input_port(0))
        builder.Connect(zeros.get_output_port(), desired_state.get_input_port(1))
        command = desired_state.get_output_port()
    steps = round(s.control.actuation_delay / s.plant.time_step)
    if steps > 0:
        # A DiscreteTimeDelay of N updates, sampled on the plant's own ticks, reaches the
        # plant's step N + 1 ticks late (its update reads the delay's output from before the
        # same tick): N = steps - 1 gives `actuation_delay` exactly (tested). A command that
        # changes in the plant's batch is sampled by the delay one tick sooner than the plant
        # would read it: one update more.
        updates = steps - 1 + int(updated_before_plant)
        control.delay = builder.AddNamedSystem(
            "actuation_delay", DiscreteTimeDelay(s.plant.time_step, updates, 14)
        )
        builder.Connect(command, control.delay.get_input_port())
        command = control.delay.get_output_port()
    builder.Connect(command, world.plant.get_desired_state_input_port(world.baxter))


def add_tip_control(
    builder,
    world: World,
    ik: ToolTipIK,
    q0,
    action_mode: str,
    home=None,
    workspace=None,
) -> TipControl:
    """Adds the tip target, the IK system and the joint command, connected to the world's
    plant. The target moves the IK's frame; `position` actions hold the orientation of `home`
    (X_WF; default `home_tip_pose`), and the target stays in `workspace` (default
    `Workspace.above_table`). The target's `action` input is left for the caller to connect.

    The joint targets move at most at Baxter's rated joint speeds (`V_MAX`), so that no
    action flings the arm through the table, and the IK solves in the plant's update batch, so
    that the target moves from the arm state the policy observed, not from the plant's state
    one plant step later (`ToolTipIKSystem`)."""
    s = world.scenario
    target = builder.AddNamedSystem(
        "tip_target",
        TipTargetSystem(
            action_mode,
            ik.chain,
            pose_to_vector(home_tip_pose(s) if home is None else home),
            Workspace.above_table(s.table.top_z) if workspace is None else workspace,
        ),
    )
    builder.Connect(
        world.plant.get_state_output_port(world.baxter), target.GetInputPort("arm_state")
    )
    control = TipControl(target, ik, np.asarray(q0, float))
    control.ik_system = builder.AddNamedSystem(
        "tool_tip_ik",
        ToolTipIKSystem(ik, q0, s.control.control_period, V_MAX, solve_before_plant_step=True),
    )
    builder.Connect(
        target.GetOutputPort("tip_pose_desired"), control.ik_system.GetInputPort("tip_pose_desired")
    )
    add_joint_command(
        builder,
        world,
        control.ik_system.GetOutputPort("desired_state"),
        control,
        updated_before_plant=True,
    )
    return control


def add_trajectory_control(builder, world: World, ik: ToolTipIK, q0, tip_source) -> TipControl:
    """Open loop: the 7-vector [p_WT, quaternion wxyz] output of `tip_source` (a Drake
    TrajectorySource, see `systems.tip_trajectory.tip_trajectory_source`) through the full
    tool-tip IK and the joint command to the plant."""
    control = TipControl(None, ik, np.asarray(q0, float))
    period = world.scenario.control.control_period
    control.ik_system = builder.AddNamedSystem("tool_tip_ik", ToolTipIKSystem(ik, q0, period))
    builder.Connect(
        tip_source.get_output_port(), control.ik_system.GetInputPort("tip_pose_desired")
    )
    add_joint_command(builder, world, control.ik_system.GetOutputPort("desired_state"), control)
    return control
