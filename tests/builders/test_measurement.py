"""Tool length from the head camera in the simulation: rendered views, dropped views, the
no-marker error, robustness, the grasp estimate, and the IK with the measured length."""

import dataclasses as dc
import math

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.sensors import CameraInfo

from drake_tooluse.builders.measurement import (
    MEASUREMENT_VIEWS,
    build_measurement_diagram,
    measure_tool,
    occluder,
    orange_distractor,
    plan_measurement,
)
from drake_tooluse.cli import make_parser
from drake_tooluse.perception.markers import add_color_noise, measure_view
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import TOOL_DOWN_RPY, make_robot_model
from drake_tooluse.world.scenario import (
    CameraConfig,
    Scenario,
    ToolConfig,
    validate_scenario,
    with_tool_length,
)

# The views' layout depends on the robot only: plan once for the whole file.
PLAN = plan_measurement(Scenario())


def _measure(length, **kwargs):
    return measure_tool(with_tool_length(Scenario(), length), plan=PLAN, **kwargs)


# -- rendered views --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def rendered():
    """Measurements of three tools with their images (rendered once for the module)."""
    return {length: _measure(length, keep_images=True) for length in (0.05, 0.175, 0.45)}


@pytest.mark.parametrize("length", [0.05, 0.175, 0.45])
def test_rendered_views_measure_the_true_length(rendered, length):
    result = rendered[length]
    assert [v.view for v in result.views] == [v.name for v in MEASUREMENT_VIEWS]
    assert not result.dropped
    assert abs(result.length - length) < 1.5e-3
    for view in result.views:
        assert abs(view.length_depth - length) < 3e-3, view.as_dict()
    # The pixel variant holds where the tool is square to the optical axis.
    for view in result.views[:2]:
        assert abs(view.length_pixel - length) < 0.02 * length + 2e-3, view.as_dict()
    assert result.spread == pytest.approx(
        max(v.length_depth for v in result.views) - min(v.length_depth for v in result.views)
    )


def test_colour_noise_and_dimmer_light_keep_the_estimate(rendered):
    info = CameraInfo(1280, 800, 1.0)
    result = rendered[0.175]
    for k, (view, (color, depth)) in enumerate(zip(result.views, result.images)):
        noisy = add_color_noise(color, 8.0, seed=k)
        m = measure_view(noisy, depth, info, PLAN.views[k].spec)
        assert m.accepted, m.reason
        assert abs(m.length_depth - view.length_depth) < 1.5e-3
        dim = (color.astype(float) * [0.45, 0.45, 0.45, 1.0]).astype(np.uint8)
        m = measure_view(dim, depth, info, PLAN.views[k].spec)
        assert m.accepted and abs(m.length_depth - 0.175) < 3e-3


def test_distractor_noise_and_side_light_in_the_simulation():
    result = _measure(
        0.25, noise_sigma=5.0, lighting="dim_side", scene_objects=[orange_distractor()]
    )
    assert not result.dropped
    assert all(v.blob_count >= 3 for v in result.views)  # the distractor was in view
    assert abs(result.length - 0.25) < 3e-3


def test_an_occluded_view_is_dropped_and_named():
    # A plate in front of where the vertical view holds a 0.30 m tool's tip.
    result = _measure(0.30, scene_objects=[occluder((0.15, 0.0, 0.55))])
    assert result.dropped == [
        {
            "view": "grip_bottom",
            "reason": "only one orange marker found: "
            "the tip marker is missing (hidden or out of frame)",
        }
    ]
    assert math.isnan(result.views[1].length_depth)
    assert abs(result.length - 0.30) < 3e-3  # the mean of the two other views


def test_a_marker_out_of_frame_drops_that_view():
    scenario = dc.replace(with_tool_length(Scenario(), 0.60), camera=CameraConfig(fov_y=0.9))
    result = measure_tool(scenario)  # narrower view: a new plan, same poses
    assert [d["view"] for d in result.dropped] == ["grip_left"]
    assert "tip marker is missing" in result.dropped[0]["reason"]
    assert abs(result.length - 0.60) < 3e-3


def test_no_marker_in_any_view_is_an_error_naming_view_and_marker():
    scenario = dc.replace(Scenario(), tool=ToolConfig(attached=False))
    with pytest.raises(
        ValueError,
        match=r"view 'grip_right': no orange marker found: both the "
        r"grip marker and the tip marker are missing",
    ):
        measure_tool(scenario, plan=PLAN)


def test_estimator_output_is_nan_before_the_first_capture():
    built = build_measurement_diagram(with_tool_length(Scenario(), 0.2), PLAN)
    context = built.diagram.CreateDefaultContext()
    assert math.isnan(built.diagram.GetOutputPort("tool_length").Eval(context)[0])
    assert built.diagram.GetOutputPort("measurement").Eval(context).views == []


# -- the measured length in use --------------------------------------------------------------


