"""The tool-tip IK as a LeafSystem: a desired tool-tip pose in, joint targets out."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem

from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.systems.lifetime import weak_method


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
    """

    def __init__(self, ik: ToolTipIK, q0, period: float):
        super().__init__()
        self._ik = ik
        q0 = ik.check_q(q0, "q0")
        self._pose_port = self.DeclareVectorInputPort("tip_pose_desired", 7)
        # Two state groups, each its own output port: Drake copies them out with no Python call.
        self._desired = self.DeclareDiscreteState(np.concatenate([q0, np.zeros(7)]))
        self._status = self.DeclareDiscreteState(np.array([1.0, 0.0, 0.0, 0.0]))
        # Callbacks through weak_method: a released diagram frees this system (lifetime.py).
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, weak_method(self._update))
        self.DeclareVectorOutputPort(
            "q_desired", 7, weak_method(self._calc_q), prerequisites_of_calc={self.xd_ticket()}
        )
        self.DeclareStateOutputPort("desired_state", self._desired)
        self.DeclareStateOutputPort("status", self._status)

    @property
    def ik(self) -> ToolTipIK:
        return self._ik

    def q_desired(self, context) -> np.ndarray:
        """The joint targets of the last solve in `context` (this system's context)."""
        return context.get_discrete_state(self._desired).get_value()[:7].copy()

    def _update(self, context, discrete_state):
        q_last = context.get_discrete_state(self._desired).get_value()[:7]
        failures = context.get_discrete_state(self._status).get_value()[3]
        # [p, quaternion]: the solver checks it and normalizes the quaternion.
        result = self._ik.solve(self._pose_port.Eval(context), q_seed=q_last)
        status = discrete_state.get_mutable_vector(self._status)
        if result.success:
            discrete_state.get_mutable_vector(self._desired).SetFromVector(
                np.concatenate([result.q, np.zeros(7)])
            )
            status.SetFromVector([1.0, result.position_error, result.orientation_error, 0.0])
        else:  # hold the last valid solution (the desired state is left as it was)
            status.SetFromVector(
                [0.0, result.position_error, result.orientation_error, failures + 1]
            )

    def _calc_q(self, context, output):
        output.SetFromVector(context.get_discrete_state(self._desired).get_value()[:7])
