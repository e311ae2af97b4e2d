"""The tool generator (`robot.tool_generator`), its files (`robot.tool_files`) and `drake-tooluse
tools`: seeded draws in each family's ranges and fabrication bounds, an SDF that reads back as
the same tool, a closed mesh, every working frame reached by the IK, and every family held in
the push env through Gymnasium's checker."""

import dataclasses as dc
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pydrake.common.yaml import yaml_dump_typed

from drake_tooluse.cli import main
from drake_tooluse.experiments.task_worlds import holding, task_scenarios
from drake_tooluse.experiments.tool_gallery import gallery_contents
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.paths import DEFAULT_SCENARIO, POLICIES_DIR
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import RobotBelief, load_tool_model, tool_spatial_inertia
from drake_tooluse.robot.tool import (
    GRASP,
    TOOL_HANDLE_DEPTH,
    TOOL_LENGTH_RANGE,
    TOOL_TIP,
    StraightTool,
)
from drake_tooluse.robot.tool_files import tool_mesh, write_tool_files
from drake_tooluse.robot.tool_generator import (
    CORNER_PARAMETERS,
    FAMILIES,
    HELD_OUT_FAMILY,
    MAX_MASS,
    MAX_STATIC_MOMENT,
    PUSH_BAND,
    PUSH_POINT,
    TRAINING_FAMILIES,
    check_fabrication,
    equivalent_hook,
    generate_tool,
    held_out_tools,
    in_corner,
    measured_tool,
    split_draw,
)
from drake_tooluse.tasks.deploy import deploy
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import load_scenario, validate_scenario, with_tool

ROOT = Path(__file__).resolve().parents[2]


def test_the_same_seed_draws_the_same_tool_and_another_seed_another():
    for family in FAMILIES:
        a, b = generate_tool(family, 5), generate_tool(family, 5)
        assert a.params == b.params and a.tool.frames() == b.tool.frames()
        assert generate_tool(family, 6).params != a.params
    # Each family draws its own stream: seed 0 of two families share no parameter value.
    hook, t_head = generate_tool("hook", 0).params, generate_tool("t_head", 0).params
    assert hook["handle_length"] != t_head["handle_length"]


@pytest.mark.parametrize("family", list(FAMILIES))
def test_every_draw_is_in_its_ranges_and_keeps_the_fabrication_bounds(family):
    ranges = FAMILIES[family].ranges
    for seed in range(60):
        generated = generate_tool(family, seed)
        for name, value in generated.params.items():
            lo, hi = ranges[name]
            assert lo <= value <= hi, (seed, name, value)
        tool = generated.tool
        check_fabrication(tool)  # raises where a bound is broken
        assert 0 < tool.mass <= MAX_MASS
        assert 0 < tool.reach() <= TOOL_LENGTH_RANGE[1]


def test_the_fabrication_check_names_the_bound_broken():
    heavy = FAMILIES["straight"].build({"length": 0.45, "radius": 0.02})
    with pytest.raises(ValueError, match="mass .* exceeds|static moment"):
        check_fabrication(heavy)
    assert MAX_STATIC_MOMENT > 0


@pytest.mark.parametrize(
    "family, seed, match",
    [("spoon", 0, "tool family='spoon' is not allowed"), ("rake", -1, "seed=-1")],
)
def test_bad_family_or_seed_is_refused(family, seed, match):
    with pytest.raises(ValueError, match=match):
        generate_tool(family, seed)


@pytest.mark.parametrize("family", list(FAMILIES))
def test_the_sdf_reads_back_as_the_same_tool(family, tmp_path):
    tool = generate_tool(family, 11).tool
    files = write_tool_files(tool, tmp_path)
    back = load_tool_model(files["sdf"])
    assert set(back.frames()) == set(tool.frames())
    for name, X in tool.frames().items():
        np.testing.assert_allclose(back.frames()[name].translation, X.translation, atol=1e-12)
    M, M_back = tool_spatial_inertia(tool), tool_spatial_inertia(back)
    np.testing.assert_allclose(M_back.CopyToFullMatrix6(), M.CopyToFullMatrix6(), atol=1e-12)
    assert [p.name for p in back.pieces()] == [p.name for p in tool.pieces()]


