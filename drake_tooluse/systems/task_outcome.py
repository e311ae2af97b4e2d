"""A task's truth as ports: `TaskOutcome`, the one outcome system every task's is.

A task gives the three things that differ: a metrics reader (a `BoxAndToolPointReader`: its
`measure(body_poses, contacts, goal, start)` reads the task's metrics from the world plant's
body poses and contact results), a reward function of those metrics, and a maker of the
metrics' empty value (the port's model).
Success is the metrics' own `is_success`. The goal and the object's start are the system's
parameters, set per episode.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector

from drake_tooluse.systems.lifetime import weak_method
from drake_tooluse.systems.tool_tip_ik import NO_WITNESS_FUNCTIONS
from drake_tooluse.world.contacts import BoxContacts


class BoxAndToolPointReader:
    """Reads from the world plant what a task's metrics are made of: the box's centre, a point
    of the true tool (the origin of `frame`, a frame of `world.plant`) and which bodies touch
    the box; a task's reader gives `_metrics(p_box, p_point, contacts, goal, start)`."""

    def __init__(self, world, frame):
        self._box = world.box
        self._box_index = int(world.box.index())
        self._frame = frame
        # `measure`'s point, a pose on its body: X_WF = X_WB X_BF, as Drake's
        # `CalcPoseInWorld` (which `read` calls) forms it: the same arithmetic, so the same bits.
        self._frame_index = int(frame.body().index())
        self._X_BF = frame.GetFixedPoseInBodyFrame()
        self._contacts = world.plant.get_contact_results_output_port()
        self._touches = BoxContacts(world).touches

    def read(self, plant_context, goal, start):
        """The metrics of the plant's state in `plant_context`. The two poses it needs are read
        alone (the plant's body-poses port copies the same cached values for every body, and
        pydrake makes a Python object of each of its ~30)."""
        return self._metrics(
            self._box.EvalPoseInWorld(plant_context).translation(),
            self._frame.CalcPoseInWorld(plant_context).translation(),
            # The cached value itself (Eval would copy every contact into Python first).
            self._contacts.EvalAbstract(plant_context).get_value(),
            goal,
            start,
        )

    def measure(self, body_poses, contacts, goal, start):
        """The metrics of the plant's body poses (X_WB by body index) and contact results."""
        return self._metrics(
            body_poses[self._box_index].translation(),
            body_poses[self._frame_index].multiply(self._X_BF).translation(),
            contacts,
            goal,
            start,
        )

    def _metrics(self, p_box, p_point, contacts, goal, start):
        """The task's metrics of the box's centre and the tool point (m, W), the contact
        results, the goal and the box's start."""
        raise NotImplementedError


class TaskOutcome:
    """A task's truth as ports, the mixin of the task's outcome system (a LeafSystem:
    `class MyOutcome(TaskOutcome, LeafSystem)`, whose docstring holds its port block). It
    declares the inputs `body_poses` (the world plant's X_WB of every body) and
    `contact_results` (the plant's), and the outputs `metrics` (`reader.measure`'s value),
    `reward` ([reward(metrics)]) and `success` ([1.0] when the metrics' `is_success`, else
    [0.0]); its parameters are the goal (3, m) and the box's start (3, m), set per episode
    (`set_episode`)."""

    DoGetWitnessFunctions = NO_WITNESS_FUNCTIONS

    def __init__(self, world, reader, reward, empty_metrics, goal, start):
        """`reader.measure(body_poses, contacts, goal, start)` gives the metrics,
        `reward(metrics)` the step's reward; `empty_metrics()` makes the metrics port's model."""
        super().__init__()  # the LeafSystem's
        self._reader = reader
        self._reward = reward
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", world.plant.get_body_poses_output_port().Allocate()
        )
        self._contacts = self.DeclareAbstractInputPort(
            "contact_results", world.plant.get_contact_results_output_port().Allocate()
        )
        self._goal = self.DeclareNumericParameter(BasicVector(np.asarray(goal, float)))
        self._start = self.DeclareNumericParameter(BasicVector(np.asarray(start, float)))
        depends = {self.all_input_ports_ticket(), self.all_parameters_ticket()}
        self._metrics = self.DeclareAbstractOutputPort(
            "metrics",
            lambda: AbstractValue.Make(empty_metrics()),
            weak_method(self._calc_metrics),
            prerequisites_of_calc=depends,
        )
        self.DeclareVectorOutputPort(
            "reward", 1, weak_method(self._calc_reward), prerequisites_of_calc=depends
        )
        self.DeclareVectorOutputPort(
            "success", 1, weak_method(self._calc_success), prerequisites_of_calc=depends
        )

    def set_episode(self, context, goal, start) -> None:
        """This episode's goal and the object's start (m, W)."""
        context.get_mutable_numeric_parameter(self._goal).SetFromVector(goal)
        context.get_mutable_numeric_parameter(self._start).SetFromVector(start)

    @property
    def reader(self):
        """The task's metrics reader (`read(plant_context, goal, start)` reads the same
        metrics from the plant's context directly)."""
        return self._reader

    def goal(self, context) -> np.ndarray:
        return context.get_numeric_parameter(self._goal).get_value()

    def _calc_metrics(self, context, output) -> None:
        output.set_value(
            self._reader.measure(
                self._poses.Eval(context),
                self._contacts.Eval(context),
                context.get_numeric_parameter(self._goal).get_value(),
                context.get_numeric_parameter(self._start).get_value(),
            )
        )

    def _calc_reward(self, context, output) -> None:
        output.SetAtIndex(0, self._reward(self._metrics.Eval(context)))

    def _calc_success(self, context, output) -> None:
        output.SetAtIndex(0, float(self._metrics.Eval(context).is_success))
