"""How the pull task holds its hook, and the hook's draw per episode.

The hook (`robot.tool.HookTool`) is held with its handle pointing away from the robot (+x of
W) and tilted PULL_TILT below the horizontal, the hook below the handle in the vertical x–z
plane of W: a rake. With the handle's tilt β and the hook's angle a (to the handle, measured
back towards the hand), the hook runs from its inner corner down and back towards the robot,

    u_W = (−cos(a − β), 0, −sin(a − β)),

so for every angle in the hook's range (60°–120°) and β = 30° it hangs between 30° below the
horizontal and straight down (a J or an L seen from the side): it never slopes away from the
robot, and whatever it catches it holds. Its reach back towards the hand from the corner is
the *slant* L_h cos(a − β), its depth below the corner the *drop* L_h sin(a − β).

The pull task controls the hook's inner corner (`hook_corner`) in position; this orientation is
the one its actions hold (`pull_orientation`).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix

from drake_tooluse.robot.tool import (
    HOOK_ANGLE_RANGE,
    HOOK_HANDLE_RANGE,
    HOOK_LENGTH_RANGE,
    HookTool,
)
from drake_tooluse.validation import check_in_range

PULL_TILT = math.radians(30.0)  # β: the handle this far below the horizontal (rad)


def pull_orientation() -> RotationMatrix:
    """R_WH: the handle frame H's orientation while pulling (every frame of a hook has it):
    +z of H (the handle) along (cos β, 0, −sin β), +x of H (where a 90° hook points) along
    (−sin β, 0, −cos β), +y of H along +y of W."""
    s, c = math.sin(PULL_TILT), math.cos(PULL_TILT)
    return RotationMatrix(np.array([[-s, 0.0, c], [0.0, 1.0, 0.0], [-c, 0.0, -s]]))


def pull_pose(p_WC) -> RigidTransform:
    """X_WC: the hook's corner C at `p_WC` (m, W), held in `pull_orientation`."""
    return RigidTransform(pull_orientation(), np.asarray(p_WC, float))


def hook_direction(angle_deg: float) -> np.ndarray:
    """u_W: the unit vector from the corner to the hook's end while pulling."""
    phi = math.radians(angle_deg) - PULL_TILT
    return np.array([-math.cos(phi), 0.0, -math.sin(phi)])


def slant_and_drop(hook_length: float, angle_deg: float) -> tuple[float, float]:
    """(slant, drop), m: how far the hook's end lies back towards the robot from the corner,
    and below it, while pulling."""
    u = hook_direction(angle_deg)
    return -hook_length * float(u[0]), -hook_length * float(u[2])


def check_hook(hook, name: str = "hook") -> tuple[float, float, float]:
    """A hook's geometry (handle length m, hook length m, angle °), each in HookTool's range."""
    if not isinstance(hook, (list, tuple, np.ndarray)) or len(hook) != 3:
        raise ValueError(
            f"{name}={hook!r} must be (handle length m, hook length m, angle °), e.g. "
            "(0.25, 0.05, 90.0)"
        )
    handle, length, angle = hook
    return (
        check_in_range(handle, *HOOK_HANDLE_RANGE, f"{name}[0] (handle length)", unit="m"),
        check_in_range(length, *HOOK_LENGTH_RANGE, f"{name}[1] (hook length)", unit="m"),
        check_in_range(angle, *HOOK_ANGLE_RANGE, f"{name}[2] (hook angle)", unit="°"),
    )


def draw_hook(rng) -> tuple[float, float, float]:
    """A hook drawn uniformly from HookTool's ranges with the numpy Generator `rng` (handle
    length, hook length, angle, in this order)."""
    return (
        float(rng.uniform(*HOOK_HANDLE_RANGE)),
        float(rng.uniform(*HOOK_LENGTH_RANGE)),
        float(rng.uniform(*HOOK_ANGLE_RANGE)),
    )


def hook_geometry(tool: HookTool) -> np.ndarray:
    """[handle length (m), hook length (m), angle (rad)] of a hook: what the observation holds."""
    return np.array([tool.handle_length, tool.hook_length, math.radians(tool.angle)])
