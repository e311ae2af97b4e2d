"""The tool-tip IK as a LeafSystem: a desired tool-tip pose in, joint targets out."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem

from drake_tooluse import compat
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.systems.lifetime import weak_method

# A marker for Python systems (a class attribute: `DoGetWitnessFunctions = NO_WITNESS_FUNCTIONS`).
# The simulator asks every system for its witness functions each time the state changes (a
# few times per control step); for a Python system pydrake's trampoline looks that name up on
# the object, and without it the lookup fails every time (an AttributeError made and dropped,
# then a look at the calling Python frame: microseconds each). A C++ function under the name is
# what pybind11 takes for "not overridden": it remembers that once per class, and Drake's
# default (no witness functions) runs.
NO_WITNESS_FUNCTIONS = compat.NO_WITNESS_FUNCTIONS  # pybind11's marker; nanobind's in compat


class ToolTipIKSystem(LeafSystem):
    """Desired tool-tip pose in, right-arm joint targets out; warm-started from its last
    solution. Solves once per control period (a periodic discrete update).

    .. pydrake_system::

        name: ToolTipIKSystem
        input_ports:
        - tip_pose_desired
        output_ports:
        - q_desired
        - desired_state
        - status

    Input ports:
        tip_pose_desired: [p_WT (3, m), quaternion wxyz (4)] — X_WT*, the desired tool-tip pose
            in W; the quaternion is normalized here (a zero one is an error).
    Output ports:
        q_desired: right-arm joint targets s0 … w2 (7, rad).
        desired_state: [q_desired (7), zeros (7)] — for the plant's PD desired-state input.
        status: [success (1/0), tip position error (m), orientation error (rad),
            consecutive failures] of the last solve. On an unreachable target the system holds
            its last valid solution and reports success 0 with the residual of the attempt.

    With `max_joint_speed` (7, rad/s), each joint target moves at most that speed × `period`
    per solve towards the IK's answer (a bound on the commanded joint velocity; the status
    still reports the solve). Default None: the IK's answer is the target.

    With `solve_before_plant_step`, the solve is an unrestricted update: it runs in the batch of
    the plant's own step (a MultibodyPlant with sampled output ports steps in an unrestricted
    update, and Drake applies those before the discrete updates due at the same time), so what
    it reads of the plant, through `tip_pose_desired`, is the state at the start of the step,
    the one a policy observed at the end of the last control period (tool-tip control). Default
    False: a discrete update, which would read the plant's state one plant step later
    (trajectory control, whose targets read no state).
    """

    DoGetWitnessFunctions = NO_WITNESS_FUNCTIONS

    def __init__(
        self,
        ik: ToolTipIK,
        q0,
        period: float,
        max_joint_speed=None,
        solve_before_plant_step: bool = False,
    ):
        super().__init__()
        self._ik = ik
        q0 = ik.check_q(q0, "q0")
        self._max_step, self._period = None, period
        if max_joint_speed is not None:
            speed = np.asarray(max_joint_speed, float).reshape(-1)
            if speed.shape != (7,) or not np.all(speed > 0) or not np.all(np.isfinite(speed)):
                raise ValueError(
                    f"max_joint_speed={speed.tolist()} must be 7 finite values > 0 rad/s"
                )
            self._max_step = speed * period
        self._pose_port = self.DeclareVectorInputPort("tip_pose_desired", 7)
        # Two state groups, each its own output port: Drake copies them out with no Python call.
        self._desired = self.DeclareDiscreteState(np.concatenate([q0, np.zeros(7)]))
        self._status = self.DeclareDiscreteState(np.array([1.0, 0.0, 0.0, 0.0]))
        self._desired_group, self._status_group = int(self._desired), int(self._status)
        # Callbacks through weak_method: a released diagram frees this system (lifetime.py).
        if solve_before_plant_step:
            self.DeclarePeriodicUnrestrictedUpdateEvent(
                period, 0.0, weak_method(self._unrestricted_update)
            )
        else:
            self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_method(self._update))
        self.DeclareVectorOutputPort(
            "q_desired", 7, weak_method(self._calc_q), prerequisites_of_calc={self.xd_ticket()}
        )
        self.DeclareStateOutputPort("desired_state", self._desired)
        # `ok` reads it (a cached copy of the state: cheaper in pydrake than
        # `get_discrete_state(index).get_value()`).
        self._status_port = self.DeclareStateOutputPort("status", self._status)

    @property
    def ik(self) -> ToolTipIK:
        return self._ik

    @property
    def max_joint_speed(self) -> np.ndarray | None:
        """The bound on the joint targets' speed (7 values, rad/s), or None where unbounded."""
        return None if self._max_step is None else self._max_step / self._period

    def q_desired(self, context) -> np.ndarray:
        """The joint targets of the last solve in `context` (this system's context)."""
        return context.get_discrete_state(self._desired).get_value()[:7].copy()

    def ok(self, context) -> bool:
        """Whether the last solve in `context` (this system's context) succeeded: the
        `status` port's first value."""
        return bool(self._status_port.Eval(context)[0] > 0.5)

    def _unrestricted_update(self, context, state):
        self._update(context, state.get_mutable_discrete_state())

    def _update(self, context, discrete_state):
        # `discrete_state` starts as a copy of the state (Drake fills it before the update), so
        # it holds the last solution too; `get_mutable_value(group)` is a view of a group,
        # pydrake's cheapest way to read and write one.
        desired = discrete_state.get_mutable_value(self._desired_group)
        status = discrete_state.get_mutable_value(self._status_group)
        # [p, quaternion]: the solver checks it and normalizes the quaternion. The seed, the
        # last solution, is only read (the solver clips a copy of it).
        result = self._ik.solve(self._pose_port.Eval(context), q_seed=desired[:7])
        errors = result.position_error, result.orientation_error
        if result.success:  # q* written; its velocities stay zeros (every write keeps them)
            if self._max_step is None:
                desired[:7] = result.q
            else:  # towards the answer at the bounded speed
                step = np.clip(result.q - desired[:7], -self._max_step, self._max_step)
                desired[:7] += step
            status[:] = (1.0, *errors, 0.0)
        else:  # hold the last valid solution (the desired state is left as it was)
            status[:] = (0.0, *errors, status[3] + 1)

    def _calc_q(self, context, output):
        output.SetFromVector(context.get_discrete_state(self._desired).get_value()[:7])
