"""A tool's shape as a fixed-size code a policy can observe, whatever the tool's family.

The code is the tool's support points: for each of SUPPORT_DIRECTIONS (W's +x, −x, +y, −y
and down), the point of the tool's surface farthest that way, as its offset from the tool tip
(m, in W). Five points say where the tool reaches beyond its tip in each direction the task
moves in — the face that meets the box, what lies below the tip and would touch the table
first — and they are what a camera can measure of a tool it was not told about.

The surface is sampled from the tool's solid pieces (`robot.tool`): a cylinder as points
every SAMPLE_SPACING along its axis, each with the cylinder's radius (the support point of
a cylinder is its axis point's plus the radius along the direction, exactly for directions
across the axis); a box as its eight corners.
"""

from __future__ import annotations

import math

import numpy as np

from drake_tooluse.robot.tool import TOOL_TIP, BoxShape, CylinderShape, Tool

SUPPORT_DIRECTIONS = np.array(
    [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, -1.0]]
)  # in W
CODE_SIZE = 3 * len(SUPPORT_DIRECTIONS)
SAMPLE_SPACING = 0.005  # m


def surface_samples(tool: Tool, frame: str = TOOL_TIP) -> tuple[np.ndarray, np.ndarray]:
    """(P_TS (n, 3), r (n,)): sample points S of `tool`'s solid pieces in its frame `frame`
    (T: default its tip; m) and the radius each stands for (a cylinder's; 0 at a box's
    corner)."""
    X_TH = tool.X_HF(frame).inverse().matrix()
    points, radii = [], []
    for piece in tool.pieces():
        X_HP = piece.X_HP.matrix()
        shape = piece.shape
        if isinstance(shape, CylinderShape):
            n = max(2, math.ceil(shape.length / SAMPLE_SPACING) + 1)
            z = np.linspace(-shape.length / 2, shape.length / 2, n)
            p_P = np.stack([np.zeros(n), np.zeros(n), z], axis=1)
            r = np.full(n, shape.radius)
        elif isinstance(shape, BoxShape):
            half = np.array(shape.size) / 2
            p_P = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
            p_P = p_P * half
            r = np.zeros(8)
        else:
            raise ValueError(
                f"tool piece {piece.name!r} is a {type(shape).__name__}: the geometry code "
                "samples cylinders and boxes"
            )
        X_TP = X_TH @ X_HP
        points.append(p_P @ X_TP[:3, :3].T + X_TP[:3, 3])
        radii.append(r)
    return np.concatenate(points), np.concatenate(radii)


class GeometryCode:
    """The support-point code of one tool (module docstring). `code(R_WT)`: its CODE_SIZE
    values with the tip frame T at orientation R_WT; `frame`: the tool frame that is T
    (default its tip)."""

    def __init__(self, tool: Tool | None, frame: str = TOOL_TIP):
        if tool is None:  # no tool: the tip is the gripper frame, nothing reaches beyond it
            self._P_TS, self._r = np.zeros((1, 3)), np.zeros(1)
        else:
            self._P_TS, self._r = surface_samples(tool, frame)

    def code(self, R_WT) -> np.ndarray:
        p_TS_W = self._P_TS @ np.asarray(R_WT).T  # each sample's offset from the tip, in W
        reach = p_TS_W @ SUPPORT_DIRECTIONS.T + self._r[:, None]  # (n, directions)
        best = np.argmax(reach, axis=0)
        return (p_TS_W[best] + self._r[best, None] * SUPPORT_DIRECTIONS).ravel()