@pytest.mark.parametrize("family", list(FAMILIES))
def test_the_mesh_is_closed_and_outward_with_the_pieces_volume(family, tmp_path):
    tool = generate_tool(family, 2).tool
    vertices, faces = tool_mesh(tool)
    edges = {}
    for a, b, c in faces:
        for e in ((a, b), (b, c), (c, a)):
            edges[e] = edges.get(e, 0) + 1
    # Closed and consistently oriented: each edge once each way.
    assert all(edges.get((b, a)) == 1 for (a, b) in edges) and set(edges.values()) == {1}
    p, q, r = (vertices[faces[:, i]] for i in range(3))
    volume = np.einsum("ij,ij->i", p, np.cross(q, r)).sum() / 6  # positive: outward
    pieces = sum(piece.shape.volume() for piece in tool.pieces())
    assert 0.98 * pieces < volume <= pieces  # 32 facets: the polygon's area is 0.6 % short
    files = write_tool_files(tool, tmp_path)
    stl = Path(files["stl"]).read_bytes()
    assert len(stl) == 84 + 50 * len(faces)
    assert Path(files["obj"]).read_text().count("\nf ") == len(faces)


@pytest.mark.parametrize("family", list(FAMILIES))
def test_the_ik_reaches_every_working_frame(family):
    tool = generate_tool(family, 0).tool
    for name in tool.frames():
        if name == GRASP:
            continue
        ik = ToolTipIK(tool, frame=name)
        X_WF = ik.fk(ik.q_nominal + np.array([0.2, -0.1, 0.1, 0.3, -0.2, 0.2, 0.1]))
        result = ik.solve(X_WF, q_seed=ik.q_nominal)
        assert result.success and result.position_error < 1e-5, name
        np.testing.assert_allclose(ik.fk(result.q).translation(), X_WF.translation(), atol=1e-5)


@pytest.mark.slow  # ~3 s: six envs built; .ci/run runs it
@pytest.mark.parametrize("family", list(FAMILIES))
def test_every_family_is_held_in_the_push_env_and_passes_the_checker(family, tmp_path):
    files = write_tool_files(generate_tool(family, 0).tool, tmp_path)
    scenario = tmp_path / "held.yaml"
    scenario.write_text(f"base: {DEFAULT_SCENARIO}\ntool: {{model: {files['sdf']}}}\n")
    env = gym.make("drake_tooluse/ToolPush-v1", scenario=str(scenario))
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_tools_sample_writes_the_tool_and_refuses_bad_input_before_work(tmp_path, capsys):
    out = tmp_path / "rake"
    assert main(["tools", "sample", "--family", "rake", "--seed", "3", "--out", str(out)]) == 0
    assert "rake tool, seed 3" in capsys.readouterr().out
    description = json.loads((out / "tool.json").read_text())
    assert description["params"] == generate_tool("rake", 3).params
    names = {"tool.sdf", "tool.obj", "tool.stl", "tool.json", "sidecar.yaml"}
    assert {p.name for p in out.iterdir()} == names
    assert load_tool_model(out / "tool.sdf").frame_names()[1] == "tool_tip"
    for argv, match in [
        (["--family", "spoon", "--out", str(tmp_path / "a")], "--family='spoon'"),
        (["--family", "rake", "--seed", "-2", "--out", str(tmp_path / "b")], "--seed=-2"),
        (["--family", "rake", "--out", str(out)], "exists and is not empty"),
    ]:
        assert main(["tools", "sample", *argv]) == 2
        assert match in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rake"]


def test_the_docs_gallery_is_of_the_generator_as_it_is():
    """docs/figures/tool_gallery.png is made by `drake-tooluse tools gallery --out
    docs/figures/tool_gallery.png`; its .json, what it shows, must be what the generator draws
    now (else the command must run again)."""
    shown = json.loads((ROOT / "docs/figures/tool_gallery.json").read_text())
    assert shown["tools"] == gallery_contents(shown["seed"], shown["rows"])
    assert len(shown["tools"]) == 24 and (ROOT / "docs/figures/tool_gallery.png").is_file()


def test_the_training_split_never_draws_a_held_out_tool_and_the_held_out_split_only_those():
    rng = np.random.default_rng(0)
    for _ in range(300):
        family, seed, region = split_draw("training", rng)
        generated = generate_tool(family, seed, region)
        assert family != HELD_OUT_FAMILY and family in TRAINING_FAMILIES
        assert not in_corner(family, generated.params)
    held_out = held_out_tools(120, seed=3)
    assert {g.family for g in held_out} == set(FAMILIES)
    for g in held_out:
        assert g.family == HELD_OUT_FAMILY or in_corner(g.family, g.params), g.as_dict()
    # The same seed, the same test set.
    assert [g.as_dict() for g in held_out_tools(5, 3)] == [g.as_dict() for g in held_out[:5]]


