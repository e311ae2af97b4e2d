"""A held hook measured with the head camera: handle length, hook length and angle, and the
grasp along the handle, within 2 mm and 2 deg, at the ranges' ends and held deep or far out;
the views that cannot see a band say so; bad input is refused naming value and range."""

import dataclasses as dc
import json
import math

import numpy as np
import pytest

from drake_tooluse.builders.hook_measurement import (
    HOOK_VIEWS,
    TOLERANCE,
    build_hook_measurement_diagram,
    measure_hook,
    measured_hook,
    plan_hook_measurement,
)
from drake_tooluse.cli import main
from drake_tooluse.robot.tool import HookTool
from drake_tooluse.world.scenario import (
    RandomizationConfig,
    Scenario,
    ToolConfig,
    validate_scenario,
)

GOAL = {"handle_length": 0.002, "hook_length": 0.002, "angle": 2.0, "grasp_along": 0.002}
# The views depend on the robot and the camera only: plan once for the whole file.
PLAN = plan_hook_measurement(Scenario())


def hook_scenario(handle, hook, angle, along=0.0) -> Scenario:
    tool = ToolConfig(
        kind="hook", length=handle, hook_length=hook, hook_angle=angle, grasp_offset_along=along
    )
    return validate_scenario(
        Scenario(tool=tool, randomization=RandomizationConfig(grasp_along=0.0))
    )


def assert_within_goal(result):
    for quantity, goal in GOAL.items():
        assert abs(result.error(quantity)) <= goal, (quantity, result.as_dict()["error"])


@pytest.mark.parametrize(
    "handle, hook, angle, along",
    [
        (0.15, 0.03, 60.0, -0.03),  # every range's lower end, held deepest
        (0.35, 0.08, 120.0, 0.03),  # every upper end, held furthest out
        (0.15, 0.08, 120.0, 0.0),
    ],
)
def test_a_hook_at_the_ranges_ends_is_measured_within_2mm_and_2deg(handle, hook, angle, along):
    result = measure_hook(hook_scenario(handle, hook, angle, along), plan=PLAN)
    assert not result.dropped
    assert_within_goal(result)
    assert [v.view for v in result.views] == [v.name for v in HOOK_VIEWS]
    assert result.truth == {
        "handle_length": handle,
        "hook_length": hook,
        "angle": angle,
        "grasp_along": along,
    }
    for quantity in GOAL:  # every view gave each quantity it can
        assert 0.0 <= result.spread[quantity] < 2 * GOAL[quantity]


def test_held_deep_the_fingers_hide_the_grip_band_from_the_hook_views_not_the_grip_views():
    result = measure_hook(hook_scenario(0.25, 0.05, 90.0, -0.02), plan=PLAN)
    hook_views = [v for v in result.views if v.kind == "hook"]
    grip_views = [v for v in result.views if v.kind == "grip"]
    assert len(hook_views) == 3 and len(grip_views) == 2
    assert all("grip band" in v.grip_reason and not v.p_CA for v in hook_views)
    assert all(v.accepted and v.p_CA for v in grip_views)
    assert all(math.isnan(v.handle_length) for v in hook_views)  # no grasp point in the image
    assert_within_goal(result)


@pytest.mark.slow  # ~2 s; the hook's noisy measurement is benchmarked by hook_vision_accuracy.py
def test_side_light_colour_noise_and_an_orange_distractor_keep_the_estimate():
    from drake_tooluse.builders.measurement import orange_distractor

    result = measure_hook(
        hook_scenario(0.3, 0.04, 65.0, 0.01),
        plan=PLAN,
        lighting="dim_side",
        noise_sigma=5.0,
        scene_objects=[orange_distractor()],
    )
    assert not result.dropped
    assert max(v.blob_count for v in result.views) >= 4  # three bands and the distractor
    assert_within_goal(result)


def test_a_hook_view_with_the_corner_hidden_is_dropped_and_named():
    from drake_tooluse.builders.measurement import occluder

    # A plate in front of where the hook_bottom view holds a 0.25 m handle's corner.
    result = measure_hook(
        hook_scenario(0.25, 0.05, 90.0), plan=PLAN, scene_objects=[occluder((0.13, 0.04, 0.55))]
    )
    assert [d["view"] for d in result.dropped] == ["hook_bottom"]
    assert "a band is hidden or out of frame" in result.dropped[0]["reason"]
    assert_within_goal(result)  # from the two other hook views


def test_a_straight_tool_or_no_tool_is_refused_naming_what_the_scenario_holds():
    with pytest.raises(ValueError, match=r"needs a hook in the hand .* has tool.kind='straight'"):
        measure_hook(Scenario(), plan=PLAN)
    no_tool = dc.replace(Scenario(), tool=ToolConfig(kind="hook", attached=False))
    with pytest.raises(ValueError, match=r"has no tool"):
        build_hook_measurement_diagram(no_tool, PLAN)


def test_the_estimator_holds_no_view_before_the_first_capture():
    built = build_hook_measurement_diagram(hook_scenario(0.2, 0.05, 90.0), PLAN)
    context = built.diagram.CreateDefaultContext()
    assert built.diagram.GetOutputPort("measurement").Eval(context).views == []
    assert np.all(np.isnan(built.diagram.GetOutputPort("hook").Eval(context)))


