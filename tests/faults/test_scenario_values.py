"""Every number of a scenario that reaches Drake is checked where it enters: Drake's own
preconditions (which pydrake raises as SystemExit, past `except Exception`) are never reached
by a scenario file, the plant's fields are range-checked, and positions that would give
infinite observations are refused. A YAML key that is not a name, a 10,000-deep document or a
number of hundreds of digits is a usage error naming the file, never a bug's exit 1.

Covers: the plant's fields, positions and joint angles; the one handler that names a value
Drake refuses; a stray Drake failure in a command; YAML keys, nesting and long integers; and
scenarios fuzzed (hypothesis)."""

import math

import gymnasium as gym
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

import drake_tooluse  # noqa: F401  (registers the envs)
import drake_tooluse.cli.robot as robot_cli
from drake_tooluse.cli import EXIT_INTERNAL, EXIT_USAGE, main
from drake_tooluse.validation import refused_by_library
from drake_tooluse.world.scenario import (
    PLANT_CHOICES,
    PLANT_FLAGS,
    PLANT_RANGES,
    WORKSPACE,
    load_scenario,
)

BAD = [
    ("plant:\n  stiction_tolerance: -1\n", r"plant.stiction_tolerance=-1 m/s is outside"),
    ("plant:\n  stiction_tolerance: 0\n", r"plant.stiction_tolerance=0 m/s is outside .*\(0,"),
    ("plant:\n  sap_near_rigid_threshold: .nan\n", r"plant.sap_near_rigid_threshold=nan must"),
    ("plant:\n  sap_near_rigid_threshold: -0.5\n", r"plant.sap_near_rigid_threshold=-0.5 is"),
    ("plant:\n  penetration_allowance: 1e9\n", r"plant.penetration_allowance=1e\+09 m is outside"),
    ("plant:\n  penetration_allowance: 0\n", r"plant.penetration_allowance=0 m is outside"),
    ("plant:\n  time_step: .inf\n", r"plant.time_step=inf must be a finite number"),
    ("plant:\n  contact_surface_representation: x\n", r"contact_surface_representation='x'"),
    ("box:\n  position: [1e300, 0, 0]\n", r"box.position\[0\]=1e\+300 m is outside .*\[-2, 2\]"),
    ("goal_offset: [0, 1e300, 0]\n", r"the goal \(box.position \+ goal_offset\)\[1\]=1e\+300"),
    ("table:\n  center_xy: [1e300, 0]\n", r"table.center_xy\[0\]=1e\+300 m is outside"),
    ("robot:\n  home_tip_xy: [0, -1e300]\n", r"robot.home_tip_xy\[1\]=-1e\+300 m is outside"),
    ("robot:\n  left_arm_q: [0, 0, 0, 1e300, 0, 0, 0]\n", r"robot.left_arm_q\[3\]=1e\+300 rad"),
    (
        "robot:\n  posture_seed: [9, 0, 0, 0, 0, 0, 0]\n",
        r"robot.posture_seed\[0\]=9 rad is outside",
    ),
    ("box:\n  mass: " + "1" * 400 + "\n", r"box.mass=<an integer of 400 digits> must be a number"),
    ("1: 2\n", r"the key 1 is not a name"),
    ("tool:\n  3: 4\n", r"the key 3 in tool is not a name"),
    ("box: {size: [0.04, 0.04, 0.04], true: 1}\n", r"the key True in box is not a name"),
    ("tool: " + "[" * 10_000 + "]" * 10_000 + "\n", r"nested more than 32 levels deep"),
    ("goal_offset: " + "[" * 40 + "]" * 40 + "\n", r"nested more than 32 levels deep"),
    ("box:\n  mass: " + "1" * 5_000 + "\n", r"a number has more than 4300 digits"),
]