def test_a_split_drawn_for_some_families_draws_only_those_and_refuses_none_of_it():
    rng = np.random.default_rng(1)
    drawn = [split_draw("training", rng, ("hook", "arc")) for _ in range(60)]
    assert {family for family, _, _ in drawn} == {"hook", "arc"}
    assert {region for _, _, region in drawn} == {"training"}
    held_out = {split_draw("held_out", rng, ("arc", "rake"))[::2] for _ in range(60)}
    assert held_out == {("arc", "corner"), ("rake", "any")}
    # Without families, the draws of before (the push env's tools are the same).
    a, b = np.random.default_rng(2), np.random.default_rng(2)
    assert [split_draw("training", a) for _ in range(5)] == [
        split_draw("training", b, None) for _ in range(5)
    ]
    with pytest.raises(ValueError, match="training split draws none"):
        split_draw("training", rng, (HELD_OUT_FAMILY,))
    with pytest.raises(ValueError, match="tool family"):
        split_draw("training", rng, ("spoon",))


def test_the_corner_is_the_upper_quarter_of_both_shape_parameters():
    for family, names in CORNER_PARAMETERS.items():
        ranges = FAMILIES[family].ranges
        top = {n: ranges[n][1] for n in ranges if not isinstance(ranges[n][0], str)}
        assert in_corner(family, top)
        for name in names:  # one of the two below its upper quarter: out of the corner
            lo, hi = ranges[name]
            assert not in_corner(family, {**top, name: hi - 0.3 * (hi - lo)})
        g = generate_tool(family, 7, "corner")
        assert in_corner(family, g.params) and g.region == "corner"
        assert not in_corner(family, generate_tool(family, 7, "training").params)
    # A region other than REGIONS is refused, naming it.
    with pytest.raises(ValueError, match="region"):
        generate_tool("hook", 0, "elsewhere")


def test_a_generated_tool_is_held_in_the_push_env_drawn_per_episode_from_its_split():
    env = gym.make(
        "drake_tooluse/ToolPush-v1",
        observation_mode="tip_geometry",
        action_mode="position",
        generated_tools="training",
    )
    try:
        obs, _ = env.reset(seed=4)
        assert obs.shape == (27,) and np.all(np.isfinite(obs))
        first = env.unwrapped.scenario.tool
        assert first.kind == "generated" and first.family in TRAINING_FAMILIES
        families = {first.family}
        for seed in range(5, 12):
            env.reset(seed=seed)
            families.add(env.unwrapped.scenario.tool.family)
        assert len(families) > 1
        env.reset(seed=4)  # the same seed, the same tool
        assert env.unwrapped.scenario.tool == first
    finally:
        env.close()
    with pytest.raises(ValueError, match="generated_tools"):
        gym.make("drake_tooluse/ToolPush-v1", generated_tools="all")


def test_a_free_end_is_a_collision_piece_of_its_own_as_a_rods_tip_is():
    rod = FAMILIES["straight"].build({"length": 0.40, "radius": 0.006})
    paper = StraightTool(0.40, radius=0.006)
    ends = {p.name: p for p in rod.collision_pieces()}
    assert set(ends) == {"tool_handle", "tool_handle_end"}
    tip = {p.name: p for p in paper.collision_pieces()}["tool_tip_collision"]
    assert ends["tool_handle_end"].shape.radius == tip.shape.radius
    assert ends["tool_handle_end"].shape.length == pytest.approx(tip.shape.length)
    assert np.allclose(ends["tool_handle_end"].X_HP.translation, tip.X_HP.translation)
    # The pieces still span the rod, from inside the hand to its tip.
    assert sum(p.shape.length for p in ends.values()) == pytest.approx(0.40 + TOOL_HANDLE_DEPTH)
    # An end another segment meets (a hook's corner, a T-head's bar) is not a tip; a segment
    # no longer than two tip pieces stays whole.
    hook = FAMILIES["hook"].build(
        {"handle_length": 0.3, "hook_length": 0.08, "angle": 90.0, "radius": 0.006}
    )
    assert [p.name for p in hook.collision_pieces()] == ["tool_handle", "tool_hook"]
    t_head = generate_tool("t_head", 1).tool
    assert "tool_handle_end" not in {p.name for p in t_head.collision_pieces()}
    # The solids (what the camera sees and the mass) are the segments, whole.
    assert [p.name for p in rod.pieces()] == ["tool_handle"]


