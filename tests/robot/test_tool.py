"""Tools are geometry: the straight tool reproduces the old rod exactly; any tool's frames are
welded and the IK places any of them; the old one-liners keep working; a tool from a model
file."""

import dataclasses as dc
import subprocess
import sys

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import SpatialInertia

from drake_tooluse.robot.baxter_model import LEFT_ARM_TUCKED, Q_LOWER, Q_UPPER
from drake_tooluse.robot.ik import (
    ToolTipIK,
    gripper_target_from_tip_target,
    rotation_angle_between,
    tool_offset,
)
from drake_tooluse.robot.model import (
    RobotBelief,
    add_baxter,
    add_tool_body,
    load_tool_model,
    make_robot_model,
    tool_center,
    tool_spatial_inertia,
)
from drake_tooluse.robot.tool import (
    BoxShape,
    CompositeTool,
    CylinderShape,
    Piece,
    Pose,
    StraightTool,
)

LENGTHS = [0.03, 0.05, 0.175, 0.6]
HANDLE_DEPTH = 0.03


def old_inertia(length, radius=0.006, mass=0.05):
    """The formula `add_tool_body` used before tools were geometry."""
    M = SpatialInertia.SolidCylinderWithMass(mass, radius, length + HANDLE_DEPTH, [0.0, 0.0, 1.0])
    return M.Shift(-np.array([0.0, 0.0, (length - HANDLE_DEPTH) / 2]))


@pytest.mark.parametrize("length", LENGTHS)
def test_straight_tool_inertia_and_frames_are_the_old_rods_exactly(length):
    tool = StraightTool(length)
    expected = old_inertia(length).CopyToFullMatrix6()
    assert np.array_equal(tool_spatial_inertia(tool).CopyToFullMatrix6(), expected)
    assert np.array_equal(
        tool_spatial_inertia(StraightTool(length, 0.01, 0.2)).CopyToFullMatrix6(),
        old_inertia(length, 0.01, 0.2).CopyToFullMatrix6(),
    )
    plant = make_robot_model(length)
    M = plant.GetBodyByName("tool").default_spatial_inertia()
    assert np.array_equal(M.CopyToFullMatrix6(), expected)
    assert list(tool.frames()) == ["grasp", "tool_tip"]
    assert tool.frames()["grasp"] == Pose()
    assert tool.X_HF("tool_tip").translation == (0.0, 0.0, length)
    tip = plant.GetFrameByName("tool_tip")
    assert tip.body().name() == "tool"
    assert np.array_equal(
        tip.GetFixedPoseInBodyFrame().GetAsMatrix4(), RigidTransform([0, 0, length]).GetAsMatrix4()
    )
    assert np.array_equal(tool_center(length), [0.0, 0.0, (length - HANDLE_DEPTH) / 2])


@pytest.mark.parametrize("length", LENGTHS)
def test_straight_tool_geometry_is_the_old_rods(length):
    r, m = 0.007, 0.01
    tool = StraightTool(length, radius=r, marker_length=m)
    (rod,) = tool.pieces()
    assert (rod.name, rod.shape) == ("tool_visual", CylinderShape(r, length + HANDLE_DEPTH))
    assert rod.X_HP == Pose((0.0, 0.0, (length - HANDLE_DEPTH) / 2))
    tip = min(length, 0.04)
    expected = [("tool_tip_collision", tip, length - tip / 2)]
    if length > tip:
        expected.append(("tool_collision", length - tip, (length - tip) / 2))
    assert [(p.name, p.shape.length, p.X_HP.translation[2]) for p in tool.collision_pieces()] == (
        expected
    )
    assert [(p.name, p.shape, p.X_HP.translation) for p in tool.marker_pieces()] == [
        ("grip_marker", CylinderShape(r * 1.15, m), (0.0, 0.0, m / 2)),
        ("tip_marker", CylinderShape(r * 1.15, m), (0.0, 0.0, length - m / 2)),
    ]


