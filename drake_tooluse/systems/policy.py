"""A trained policy as a Drake LeafSystem."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem

from drake_tooluse.systems.lifetime import weak_method


class PolicySystem(LeafSystem):
    """Observation in, action out: a saved stable-baselines3 policy, deterministic, with its
    observation normalisation.

    .. pydrake_system::

        name: PolicySystem
        input_ports:
        - observation
        output_ports:
        - action

    The action is computed when it is evaluated (direct feedthrough, cached on the
    observation): the IK evaluates it once per control period, so the policy acts at the
    control period on the observation of that instant, exactly as in the Gym env.

    Input ports:
        observation: the task observation (see `tasks.push.observation`), size of the policy's.
    Output ports:
        action: the policy's action (see `systems.tip_target`), in [-1, 1].

    Args:
        policy: a loaded policy (`learning.policy_dir.load_policy`): its `act(observation)`
            and `meta.observation_shape` / `meta.action_shape` are used.
    """

    def __init__(self, policy):
        super().__init__()
        self._policy = policy
        self._obs = self.DeclareVectorInputPort("observation", policy.meta.observation_shape[0])
        self.DeclareVectorOutputPort(
            "action",
            policy.meta.action_shape[0],
            weak_method(self._calc),
            prerequisites_of_calc={self._obs.ticket()},
        )

    def _calc(self, context, output):
        output.SetFromVector(np.asarray(self._policy.act(self._obs.Eval(context)), float))