@pytest.mark.slow  # ~40 s: 6 pushes; .ci/run runs it
def test_a_generated_rod_pushes_as_the_rod_of_the_same_length():
    """The tip policy, trained on rods, pushes with a generated rod of 0.40 m as with the rod
    of `StraightTool`: as one collision cylinder, the generated rod's contact with the box
    could act far above its tip and lift it over the box (2 of 12 at the goal)."""
    policy = load_policy(POLICIES_DIR / "ppo_toolpush_tip")
    nominal = task_scenarios("push")[0]
    generated = measured_tool("straight", {"length": 0.40, "radius": 0.006})
    for seed in range(3):
        finals = []
        for tool in (generated, 0.40):
            base = holding(nominal, generated) if tool is generated else with_tool(nominal, 0.40)
            s = apply_draw(base, draw_randomization(base, np.random.default_rng(4000 + seed)))
            grasp = (s.tool.grasp_offset_across, s.tool.grasp_offset_along)
            belief = RobotBelief(generated.tool if tool is generated else 0.40, grasp)
            run = deploy(s, policy, belief)
            assert run.success, (seed, tool)
            finals.append(run.final_object_to_goal)
        assert abs(finals[0] - finals[1]) < 0.01, (seed, finals)


def test_the_pull_env_holds_a_generated_hook_or_arc_believed_as_its_equivalent_hook():
    env = gym.make("drake_tooluse/ToolPull-v1", generated_tools="training")
    try:
        families = set()
        for seed in range(6):
            obs, info = env.reset(seed=seed)
            tool = env.unwrapped.scenario.tool
            assert tool.kind == "generated" and tool.region == "training"
            families.add(tool.family)
            hook = equivalent_hook(generate_tool(tool.family, tool.seed, tool.region))
            assert info["hook"] == (hook.handle_length, hook.hook_length, hook.angle)
            # The observation's believed hook is that hook's geometry.
            assert np.allclose(
                obs[13:16],
                [hook.handle_length, hook.hook_length, np.radians(hook.angle)],
                atol=1e-6,
            )
        assert families == {"hook", "arc"}
        obs, _, _, _, info = env.step(env.action_space.sample())
        assert np.all(np.isfinite(obs)) and not info["sim_error"]
    finally:
        env.close()
    with pytest.raises(ValueError, match="generated_tools"):
        gym.make("drake_tooluse/ToolPull-v1", generated_tools="all")
    with pytest.raises(ValueError, match="generated_tools or a hook"):
        gym.make("drake_tooluse/ToolPull-v1", generated_tools="training", hook=(0.25, 0.05, 90))


def test_the_push_point_is_the_front_of_what_meets_the_box_at_the_lowest_height():
    """Held pointing down (+z of H downwards) with +x towards the box: of the skeleton within
    PUSH_BAND of its lowest point, the front (farthest along +x), at the lowest point's height;
    the tip where the front ties with it."""

    def frames(family, **params):
        ranges = FAMILIES[family].ranges
        middle = {n: (lo + hi) / 2 for n, (lo, hi) in ranges.items() if isinstance(lo, float)}
        return FAMILIES[family].skeleton({**middle, **params}).working_frames()

    R = 0.045
    arc = frames("arc", handle_length=0.25, arc_radius=R, sweep_deg=190.0)
    phi = np.pi - np.arcsin(1 - PUSH_BAND / R)  # where the curl leaves the band, in front
    assert arc[PUSH_POINT][2] == pytest.approx(0.25 + R, abs=1e-3)  # the bottom's height
    assert arc[PUSH_POINT][0] == pytest.approx(R * (1 - np.cos(phi)), abs=4e-3)  # its front
    hook = frames("hook", handle_length=0.25, hook_length=0.08, angle=60.0)  # bent back up
    # In the band, the hook reaches 3/4 of its 0.04 m rise: 0.75 * 0.08 sin 60° forward.
    np.testing.assert_allclose(
        hook[PUSH_POINT], [0.75 * 0.08 * np.sin(np.pi / 3), 0.0, 0.25], atol=1e-9
    )
    for family, params in [
        ("straight", {}),
        ("hook", {"angle": 120.0}),
        ("rake", {"tines": 3}),
        ("t_head", {}),
        ("two_bend", {}),
    ]:
        f = frames(family, **params)
        np.testing.assert_allclose(f[PUSH_POINT], f[TOOL_TIP], atol=1e-12, err_msg=family)
    # An even-tined rake's tip is in the air between its inner tines: the push point is the
    # end of an inner tine, on the tool, always the one on the -y side (the two are as near
    # the tip; which is nearer by a rounding must not decide, or a measured rake's width a
    # hair off the truth's would put its push point on the other tine).
    for tines, inner in [(2, 0.5), (4, 1 / 6)]:
        for width in np.linspace(0.06, 0.16, 41):
            f = frames("rake", tines=tines, width=width, tine_length=0.03)
            expected = [0.03, -inner * width, f[TOOL_TIP][2]]
            np.testing.assert_allclose(f[PUSH_POINT], expected, atol=1e-9, err_msg=str(width))
    # It is one of the tool's frames, reached by the IK as the others (above).
    assert PUSH_POINT in generate_tool("arc", 1).tool.frame_names()