def test_old_one_liners_keep_working():
    belief = RobotBelief(0.175)
    assert belief.tool == StraightTool(0.175) and belief.tool_length == 0.175
    assert belief.grasp_offset == (0.0, 0.0)
    belief = RobotBelief(0.175, (0.0, 0.008))
    assert belief.tool_length == 0.175 and belief.grasp_offset == (0.0, 0.008)
    assert RobotBelief(None).tool is None and RobotBelief(None).tool_length is None
    assert RobotBelief(np.float64(0.2)) == RobotBelief(StraightTool(0.2))
    assert RobotBelief(tool_length=0.2, grasp_offset=(0.001, 0.0)) == RobotBelief(0.2, (0.001, 0.0))
    assert dc.replace(belief, grasp_offset=(0.0, 0.0)) == RobotBelief(0.175)
    with pytest.raises(ValueError, match="believed tool length=0.9 m is outside"):
        RobotBelief(0.9)
    with pytest.raises(ValueError, match="believed grasp offset along"):
        RobotBelief(0.175, (0.0, 0.05))
    assert np.array_equal(tool_offset(0.175), tool_offset(StraightTool(0.175)))
    # A float, the keyword of old and the description give the same IK, to the bit.
    X = ToolTipIK(0.175, library_size=1).fk([0.3, -0.5, 0.2, 1.2, 0.1, 0.8, -0.3])
    answers = [
        ik.solve(X).q
        for ik in (
            ToolTipIK(0.175, library_size=1),
            ToolTipIK(tool_length=0.175, library_size=1),
            ToolTipIK(StraightTool(0.175), library_size=1),
        )
    ]
    assert all(np.array_equal(answers[0], q) for q in answers[1:])
    assert ToolTipIK(tool_length=0.175, library_size=1).tool_length == 0.175
    a, b = make_robot_model(0.175), make_robot_model(StraightTool(0.175))
    assert np.array_equal(
        a.GetBodyByName("tool").default_spatial_inertia().CopyToFullMatrix6(),
        b.GetBodyByName("tool").default_spatial_inertia().CopyToFullMatrix6(),
    )
    with pytest.raises(ValueError, match="not both"):
        ToolTipIK(0.175, tool_length=0.175)


def hook(angle: float = np.pi / 2) -> CompositeTool:
    """A toy hook: a handle rod 0.20 m along +z of H and a box end 0.08 m long at `angle` from
    it; frames at the end's tip and at the inner corner (turned with the end)."""
    handle, end, w = 0.20, 0.08, 0.012
    X_H_elbow = Pose.from_rpy((0.0, angle, 0.0), (0.0, 0.0, handle))  # end along +z of elbow
    return CompositeTool(
        {
            "tool_tip": X_H_elbow @ Pose((0.0, 0.0, end)),
            "hook_corner": X_H_elbow @ Pose((0.0, 0.0, w / 2)),
        },
        solids=(
            Piece("handle", CylinderShape(0.006, handle), Pose((0.0, 0.0, handle / 2))),
            Piece("end", BoxShape((w, w, end)), X_H_elbow @ Pose((0.0, 0.0, end / 2))),
        ),
        mass=0.08,
    )


def test_a_two_piece_tool_welds_with_all_its_frames_and_its_mass():
    tool = hook()
    assert tool.frame_names() == ["grasp", "tool_tip", "hook_corner"]
    grasp = (0.003, -0.01)
    plant = make_robot_model(tool, grasp_offset=grasp)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, np.random.default_rng(1).uniform(Q_LOWER, Q_UPPER))
    G = plant.GetFrameByName("right_gripper")
    X_GH = RigidTransform([grasp[0], 0.0, grasp[1]])
    for name, plant_name in (
        ("grasp", "tool_grasp"),
        ("tool_tip", "tool_tip"),
        ("hook_corner",) * 2,
    ):
        X_GF = plant.GetFrameByName(plant_name).CalcPose(context, G)
        expected = X_GH.GetAsMatrix4() @ tool.X_HF(name).matrix()
        np.testing.assert_allclose(X_GF.GetAsMatrix4(), expected, atol=1e-15)
    # The tip: 0.20 m up the handle, then 0.08 m along +x (the end turned 90 deg about y).
    np.testing.assert_allclose(tool.X_HF("tool_tip").translation, [0.08, 0.0, 0.2], atol=1e-15)
    M = plant.GetBodyByName("tool").default_spatial_inertia()
    assert M.get_mass() == pytest.approx(0.08)
    v_handle, v_end = np.pi * 0.006**2 * 0.20, 0.012**2 * 0.08
    com = (v_handle * np.array([0, 0, 0.1]) + v_end * np.array([0.04, 0, 0.2])) / (v_handle + v_end)
    np.testing.assert_allclose(M.get_com(), com, atol=1e-12)
    assert M.IsPhysicallyValid()


