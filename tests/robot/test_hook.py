"""A hook is a tool geometry like the straight rod: a handle and an end at an angle, with the
frames a pulling task needs (the inner corner and the tip), welded in the gripper by a
scenario line, and the IK solves for either frame."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.control import add_world_at_home, nominal_belief
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import HOOK_CORNER, HookTool
from drake_tooluse.world.scenario import Scenario, ToolConfig, validate_scenario


@pytest.mark.parametrize("angle", [60.0, 90.0, 120.0])
def test_the_hooks_frames_are_its_corner_and_its_end(angle):
    hook = HookTool(0.25, 0.05, angle)
    corner = np.array(hook.X_HF(HOOK_CORNER).translation)
    tip = np.array(hook.X_HF("tool_tip").translation)
    assert np.allclose(corner, [0, 0, 0.25])
    assert np.linalg.norm(tip - corner) == pytest.approx(0.05)
    # The angle between the hook and the handle (back towards the hand) is `angle`.
    cos = np.dot(tip - corner, -corner) / (0.05 * 0.25)
    assert math.degrees(math.acos(cos)) == pytest.approx(angle)
    # The hook piece runs from the corner to the tip.
    piece = {p.name: p for p in hook.pieces()}["tool_hook"]
    p = np.array(piece.X_HP.translation)
    z = np.array(piece.X_HP.rotation)[:, 2]
    assert np.allclose(p, (corner + tip) / 2) and np.allclose(z, (tip - corner) / 0.05)


@pytest.mark.parametrize(
    "args, message",
    [
        ((0.10, 0.05, 90.0), r"hook handle length=0.1 m is outside the allowed range"),
        ((0.25, 0.10, 90.0), r"hook length=0.1 m is outside the allowed range"),
        ((0.25, 0.05, 150.0), r"hook angle=150.0 ° is outside the allowed range|hook angle=150"),
    ],
)
def test_a_hook_outside_its_ranges_is_refused(args, message):
    with pytest.raises(ValueError, match=message):
        HookTool(*args)


def test_a_scenario_line_welds_a_hook_and_the_ik_reaches_its_corner():
    tool = ToolConfig(kind="hook", length=0.25, hook_length=0.06, hook_angle=75.0)
    scenario = validate_scenario(Scenario(tool=tool))
    belief = nominal_belief(scenario)
    assert isinstance(belief.tool, HookTool)
    builder = DiagramBuilder()
    world, ik, q0 = add_world_at_home(builder, scenario, belief)
    inspector = world.scene_graph.model_inspector()
    names = {inspector.GetName(g) for g in inspector.GetAllGeometryIds()}
    assert any("tool_hook" in n for n in names) and any("corner_marker" in n for n in names)
    X_WF = RigidTransform(RollPitchYaw(np.pi, 0, np.pi / 2), [0.65, -0.25, -0.10])
    for frame in ("tool_tip", HOOK_CORNER):
        result = ToolTipIK(RobotBelief(belief.tool).tool, frame=frame).solve(X_WF, q_seed=q0)
        assert result.success and result.position_error < 1e-5, frame


def test_a_hook_scenario_outside_its_ranges_names_the_field():
    tool = ToolConfig(kind="hook", length=0.25, hook_angle=30.0)
    with pytest.raises(ValueError, match="tool.hook_angle=30 ° is outside the allowed range"):
        validate_scenario(Scenario(tool=tool))
    with pytest.raises(ValueError, match="tool.kind='lasso' is not allowed"):
        validate_scenario(Scenario(tool=ToolConfig(kind="lasso")))
