"""The tool's geometry code (`robot.tool_geometry`): the support points of a rod and of a hook
where they must be, whatever the tool's pose."""

import numpy as np
import pytest

from drake_tooluse.robot.tool import BoxShape, CompositeTool, HookTool, MeshShape, Piece, Pose
from drake_tooluse.robot.tool_generator import generate_tool
from drake_tooluse.robot.tool_geometry import (
    CODE_SIZE,
    SUPPORT_DIRECTIONS,
    GeometryCode,
    surface_samples,
)

DOWN = 4  # SUPPORT_DIRECTIONS' row of W's −z


def _rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_a_rod_pointing_down_reaches_below_its_tip_by_its_radius():
    rod = generate_tool("straight", 3).tool
    r = rod.pieces()[0].shape.radius
    R_WT = np.diag([1.0, -1.0, -1.0])  # the tip frame's +z (the rod's axis) pointing down
    code = GeometryCode(rod).code(R_WT).reshape(-1, 3)
    assert code.shape == (len(SUPPORT_DIRECTIONS), 3) and CODE_SIZE == code.size
    np.testing.assert_allclose(code[DOWN], [0.0, 0.0, -r], atol=1e-12)
    for k in range(4):  # sideways, every point of the rod reaches its radius
        assert code[k] @ SUPPORT_DIRECTIONS[k] == pytest.approx(r)


def test_a_hook_reaches_sideways_by_its_hook_and_the_code_turns_with_the_tool():
    hook = HookTool(0.2, 0.06, 90.0, radius=0.005)
    code = GeometryCode(hook)
    R_WT = np.diag([1.0, -1.0, -1.0])
    base = code.code(R_WT).reshape(-1, 3)
    # The hook reaches out from the tip's side: the farthest point along each direction is
    # at least as far as the tip itself (the origin) plus the radius.
    reach = np.einsum("ij,ij->i", base, SUPPORT_DIRECTIONS)
    assert np.all(reach >= 0.005 - 1e-12)
    # The support function is that of the turned tool: turning the tool about W's z by a
    # quarter turn shows towards +y what it showed towards +x.
    turned = code.code(_rotation([0, 0, 1], np.pi / 2) @ R_WT).reshape(-1, 3)
    assert turned[2] @ SUPPORT_DIRECTIONS[2] == pytest.approx(reach[0], abs=1e-9)
    assert reach[0] != pytest.approx(reach[1])  # the hook reaches one way, not the other
    assert turned[DOWN] @ SUPPORT_DIRECTIONS[DOWN] == pytest.approx(reach[DOWN], abs=1e-9)


def test_boxes_are_sampled_at_their_corners_and_meshes_are_refused():
    tool = CompositeTool(
        {"tool_tip": Pose((0, 0, 0.1))}, solids=(Piece("b", BoxShape((0.02, 0.04, 0.2))),)
    )
    points, radii = surface_samples(tool)
    assert points.shape == (8, 3) and np.all(radii == 0)
    np.testing.assert_allclose(points.min(axis=0), [-0.01, -0.02, -0.2])
    meshy = CompositeTool({"tool_tip": Pose()}, solids=(Piece("m", MeshShape("x.obj")),))
    with pytest.raises(ValueError, match="'m' is a MeshShape"):
        surface_samples(meshy)
