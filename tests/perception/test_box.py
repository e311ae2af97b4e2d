"""The hand camera finds where the box starts (diagrams.box_measurement, perception.box)."""

import dataclasses as dc

import numpy as np
import pytest

from drake_tooluse.diagrams.box_measurement import measure_box_start
from drake_tooluse.paths import REALITY_SCENARIO
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.world.scenario import load_scenario, with_tool_length
from drake_tooluse.world.scene import initial_box_pose


def _moved(scenario, dx, dy, yaw):
    x, y, z = scenario.box.position
    return dc.replace(scenario, box=dc.replace(scenario.box, position=(x + dx, y + dy, z), yaw=yaw))


@pytest.mark.parametrize("tool", [0.125, 0.3])
def test_the_box_start_is_measured_within_two_millimetres(tool):
    reality = with_tool_length(load_scenario(REALITY_SCENARIO), tool)
    belief = RobotBelief(tool, (0.0, 0.0))
    for dx, dy, yaw in [(0.02, -0.02, 0.2), (-0.02, 0.02, -0.2), (0.0, 0.0, 0.0)]:
        scenario = _moved(reality, dx, dy, yaw)
        measured = measure_box_start(scenario, belief)
        truth = initial_box_pose(scenario).translation()
        assert np.linalg.norm(measured.p_WB_xy - truth[:2]) < 0.002
        assert measured.top_z == pytest.approx(truth[2] + scenario.box.size[2] / 2, abs=0.002)


def test_a_box_out_of_view_is_a_one_line_error():
    scenario = _moved(load_scenario(REALITY_SCENARIO), 0.3, 0.4, 0.0)
    with pytest.raises(ValueError, match="no box in the camera's view") as error:
        measure_box_start(scenario)
    assert "\n" not in str(error.value)
