"""The robot chooses among tools it never trained with: racks of generated tools, each
measured once by its shape, predicted from that shape, the chosen one measured again in the
hand."""

from types import SimpleNamespace

import numpy as np
import pytest

from drake_tooluse.builders.shape_measurement import true_frames_G
from drake_tooluse.cli import EXIT_USAGE, main
from drake_tooluse.experiments.tool_choice import (
    MAX_TOOLS,
    Policies,
    TaskInstance,
    check_rack,
    choose_tool,
    generated_rack,
    no_policy_reason,
)
from drake_tooluse.robot.tool import HOOK_LENGTH_RANGE, HookTool
from drake_tooluse.robot.tool_generator import (
    FAMILIES,
    HELD_OUT_FAMILY,
    equivalent_hook,
    generate_tool,
    in_corner,
    measured_tool,
)


def test_a_generated_rack_holds_five_families_never_trained_with():
    for seed in range(20):
        rack = generated_rack(seed)
        assert check_rack(rack) == rack and len(rack) == MAX_TOOLS
        assert len({tool.family for tool in rack}) == MAX_TOOLS
        for tool in rack:  # the held-out split: the held-out family, or another's corner
            assert tool.family == HELD_OUT_FAMILY or in_corner(tool.family, tool.params)
    assert generated_rack(3) == generated_rack(3) and generated_rack(3) != generated_rack(4)
    with pytest.raises(ValueError, match="rack seed=-1 is outside"):
        generated_rack(-1)


def test_generated_tools_serve_the_tasks_their_policies_act_for():
    for family in FAMILIES:
        tool = generate_tool(family, 1)
        assert no_policy_reason("push", tool) is None
        assert no_policy_reason("push-far", tool) is None
        reason = no_policy_reason("pull", tool)
        assert (reason is None) == (family in ("hook", "arc"))
    assert "it serves the hook and arc families" in no_policy_reason(
        "pull", generate_tool("rake", 1)
    )
    policies = Policies()
    assert policies.for_task("push", generated=True).directory.name == "ppo_toolpush_shapes"
    assert policies.for_task("push").directory.name == "ppo_toolpush_tip"
    far_shapes = policies.for_task("push-far", generated=True).directory.name
    assert far_shapes == "ppo_toolpush_shapes_far"
    assert policies.for_task("push-far").directory.name == "ppo_toolpush_tip_far"
    pull_shapes = policies.for_task("pull", generated=True).directory.name
    assert pull_shapes == "ppo_toolpull_shapes"


class FamilyPolicy:
    """A stand-in for a learned policy: succeeds with the families it is given, and records
    each run's world and belief."""

    def __init__(self, families):
        self.families = families
        self.calls = []

    def run(self, scenario, belief, **_):
        self.calls.append((scenario, belief))
        return SimpleNamespace(
            success=scenario.tool.family in self.families,
            final_object_to_goal=0.01 if scenario.tool.family in self.families else 0.2,
            error=None,
        )


def _told(rack):
    """Rack shapes as if measured without error: each tool's own family and parameters."""
    return {i: (measured_tool(t.family, t.params), None) for i, t in enumerate(rack)}


def test_the_choice_predicts_from_the_rack_s_shapes_and_measures_the_chosen_grasp():
    rack = (generate_tool("rake", 5), generate_tool("two_bend", 5, "corner"))
    policy = FamilyPolicy({"two_bend"})
    out = choose_tool(
        TaskInstance("push", 2), rack, 2, policies=Policies(push=policy), rack_shapes=_told(rack)
    )
    assert out["chosen"] == rack[1].label() and out["success"]
    assert out["rack_measure_time_s"] == 0.0  # given, not measured here
    assert [c["predicted_success"] for c in out["candidates"]] == [0.0, 1.0]
    predictions, (reality, in_hand) = policy.calls[:4], policy.calls[4]
    assert len(policy.calls) == 2 * 2 + 1  # the rollouts, then the chosen tool in reality
    for (world, belief), tool in zip(predictions[::2], rack):
        assert world.tool.params == pytest.approx(tool.params)  # the measured shape
        assert belief.grasp_offset == (0.0, 0.0)  # not yet held: the nominal grasp
    # In reality the true tool, measured again in the hand: the working frames in G where
    # they are, the grasp held deeper or less deep with the handle (which look the same).
    assert reality.tool.seed == rack[1].seed and not reality.tool.params
    assert (reality.tool.grasp_offset_across, reality.tool.grasp_offset_along) != (0.0, 0.0)
    across, along = in_hand.grasp_offset
    believed = {
        name: np.array(X.translation) + [across, 0.0, along]
        for name, X in in_hand.tool.frames().items()
    }
    for name, p_GF in true_frames_G(reality).items():
        assert np.linalg.norm(believed[name] - p_GF) < 0.002, name


def test_a_tool_with_a_hook_corner_pulls_as_its_equivalent_hook():
    hook = generate_tool("hook", 7)
    p = hook.params
    expected = HookTool(p["handle_length"], p["hook_length"], p["angle"], radius=p["radius"])
    assert equivalent_hook(hook).handle_length == pytest.approx(expected.handle_length)
    assert equivalent_hook(hook).hook_length == pytest.approx(expected.hook_length)
    assert equivalent_hook(hook).angle == pytest.approx(expected.angle)
    # An arc: its hook the chord from where the curve starts to its end (seed 7's: 7.7 cm at
    # 107°, within HookTool's ranges); seed 1's chord, 9.5 cm, is held at the longest hook.
    frames = generate_tool("arc", 7).tool.frames()
    as_hook = equivalent_hook(generate_tool("arc", 7))
    tip = np.array([0, 0, as_hook.handle_length]) + as_hook.hook_length * as_hook.direction()
    assert tip == pytest.approx(np.asarray(frames["tool_tip"].translation), abs=1e-9)
    assert equivalent_hook(generate_tool("arc", 1)).hook_length == HOOK_LENGTH_RANGE[1]
    with pytest.raises(ValueError, match="a straight tool has no hook_corner"):
        equivalent_hook(generate_tool("straight", 7))


def test_a_generated_hook_pulls_as_a_hook_and_a_bad_measurement_is_no_candidate():
    rack = (generate_tool("rake", 2), generate_tool("hook", 2, "corner"), generate_tool("arc", 2))
    shapes = {**_told(rack), 2: (None, "ValueError: the tool in the hand fits no family")}
    policy = FamilyPolicy({"hook"})
    out = choose_tool("pull", rack, 1, policies=Policies(pull=policy), rack_shapes=shapes)
    rake, hook, arc = out["candidates"]
    assert "serves the hook and arc" in rake["reason"] and "fits no family" in arc["reason"]
    assert out["chosen"] == rack[1].label() and out["success"]
    believed = policy.calls[0][1].tool  # the pull's control holds a HookTool
    assert believed == equivalent_hook(rack[1])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--rack-seed", "1", "--tools", "straight:0.3"], "give no --tools with it"),
        (["--rack-seed", "-1"], "--rack-seed=-1 is outside the allowed range"),
    ],
)
def test_cli_refuses_a_bad_generated_rack(capsys, argv, message):
    assert main(["choose-tool", *argv]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_cli_chooses_from_a_generated_rack(capsys):
    """The whole command: five tools measured by their shapes, a choice in seconds."""
    argv = ["choose-tool", "--task", "pull", "--rack-seed", "1", "--rollouts", "1"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "measuring the rack's shapes" in text
    assert text.count("predicted success") == MAX_TOOLS
    assert "chosen: hook#" in text or "chosen: arc#" in text