@pytest.mark.parametrize("frame", ["hook_corner", "tool_tip", "grasp"])
def test_ik_places_any_frame_of_the_tool(frame):
    tool = hook(angle=2.0)
    ik = ToolTipIK(tool, frame=frame, grasp_offset=(0.0, 0.005), library_size=500)
    assert ik.frame == frame and ik.tool_length == pytest.approx(tool.reach())
    truth = make_robot_model(tool, grasp_offset=(0.0, 0.005))  # an independent model
    context = truth.CreateDefaultContext()
    F = truth.GetFrameByName("tool_grasp" if frame == "grasp" else frame)
    rng = np.random.default_rng(4)
    for _ in range(4):
        truth.SetPositions(context, rng.uniform(Q_LOWER, Q_UPPER))
        X_WF = F.CalcPoseInWorld(context)
        for result in (ik.solve(X_WF), ik.solve_with_snopt(X_WF, max_attempts=4)):
            assert result.success, result
            truth.SetPositions(context, result.q)
            X = F.CalcPoseInWorld(context)
            assert np.linalg.norm(X.translation() - X_WF.translation()) < 1e-5
            assert rotation_angle_between(X.rotation(), X_WF.rotation()) < 1e-4


def test_a_straight_tool_with_a_second_functional_frame():
    rod = StraightTool(0.25)
    tool = CompositeTool(
        {**rod.frames(), "side_point": Pose((0.006, 0.0, 0.2))},
        solids=rod.pieces(),
        collisions=rod.collision_pieces(),
        markers=rod.marker_pieces(),
        mass=rod.mass,
    )
    assert np.array_equal(
        tool_spatial_inertia(tool).CopyToFullMatrix6(),
        tool_spatial_inertia(rod).CopyToFullMatrix6(),
    )
    tip_ik, side_ik = ToolTipIK(tool, library_size=200), ToolTipIK(tool, frame="side_point")
    q = np.array([0.4, -0.6, 0.1, 1.4, 0.2, 0.9, -0.2])
    X_WS = side_ik.fk(q)
    result = side_ik.solve(X_WS, q_seed=q + 0.1)
    assert result.success and result.position_error < 1e-5
    assert np.linalg.norm(side_ik.fk(result.q).translation() - X_WS.translation()) < 1e-5
    # The same joints put the tip 0.05 m past the side point along the tool.
    X_WT = tip_ik.fk(result.q)
    np.testing.assert_allclose(
        X_WT.translation() - X_WS.translation(),
        X_WS.rotation() @ np.array([-0.006, 0.0, 0.05]),
        atol=1e-5,
    )


def test_bad_tools_and_frames_are_errors_naming_them():
    with pytest.raises(ValueError, match="'tool_tip' frame"):
        CompositeTool({"corner": Pose()}, solids=hook().pieces())
    with pytest.raises(ValueError, match="'grasp' frame must be"):
        CompositeTool({"grasp": Pose((0, 0, 0.01)), "tool_tip": Pose()}, solids=hook().pieces())
    with pytest.raises(ValueError, match="repeated names"):
        CompositeTool({"tool_tip": Pose()}, solids=hook().pieces() * 2)
    with pytest.raises(ValueError, match="not a rotation"):
        Pose(rotation=((1, 0, 0), (0, 1, 0), (0, 0, 2)))
    with pytest.raises(ValueError, match="tool length=0 m is outside"):
        StraightTool(0.0)
    with pytest.raises(ValueError, match=r"frame='elbow' is not a frame of the believed tool"):
        ToolTipIK(hook(), frame="elbow", library_size=1)
    with pytest.raises(ValueError, match="not a frame of the believed tool"):
        ToolTipIK(None, frame="grasp", library_size=1)
    plant = MultibodyPlant(0.0)
    baxter = add_baxter(plant, LEFT_ARM_TUCKED)
    with pytest.raises(ValueError, match="give them to the tool"):
        add_tool_body(plant, baxter, StraightTool(0.1), radius=0.01)
    clash = CompositeTool(
        {"tool_tip": Pose(), "right_gripper": Pose()}, solids=StraightTool(0.1).pieces()
    )
    with pytest.raises(ValueError, match="already has a frame named 'right_gripper'"):
        add_tool_body(plant, baxter, clash)
    with pytest.raises(ValueError, match="rotated"):
        gripper_target_from_tip_target(RigidTransform(), hook())