def test_belief_holds_a_straight_tool_of_the_measured_length(rendered, monkeypatch):
    from drake_tooluse.builders import measurement
    from drake_tooluse.robot.tool import StraightTool

    result = rendered[0.175]
    monkeypatch.setattr(measurement, "measure_tool", lambda scenario, **kwargs: result)
    belief, same = measurement.measure_belief(Scenario())
    assert same is result
    assert belief.tool == StraightTool(result.length) and belief.tool_length == result.length
    assert belief.grasp_offset == (0.0, result.grasp_along)
    nominal, _ = measurement.measure_belief(Scenario(), use_grasp_estimate=False)
    assert nominal.tool == belief.tool and nominal.grasp_offset == (0.0, 0.0)


def test_measured_length_gives_an_ik_that_reaches_the_target(rendered):
    true_length = 0.175
    measured = rendered[true_length].length
    ik = ToolTipIK(measured)
    from pydrake.math import RollPitchYaw

    X_WT = RigidTransform(RollPitchYaw(*TOOL_DOWN_RPY), [0.65, -0.25, -0.10])
    result = ik.solve(X_WT)
    assert result.success
    # The true tool's tip, at those joint angles, is where the robot wanted it (to within the
    # measurement error).
    truth = make_robot_model(true_length)
    context = truth.CreateDefaultContext()
    truth.SetPositions(context, result.q)
    p_WT = truth.GetFrameByName("tool_tip").CalcPoseInWorld(context).translation()
    assert np.linalg.norm(p_WT - X_WT.translation()) < 2e-3


# -- inputs ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("fov_y", 3.0, r"camera.fov_y=3 rad is outside the allowed range \[0.1, 2.5\]"),
        ("width", 10, r"camera.width=10 must be an integer in \[16, 4096\]"),
        ("depth_max", 50.0, r"camera.depth_max=50 m is outside"),
        ("noise_sigma", -1.0, r"camera.noise_sigma=-1 grey levels is outside"),
    ],
)
def test_bad_camera_values_name_value_and_range(field, value, message):
    scenario = dc.replace(Scenario(), camera=dc.replace(CameraConfig(), **{field: value}))
    with pytest.raises(ValueError, match=message):
        validate_scenario(scenario)


def test_bad_method_and_noise_are_errors():
    scenario = with_tool_length(Scenario(), 0.2)
    with pytest.raises(ValueError, match=r"method='meters' is not allowed"):
        measure_tool(scenario, method="meters", plan=PLAN)
    with pytest.raises(ValueError, match=r"noise sigma=-2 grey levels is outside"):
        measure_tool(scenario, noise_sigma=-2, plan=PLAN)


def test_cli_command_measures_and_saves_annotated_views(tmp_path):
    args = make_parser().parse_args(
        ["measure", "--tool-length", "0.125", "--method", "pixel", "--save-images", str(tmp_path)]
    )
    out = args.run(args)
    assert out["method"] == "pixel"
    assert out["tool_length_m"] == pytest.approx(out["length_pixel_m"])
    assert abs(out["length_depth_m"] - 0.125) < 1.5e-3
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "measure_grip_bottom.png",
        "measure_grip_left.png",
        "measure_grip_right.png",
    ]


@pytest.mark.parametrize("length, along", [(0.125, 0.008), (0.40, -0.01)])
def test_camera_finds_where_the_hand_holds_the_tool(length, along):
    """The grip marker's outer end is the grasp point: seen in 3-D and put in the gripper frame
    with the arm's joint angles, it gives the grasp shift along the tool."""
    import dataclasses as dc

    from drake_tooluse.builders.measurement import measure_tool
    from drake_tooluse.world.scenario import Scenario, validate_scenario

    s = Scenario()
    s = validate_scenario(
        dc.replace(
            s,
            tool=dc.replace(
                s.tool, length=length, grasp_offset_along=along, grasp_offset_across=0.004
            ),
        )
    )
    result = measure_tool(s)
    assert result.grasp_along == pytest.approx(along, abs=0.001)
    assert result.as_dict()["grasp_along_m"] == result.grasp_along
    assert result.length == pytest.approx(length, abs=0.001)


def test_grasp_estimate_for_a_short_tool_held_deep():
    """0.05 m tool held 10 mm deeper: its grip band is half inside the fingers and one view
    pairs the two bands the wrong way round; the grasp is the end nearer the wrist."""
    import dataclasses as dc

    from drake_tooluse.builders.measurement import measure_tool
    from drake_tooluse.world.scenario import Scenario, validate_scenario

    s = Scenario()
    s = validate_scenario(
        dc.replace(
            s,
            tool=dc.replace(s.tool, length=0.05, grasp_offset_along=-0.01),
            camera=dc.replace(s.camera, noise_sigma=5.0),
        )
    )
    assert measure_tool(s, seed=0).grasp_along == pytest.approx(-0.01, abs=0.001)