def test_the_push_env_places_and_observes_the_working_frame():
    """With working_frame="push_point" the IK holds the push point where the tip would be held,
    and the observation's tip is that point; a tool without the frame is refused."""
    from drake_tooluse.world.scenario import Scenario, with_tool

    arc = generate_tool("arc", 1, "corner")
    tips = {}
    for frame in ("tool_tip", PUSH_POINT):
        env = gym.make(
            "drake_tooluse/ToolPush-v1",
            observation_mode="tip",
            action_mode="position",
            scenario=with_tool(Scenario(), arc),
            working_frame=frame,
        )
        try:
            obs, _ = env.reset(seed=0)
            world = env.unwrapped.world
            context = world.plant.GetMyContextFromRoot(env.unwrapped.simulator.get_context())
            p = {
                name: world.plant.GetFrameByName(name).CalcPoseInWorld(context).translation()
                for name in ("tool_tip", PUSH_POINT)
            }
            np.testing.assert_allclose(obs[6:9], p[frame], atol=1e-6)
            tips[frame] = p
            # Whichever frame the policy acts with, the judge's d(x, y) is from the tool's
            # push point (its tip is up in the curl), as the paper's is from a rod's tip.
            _, _, _, _, info = env.step(np.zeros(3, np.float32))
            p_WB = world.box.EvalPoseInWorld(context).translation()
            p_WP = world.plant.GetFrameByName(PUSH_POINT).CalcPoseInWorld(context).translation()
            assert info["tip_to_object"] == pytest.approx(np.linalg.norm(p_WP - p_WB), abs=1e-9)
        finally:
            env.close()
    # The same place at home, taken by the frame the IK holds.
    np.testing.assert_allclose(
        tips["tool_tip"]["tool_tip"], tips[PUSH_POINT][PUSH_POINT], atol=1e-4
    )
    with pytest.raises(ValueError, match="working frame 'push_point' is not a frame of the tool"):
        gym.make("drake_tooluse/ToolPush-v1", working_frame=PUSH_POINT).reset(seed=0)


@pytest.mark.parametrize("family", list(FAMILIES))
def test_a_measured_tool_is_held_by_its_parameters(family, tmp_path):
    """A tool the camera measured has no seed: a scenario holds it by its family's
    parameters, which a scenario file keeps (integers read back as floats)."""
    drawn = generate_tool(family, 4)
    measured = measured_tool(family, {k: float(v) for k, v in drawn.params.items()})
    assert measured.params == drawn.params and measured.label() == f"{family} (measured)"
    held = with_tool(load_scenario(DEFAULT_SCENARIO), measured)
    path = tmp_path / "held.yaml"
    path.write_text(yaml_dump_typed(held))
    tool = load_scenario(path).tool.description()
    assert tool.frames() == drawn.tool.frames() and tool.mass == pytest.approx(drawn.tool.mass)


def test_a_bad_measured_tool_is_refused():
    params = dict(generate_tool("rake", 1).params)
    with pytest.raises(ValueError, match=r"rake tines=2.5 must be a whole number"):
        measured_tool("rake", {**params, "tines": 2.5})
    with pytest.raises(ValueError, match=r"rake width=0.5 is outside the allowed range"):
        measured_tool("rake", {**params, "width": 0.5})
    with pytest.raises(ValueError, match=r"a rake tool's parameters are \["):
        measured_tool("rake", {"width": 0.1})
    scenario = load_scenario(DEFAULT_SCENARIO)
    with pytest.raises(ValueError, match="tool.params are a generated tool's; tool.kind is"):
        validate_scenario(dc.replace(scenario, tool=dc.replace(scenario.tool, params=params)))