class _Measured:
    """A stand-in for a measurement result: `value(quantity)` only."""

    def __init__(self, **values):
        self.values = values

    def value(self, quantity):
        return self.values[quantity]


def test_the_believed_hook_takes_a_value_just_past_a_range_end_at_the_end_and_refuses_more():
    at_ends = _Measured(handle_length=0.3505, hook_length=0.0298, angle=121.5)
    assert measured_hook(at_ends) == HookTool(0.35, 0.03, 120.0)
    like = HookTool(0.2, 0.05, 90.0, radius=0.008)
    assert (
        measured_hook(_Measured(handle_length=0.2, hook_length=0.05, angle=90.0), like).radius
        == 0.008
    )
    too_far = _Measured(
        handle_length=0.25, hook_length=0.05, angle=120.0 + TOLERANCE["angle"] + 0.1
    )
    with pytest.raises(
        ValueError,
        match=r"measured hook angle=122.1 deg is outside the allowed range \[60, 120\] deg",
    ):
        measured_hook(too_far)
    with pytest.raises(ValueError, match=r"measured hook handle_length=nan m"):
        measured_hook(_Measured(handle_length=math.nan, hook_length=0.05, angle=90.0))


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["--tool-kind", "hook", "--hook-angle", "150"],
            "--hook-angle=150 ° is outside the allowed range [60, 120] °",
        ),
        (
            ["--tool-kind", "hook", "--hook-length", "0.1"],
            "--hook-length=0.1 m is outside the allowed range [0.03, 0.08] m",
        ),
        (
            ["--tool-kind", "hook", "--tool-length", "0.5"],
            "--tool-length (the hook's handle)=0.5 m is outside the allowed range [0.15, 0.35] m",
        ),
        (["--hook-angle", "90"], "--hook-angle is a hook's: give --tool-kind hook with it"),
        (["--tool-kind", "hook", "--method", "pixel"], "--method='pixel' measures a straight tool"),
    ],
)
def test_bad_hook_options_are_one_line_errors_naming_value_and_range(capsys, args, message):
    assert main(["measure", *args, "--json"]) == 2
    out = json.loads(capsys.readouterr().out)
    assert message in out["error"] and "\n" not in out["error"]


@pytest.mark.slow
def test_the_command_line_measures_a_hook_and_saves_its_views(capsys, tmp_path):
    code = main(
        ["measure", "--tool-kind", "hook", "--tool-length", "0.3", "--hook-length", "0.06"]
        + ["--hook-angle", "70", "--save-images", str(tmp_path), "--json"]
    )
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["tool_kind"] == "hook"
    assert out["truth"] == {
        "handle_length_m": 0.3,
        "hook_length_m": 0.06,
        "angle_deg": 70.0,
        "grasp_along_m": 0.0,
    }
    assert abs(out["error"]["angle_deg"]) <= 2.0 and abs(out["error"]["handle_length_m"]) <= 2e-3
    assert len(out["views"]) == len(HOOK_VIEWS) and not out["dropped"]
    names = sorted(f"measure_{v.name}.png" for v in HOOK_VIEWS)
    assert sorted(p.name for p in tmp_path.iterdir()) == names


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_seeded_draws_with_colour_noise_are_within_2mm_and_2deg(seed):
    rng = np.random.default_rng(seed)
    for k in range(4):
        handle, hook, angle, along = (
            rng.uniform(0.15, 0.35),
            rng.uniform(0.03, 0.08),
            rng.uniform(60.0, 120.0),
            rng.uniform(-0.03, 0.03),
        )
        result = measure_hook(
            hook_scenario(handle, hook, angle, along), plan=PLAN, noise_sigma=5.0, seed=k
        )
        assert_within_goal(result)


def test_the_belief_holds_the_measured_hook_where_the_camera_saw_the_grasp(monkeypatch):
    from drake_tooluse.builders import hook_measurement

    result = hook_measurement.HookMeasurementResult(
        handle_length=0.2512,
        hook_length=0.0495,
        angle=88.7,
        grasp_along=0.0061,
        spread={},
        views=[],
        truth={},
        wall_time=0.0,
        sim_time=0.0,
    )
    monkeypatch.setattr(hook_measurement, "measure_hook", lambda scenario, **kwargs: result)
    belief, same = hook_measurement.measure_hook_belief(Scenario())
    assert same is result
    assert belief.tool == HookTool(0.2512, 0.0495, 88.7)
    assert belief.grasp_offset == (0.0, 0.0061)
    nominal, _ = hook_measurement.measure_hook_belief(Scenario(), use_grasp_estimate=False)
    assert nominal.tool == belief.tool and nominal.grasp_offset == (0.0, 0.0)


def test_a_straight_tool_measured_in_the_pull_world_takes_a_straight_tools_length(capsys):
    """`--tool-kind straight` in the pull world (which holds a hook): 0.5 m is a valid straight
    tool, not a hook's handle outside [0.15, 0.35] m."""
    from drake_tooluse.paths import PULL_SCENARIO

    argv = ["measure", "--tool-kind", "straight", "--scenario", str(PULL_SCENARIO)]
    code = main([*argv, "--tool-length", "0.5", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["tool_length_m"] == pytest.approx(0.5, abs=0.005)
