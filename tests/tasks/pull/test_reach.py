"""The cube starts beyond the bare gripper's reach, and within the hook's.

The bare gripper: Baxter's right arm with no tool, its gripper frame (between the fingertips)
asked to be at a point, in any orientation (a position constraint alone), by Drake's
InverseKinematics from the middle of the joint ranges and from 15 random seeds. No point of the
cube's nearest possible face (the start drawn nearest the robot, turned by the largest yaw),
from the table top to the cube's top, is found reachable; a point 3 cm nearer is (so the search
finds reach where there is reach). The bare gripper's reach at the cube's mid-height is
1.106 m at y = −0.25 m, at its top 1.117 m (bisection with the same search); the nearest face
starts at 1.131 m."""

import math

import numpy as np
import pytest
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import Solve

from drake_tooluse.paths import PULL_SCENARIO
from drake_tooluse.robot.baxter_model import Q_LOWER, Q_MID, Q_UPPER
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import GRIPPER_FRAME, make_robot_model
from drake_tooluse.robot.tool import HOOK_CORNER, HookTool
from drake_tooluse.tasks.pull.hook import pull_pose, slant_and_drop
from drake_tooluse.world.scenario import load_scenario

SCENARIO = load_scenario(PULL_SCENARIO)


@pytest.fixture(scope="module")
def gripper_reaches():
    plant = make_robot_model(None)
    context = plant.CreateDefaultContext()
    frame = plant.GetFrameByName(GRIPPER_FRAME)
    seeds = [Q_MID, *np.random.default_rng(0).uniform(Q_LOWER, Q_UPPER, (15, 7))]

    def reaches(p) -> bool:
        for seed in seeds:
            ik = InverseKinematics(plant, context)
            ik.AddPositionConstraint(frame, np.zeros(3), plant.world_frame(), p, p)
            if Solve(ik.prog(), seed).is_success():
                return True
        return False

    return reaches


def nearest_face_x() -> float:
    """x (m) of the cube's point nearest the robot over every start: the centre drawn
    `box_xy` nearer, the cube turned by the largest yaw (its corner then leads)."""
    s, r = SCENARIO, SCENARIO.randomization
    half = s.box.size[0] / 2
    yaw = r.box_yaw
    return s.box.position[0] - r.box_xy - half * (math.cos(yaw) + math.sin(yaw))


def test_no_start_of_the_cube_is_within_the_bare_grippers_reach(gripper_reaches):
    s, r = SCENARIO, SCENARIO.randomization
    x = nearest_face_x()
    assert x == pytest.approx(1.131, abs=1e-3)
    top = s.table.top_z
    y0 = s.box.position[1]
    for y in (y0 - r.box_xy, y0, y0 + r.box_xy):
        for z in (top, top + s.box.size[2] / 2, top + s.box.size[2]):
            assert not gripper_reaches(np.array([x, y, z])), (x, y, z)
    # The search finds reach where there is some: 3 cm nearer, at the cube's top.
    assert gripper_reaches(np.array([x - 0.03, y0, top + s.box.size[2]]))


def test_the_shortest_hook_reaches_behind_the_farthest_cube():
    """The hook's corner, held as it pulls, goes behind the farthest start's far face with the
    shortest handle and the hook that needs it farthest out (the longest, most bent back)."""
    s, r = SCENARIO, SCENARIO.randomization
    hook = HookTool(0.15, 0.08, 60.0)
    slant, drop = slant_and_drop(hook.hook_length, hook.angle)
    half = s.box.size[0] / 2
    far = s.box.position[0] + r.box_xy + half * (math.cos(r.box_yaw) + math.sin(r.box_yaw))
    ik = ToolTipIK(hook, frame=HOOK_CORNER)
    for y in (s.box.position[1] - r.box_xy, s.box.position[1] + r.box_xy):
        X_WC = pull_pose([far + hook.radius + slant, y, s.table.top_z + drop + 0.012])
        assert ik.solve(X_WC).success
