"""What a task's observation system shares: `GoalObservation`, plant state in, the observation
of that state and the episode's goal out, all NaN where the state is not finite.

A task's observation system is a LeafSystem with it as a mixin, and gives
`finite_observation(x, goal)`.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector

from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.systems.tool_tip_ik import NO_WITNESS_FUNCTIONS
from drake_tooluse.validation import all_finite


class GoalObservation:
    """Plant state in, a task's observation of it and of the goal out: the mixin of the
    task's observation system (a LeafSystem: `class MyObservation(GoalObservation,
    LeafSystem)`, whose docstring holds its port block). It declares the input `plant_state`
    (the world plant's full state [q, v]) and the output `observation` (`size` values,
    `finite_observation(x, goal)`; all NaN when the state is not finite); its parameter is the
    goal (3, m), set per episode (`set_goal`)."""

    DoGetWitnessFunctions = NO_WITNESS_FUNCTIONS

    def __init__(self, world, goal, size: int):
        super().__init__()  # the LeafSystem's
        plant = world.plant
        self._size = size
        self._state = self.DeclareVectorInputPort(
            "plant_state", plant.num_positions() + plant.num_velocities()
        )
        self._goal = self.DeclareNumericParameter(BasicVector(np.asarray(goal, float)))
        self.DeclareVectorOutputPort(
            "observation",
            size,
            weak_method(self._calc),
            prerequisites_of_calc={self.all_input_ports_ticket(), self.all_parameters_ticket()},
        )

    def set_goal(self, context, goal) -> None:
        context.get_mutable_numeric_parameter(self._goal).SetFromVector(goal)

    def goal(self, context) -> np.ndarray:
        return context.get_numeric_parameter(self._goal).get_value()

    def _calc(self, context, output):
        output.SetFromVector(self.observation(self._state.Eval(context), self.goal(context)))

    def observation(self, x, goal) -> np.ndarray:
        """The observation of the plant state x and the goal; NaN where x is not finite (a
        failed simulation: the robot model refuses such joint angles)."""
        if not all_finite(x):
            return np.full(self._size, np.nan)
        return self.finite_observation(x, goal)

    def finite_observation(self, x, goal) -> np.ndarray:
        """`observation` of a plant state x known to be finite (not checked again)."""
        raise NotImplementedError