@pytest.mark.parametrize("text, message", BAD, ids=[b[0][:40] for b in BAD])
def test_a_bad_scenario_is_exit_2_naming_the_value(tmp_path, capsys, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        load_scenario(path)
    code = main(["measure-box", "--scenario", str(path)])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE, err
    assert len(err.strip().splitlines()) == 1 and "Failure at" not in err, err


def test_an_env_and_a_training_run_refuse_it_before_drake_does(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("plant:\n  stiction_tolerance: -1\n")
    with pytest.raises(ValueError, match="stiction_tolerance"):
        gym.make("drake_tooluse/ToolPush-v1", scenario=str(path))
    out = tmp_path / "run"
    code = main(["train", "--out", str(out), "--scenario", str(path), "--timesteps", "64"])
    assert code == EXIT_USAGE and "stiction_tolerance" in capsys.readouterr().err
    assert not out.exists()  # nothing written, not even a lock


def test_a_run_refused_inside_train_leaves_no_directory(tmp_path, capsys):
    """What train refuses after it took the run directory's lock (here: an --init-from policy
    whose actions do not fit the env's) leaves no directory holding only that lock."""
    from drake_tooluse.paths import POLICIES_DIR

    out = tmp_path / "run"
    argv = ["train", "--out", str(out), "--timesteps", "64", "--n-envs", "1"]
    code = main([*argv, "--init-from", str(POLICIES_DIR / "ppo_toolpush_paper_action")])
    assert code == EXIT_USAGE and "init_from" in capsys.readouterr().err
    assert not out.exists()


def test_every_plant_field_is_checked():
    """A field a newer Drake adds to MultibodyPlantConfig is a failing test here, not a value
    that reaches Drake unchecked (it is still put through Drake's preconditions)."""
    fields = {f.name for f in MultibodyPlantConfig.__fields__}
    assert fields == set(PLANT_RANGES) | set(PLANT_CHOICES) | set(PLANT_FLAGS)


def test_the_one_handler_names_a_value_drake_refuses():
    config = MultibodyPlantConfig(time_step=0.01, stiction_tolerance=-1.0)
    with pytest.raises(ValueError, match=r"^plant x: Drake refuses it \(set_stiction_tolerance"):
        with refused_by_library("plant x"):
            AddMultibodyPlant(config, DiagramBuilder())
    with pytest.raises(SystemExit):  # any other SystemExit passes through
        with refused_by_library("x"):
            raise SystemExit(3)


def test_a_drake_failure_that_escapes_is_one_line_not_drake_s_abort(monkeypatch, capsys):
    def reaches_drake(args):
        AddMultibodyPlant(MultibodyPlantConfig(stiction_tolerance=-1.0), DiagramBuilder())

    monkeypatch.setattr(robot_cli, "cmd_fk", reaches_drake)
    code = main(["fk", "--no-tool", "--q", *["0"] * 7, "--json"])
    captured = capsys.readouterr()
    assert code == EXIT_INTERNAL, captured.err
    assert len(captured.err.strip().splitlines()) == 1 and "bazel-out" not in captured.err
    assert "set_stiction_tolerance" in captured.err and "a bug" in captured.err


# -- fuzzing -----------------------------------------------------------------------------

_number = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.sampled_from([0, -1, 1e-300, 1e300, 0.001, 0.02, 1.0]),
)
_FIELDS = {
    "plant": [
        "time_step",
        "penetration_allowance",
        "stiction_tolerance",
        "sap_near_rigid_threshold",
    ],
    "box": ["mass", "friction", "yaw"],
    "tool": ["length", "radius", "mass"],
    "control": ["control_period", "actuation_delay"],
    "camera": ["fov_y", "clipping_near", "noise_sigma"],
}
_VECTORS = {
    ("box", "position"): 3,
    ("table", "center_xy"): 2,
    ("robot", "home_tip_xy"): 2,
    ("robot", "left_arm_q"): 7,
}


@st.composite
def _scenarios(draw):
    doc = {}
    for _ in range(draw(st.integers(1, 4))):
        group = draw(st.sampled_from(sorted(_FIELDS)))
        doc.setdefault(group, {})[draw(st.sampled_from(_FIELDS[group]))] = draw(_number)
    if draw(st.booleans()):
        (group, name), size = draw(st.sampled_from(sorted(_VECTORS.items())))
        doc.setdefault(group, {})[name] = draw(st.lists(_number, min_size=size, max_size=size))
    if draw(st.booleans()):
        doc["goal_offset"] = draw(st.lists(_number, min_size=3, max_size=3))
    return doc


@settings(
    max_examples=40,
    deadline=None,
    database=None,  # (nothing written into the checkout)
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(doc=_scenarios())
def test_a_fuzzed_scenario_is_valid_for_drake_or_a_value_error(tmp_path_factory, doc):
    path = tmp_path_factory.mktemp("fuzz") / "s.yaml"
    path.write_text(yaml.safe_dump(doc))
    try:
        s = load_scenario(path)
    except ValueError as e:
        assert "\n" not in str(e) and len(str(e)) < 1000
        return
    AddMultibodyPlant(s.plant, DiagramBuilder())  # Drake's preconditions hold
    for v in [*s.box.position, *s.table.center_xy, *s.robot.home_tip_xy]:
        assert math.isfinite(v) and abs(v) <= WORKSPACE
    goal = [b + g for b, g in zip(s.box.position, s.goal_offset)]
    assert all(abs(v) <= WORKSPACE for v in goal)


@pytest.mark.parametrize(
    "tool_yaml, field",
    [
        ("  kind: straight\n  hook_length: 0.06\n  hook_angle: 75\n", "hook_length"),
        ("  hook_angle: 75\n", "hook_angle"),  # kind left out: straight
    ],
)
def test_a_straight_tool_with_a_hooks_fields_is_refused_naming_them(tmp_path, tool_yaml, field):
    path = tmp_path / "s.yaml"
    path.write_text("tool:\n" + tool_yaml)
    with pytest.raises(ValueError, match=rf"tool\.{field}=.* describes a hook, but tool\.kind"):
        load_scenario(path)
