"""A tool the robot was not told about, measured by the head camera's depth views in the
simulation (`builders.shape_measurement`): a held-out tool named and its frames found within
the goal under noise and dim light, the belief it gives, the depth noise system, refusals."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.sensors import ImageDepth32F

from drake_tooluse.builders.shape_measurement import (
    measure_shape,
    shape_belief,
    true_frames_G,
)
from drake_tooluse.robot.tool_generator import generate_tool
from drake_tooluse.systems.camera import DepthImageNoise
from drake_tooluse.world.scenario import Scenario, ToolConfig, with_tool

FRAME_GOAL = 0.002  # m


def held(generated, across, along):
    scenario = with_tool(Scenario(), generated)
    tool = dc.replace(scenario.tool, grasp_offset_across=across, grasp_offset_along=along)
    return dc.replace(scenario, tool=tool)


@pytest.mark.slow  # ~5 s; benchmarks/shape_vision_accuracy.py measures 100 such tools
def test_a_held_out_tool_is_named_and_its_frames_found_under_noise_and_dim_light():
    scenario = held(generate_tool("rake", 11), -0.006, 0.02)  # the family training never sees
    result = measure_shape(scenario, noise_sigma=8.0, depth_noise_sigma=0.001, lighting="dim_side")
    assert result.family == result.truth_family == "rake", result.as_dict()
    assert set(result.frame_errors) == set(true_frames_G(scenario)) and result.frame_errors
    assert result.max_frame_error < FRAME_GOAL, result.frame_errors
    assert not result.dropped and result.shape.points > 500
    belief = shape_belief(result)  # the robot now holds what it measured
    across, along = belief.grasp_offset
    for name, p_G in result.shape.best.frames_G().items():
        np.testing.assert_allclose(
            np.array(belief.tool.frames()[name].translation) + [across, 0.0, along], p_G
        )


def test_no_tool_in_the_hand_is_refused():
    scenario = Scenario(tool=ToolConfig(attached=False))
    with pytest.raises(ValueError, match="needs a tool in the hand; the scenario has none"):
        measure_shape(scenario)


def _depth(system, image, t):
    context = system.CreateDefaultContext()
    context.SetTime(t)
    system.get_input_port().FixValue(context, image)
    return system.get_output_port().Eval(context).data.copy()


def test_depth_noise_is_repeatable_leaves_no_return_alone_and_is_bounded():
    image = ImageDepth32F(8, 6)
    image.mutable_data[:] = 0.6
    image.mutable_data[0, 0] = np.inf  # no return
    noisy = _depth(DepthImageNoise(8, 6, 0.001, seed=3), image, 0.5)
    np.testing.assert_array_equal(noisy, _depth(DepthImageNoise(8, 6, 0.001, seed=3), image, 0.5))
    assert np.isinf(noisy[0, 0]) and 0 < np.std(noisy[np.isfinite(noisy)] - 0.6) < 0.003
    np.testing.assert_array_equal(_depth(DepthImageNoise(8, 6, 0.0), image, 0.5), image.data)
    with pytest.raises(ValueError, match=r"depth noise sigma=0.5 .*\[0, 0.01\]"):
        DepthImageNoise(8, 6, 0.5)
