"""What a simulation failure looks like from Python, caught where a run advances.

Drake reports a failed step (a solver that does not converge, a non-finite pose reaching
SceneGraph) as a `RuntimeError`. A failed check in its inline C++ (`DRAKE_THROW_UNLESS`, e.g.
`MultibodyPlant.SetPositions` given NaN inside a Python system's calc) reaches Python as a
`SystemExit` whose message starts "Failure at": left alone it would end the process.
`advance` turns both into a message; anything else propagates.
"""

from __future__ import annotations

import math

import numpy as np

from drake_tooluse.validation import all_finite

DRAKE_FAILURE = "Failure at "


def failure_message(error: BaseException) -> str | None:
    """The one-line message of a Drake simulation failure, or None if `error` is not one."""
    if isinstance(error, SystemExit) and not str(error).startswith(DRAKE_FAILURE):
        return None
    if not isinstance(error, (RuntimeError, SystemExit)):
        return None
    lines = str(error).strip().splitlines()
    return (lines[0] if lines else type(error).__name__)[:300]


def advance(simulator, time: float) -> str | None:
    """`simulator.AdvanceTo(time)`; None, or the failure's message."""
    try:
        simulator.AdvanceTo(time)
    except (RuntimeError, SystemExit) as e:
        message = failure_message(e)
        if message is None:
            raise
        return message
    return None


def finite_state(plant, plant_context) -> bool:
    """Whether the plant's positions and velocities are all finite (read without running any
    Python system)."""
    return finite_state_vector(plant, plant_context) is not None


def finite_state_vector(plant, plant_context) -> np.ndarray | None:
    """The plant's positions and velocities [q, v] where all are finite, else None (read
    without running any Python system)."""
    x = plant.GetPositionsAndVelocities(plant_context)
    # A finite dot product proves every value finite in one C call (`all_finite`'s sum goes
    # through numpy's Python code); only where it is not does `all_finite` decide.
    return x if math.isfinite(x.dot(x)) or all_finite(x) else None


# m/s: the arm moves the tool's target at most 0.5 m/s; an object faster than this between two
# control steps was flung by a contact solve that diverged (forced steep tool tilts do it), and
# its "travel" would be metres of nonsense. Every task's env and deployed run end there.
MAX_OBJECT_SPEED = 5.0


def object_diverged(p_before, p_after, period: float, step: int) -> str | None:
    """The failure's message where the object moved from `p_before` to `p_after` (W, m) in one
    control `period` (s) faster than MAX_OBJECT_SPEED, else None."""
    speed = math.dist(p_before, p_after) / period
    if speed <= MAX_OBJECT_SPEED:
        return None
    return (
        f"the object flew off at {speed:.1f} m/s at step {step} (more than "
        f"{MAX_OBJECT_SPEED:g} m/s, which the arm never moves it): the simulation diverged"
    )