def test_pose_from_rpy_is_drakes():
    rpy = (0.3, -1.1, 2.5)
    np.testing.assert_allclose(
        np.array(Pose.from_rpy(rpy).rotation),
        RollPitchYaw(*rpy).ToRotationMatrix().matrix(),
        atol=1e-15,
    )
    X = Pose.from_rpy(rpy, (0.1, 0.2, 0.3))
    np.testing.assert_allclose((X @ X.inverse()).matrix(), np.eye(4), atol=1e-15)


def test_the_tool_description_imports_without_drake():
    code = (
        "import sys; from drake_tooluse.robot.tool import StraightTool; StraightTool(0.1).pieces();"
        "assert not [m for m in sys.modules if m.startswith('pydrake')]"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


SDF = """<?xml version="1.0"?>
<sdf version="1.9">
  <model name="toy_tool">
    <link name="stick">
      <pose>0 0 0.1 0 0 0</pose>
      <inertial>
        <mass>0.1</mass>
        <inertia><ixx>4e-4</ixx><iyy>4e-4</iyy><izz>2e-6</izz>
          <ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia>
      </inertial>
      <visual name="stick_visual">
        <geometry><cylinder><radius>0.006</radius><length>0.2</length></cylinder></geometry>
        <material><diffuse>0.2 0.3 0.4 1</diffuse></material>
      </visual>
      <collision name="stick_collision">
        <geometry><box><size>0.01 0.01 0.2</size></box></geometry>
      </collision>
    </link>
    <frame name="grasp" attached_to="stick"><pose>0 0 -0.08 0 0 0</pose></frame>
    <frame name="tool_tip" attached_to="stick"><pose>0 0 0.1 0 0 0</pose></frame>
    <frame name="notch" attached_to="stick"><pose>0.006 0 0.05 0 0.5 0</pose></frame>
  </model>
</sdf>
"""


def test_a_tool_loads_from_a_model_file_with_named_frames(tmp_path):
    path = tmp_path / "toy_tool.sdf"
    path.write_text(SDF)
    tool = load_tool_model(path)
    assert tool.frame_names() == ["grasp", "tool_tip", "notch"]
    np.testing.assert_allclose(tool.X_HF("tool_tip").translation, [0, 0, 0.18], atol=1e-15)
    notch = RigidTransform(RollPitchYaw(0, 0.5, 0), [0.006, 0, 0.13]).GetAsMatrix4()
    np.testing.assert_allclose(tool.X_HF("notch").matrix(), notch, atol=1e-15)
    assert tool.reach() == pytest.approx(0.18)
    M = tool_spatial_inertia(tool)
    assert M.get_mass() == pytest.approx(0.1)
    np.testing.assert_allclose(M.get_com(), [0, 0, 0.08], atol=1e-15)  # the link's origin in H
    ((visual,), (collision,)) = tool.pieces(), tool.collision_pieces()
    assert visual.name == "stick_visual" and visual.shape == CylinderShape(0.006, 0.2)
    assert visual.rgba == pytest.approx((0.2, 0.3, 0.4, 1.0))
    np.testing.assert_allclose(visual.X_HP.translation, [0, 0, 0.08], atol=1e-15)
    assert collision.shape == BoxShape((0.01, 0.01, 0.2))
    ik = ToolTipIK(tool, frame="notch", library_size=200)
    q = np.array([0.4, -0.6, 0.1, 1.4, 0.2, 0.9, -0.2])
    result = ik.solve(ik.fk(q), q_seed=q - 0.1)
    assert result.success and result.position_error < 1e-5


def test_a_model_file_without_a_tip_frame_is_an_error(tmp_path):
    path = tmp_path / "no_tip.sdf"
    path.write_text(SDF.replace('name="tool_tip"', 'name="end"'))
    with pytest.raises(ValueError, match="has no 'tool_tip' frame"):
        load_tool_model(path)
