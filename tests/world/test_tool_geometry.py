"""The world's tool is the scenario's tool description: every scenario file loads unchanged, the
straight rod's geometry is the old one, and any tool's pieces become its geometry."""

from pathlib import Path

import numpy as np
import pytest
from pydrake.geometry import Role
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.robot.baxter_model import LEFT_ARM_TUCKED
from drake_tooluse.robot.model import add_baxter, add_tool_body
from drake_tooluse.robot.tool import (
    BoxShape,
    CompositeTool,
    CylinderShape,
    HookTool,
    Piece,
    Pose,
    StraightTool,
)
from drake_tooluse.world.scenario import Scenario, load_scenario, tool_or_none, with_tool_length
from drake_tooluse.world.scene import add_tool_geometry, add_world

DIAGRAMS = Path(__file__).resolve().parents[2] / "diagrams"


@pytest.mark.parametrize("path", sorted(DIAGRAMS.glob("*.yaml")), ids=lambda p: p.name)
def test_every_scenario_file_gives_its_tool(path):
    t = load_scenario(path).tool
    tool = t.description()
    if t.kind == "hook":
        assert tool == HookTool(
            t.length, t.hook_length, t.hook_angle, t.radius, t.mass, t.marker_length
        )
    else:
        assert tool == StraightTool(t.length, t.radius, t.mass, t.marker_length)
        assert tool.reach() == t.length


def test_no_tool_attached_is_none():
    scenario = Scenario()
    assert tool_or_none(scenario) == StraightTool(0.175)
    scenario.tool.attached = False
    assert tool_or_none(scenario) is None


def _tool_geometry(world):
    inspector = world.scene_graph.model_inspector()
    frame = world.plant.GetBodyFrameIdOrThrow(world.tool.index())
    out = {}
    for role in (Role.kIllustration, Role.kProximity):
        for gid in inspector.GetGeometries(frame, role):
            shape = inspector.GetShape(gid)
            out[(inspector.GetName(gid).split("::")[-1], role)] = (
                shape.radius(),
                shape.length(),
                inspector.GetPoseInFrame(gid).GetAsMatrix4(),
            )
    return out


@pytest.mark.parametrize("length", [0.03, 0.175, 0.45])
def test_straight_tool_geometry_in_the_world_is_the_old_rods(length):
    scenario = with_tool_length(Scenario(), length)
    r, m = scenario.tool.radius, scenario.tool.marker_length
    tip = min(length, 0.04)

    def at(z):
        X = np.eye(4)
        X[2, 3] = z
        return X

    expected = {
        ("tool_visual", Role.kIllustration): (r, length + 0.03, at((length - 0.03) / 2)),
        ("grip_marker", Role.kIllustration): (r * 1.15, m, at(m / 2)),
        ("tip_marker", Role.kIllustration): (r * 1.15, m, at(length - m / 2)),
        ("tool_tip_collision", Role.kProximity): (r, tip, at(length - tip / 2)),
    }
    if length > tip:
        expected[("tool_collision", Role.kProximity)] = (r, length - tip, at((length - tip) / 2))
    got = _tool_geometry(add_world(DiagramBuilder(), scenario))
    assert got.keys() == expected.keys()
    for key, (radius, size, X) in expected.items():
        assert got[key][:2] == (radius, size)
        assert np.array_equal(got[key][2], X)


def test_any_tools_pieces_become_its_geometry():
    tool = CompositeTool(
        {"tool_tip": Pose((0.05, 0.0, 0.15)), "corner": Pose((0.0, 0.0, 0.15))},
        solids=(
            Piece("handle", CylinderShape(0.006, 0.15), Pose((0.0, 0.0, 0.075))),
            Piece("end", BoxShape((0.05, 0.01, 0.01)), Pose((0.025, 0.0, 0.15)), (1, 0, 0, 1)),
        ),
        markers=(Piece("band", CylinderShape(0.007, 0.01), Pose((0.0, 0.0, 0.01))),),
    )
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    baxter = add_baxter(plant, LEFT_ARM_TUCKED)
    body = add_tool_body(plant, baxter, tool)
    add_tool_geometry(plant, body, tool)
    plant.Finalize()
    inspector = scene_graph.model_inspector()
    frame = plant.GetBodyFrameIdOrThrow(body.index())

    def names(role):
        return sorted(inspector.GetName(g) for g in inspector.GetGeometries(frame, role))

    assert names(Role.kIllustration) == ["baxter::band", "baxter::end", "baxter::handle"]
    assert names(Role.kProximity) == ["baxter::end", "baxter::handle"]
    end = inspector.GetGeometryIdByName(frame, Role.kIllustration, "baxter::end")
    rgba = inspector.GetIllustrationProperties(end).GetProperty("phong", "diffuse")
    assert tuple(rgba.rgba) == (1.0, 0.0, 0.0, 1.0)
