"""Scenario loading: typed YAML, unknown keys, ranges, missing files."""

from pathlib import Path

import pytest

from drake_tooluse.world.paper import PAPER_TOOL_LENGTHS
from drake_tooluse.world.scenario import Scenario, load_scenario, validate_scenario

DIAGRAMS = Path(__file__).resolve().parents[2] / "diagrams"


def test_push_scenarios_hold_the_papers_two_tools():
    lengths = {
        load_scenario(DIAGRAMS / name).tool.length for name in ("push.yaml", "push_tool_125.yaml")
    }
    assert lengths == set(PAPER_TOOL_LENGTHS)


def test_unknown_key_is_an_error_naming_it(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("tool:\n  lenght: 0.2\n")
    with pytest.raises(ValueError, match="lenght"):
        load_scenario(path)


def test_missing_file_is_an_error_naming_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.yaml"):
        load_scenario(tmp_path / "nope.yaml")


@pytest.mark.parametrize(
    "yaml_text, message",
    [
        ("tool:\n  length: 0.0\n", r"tool.length=0 m is outside the allowed range \(0, 0.6\]"),
        ("tool:\n  length: 0.9\n", r"tool.length=0.9 m is outside"),
        ("tool:\n  length: .nan\n", r"tool.length=nan must be a finite number"),
        ("box:\n  mass: -1.0\n", r"box.mass=-1 kg is outside the allowed range \[0.01, 10\]"),
        ("plant:\n  contact_model: soft\n", r"plant.contact_model='soft' is not allowed"),
        ("control:\n  kp: [1, 2]\n", r"control.kp has 2 values; it needs exactly 7"),
    ],
)
def test_bad_values_name_value_and_range(tmp_path, yaml_text, message):
    path = tmp_path / "s.yaml"
    path.write_text(yaml_text)
    with pytest.raises(ValueError, match=message):
        load_scenario(path)


def test_defaults_validate():
    validate_scenario(Scenario())


def test_reality_is_push_with_only_what_it_states(tmp_path):
    """Scenarios are layers: reality.yaml names push.yaml as its base and changes four values."""
    import dataclasses as dc

    from pydrake.common.yaml import yaml_dump_typed

    push, reality = load_scenario(DIAGRAMS / "push.yaml"), load_scenario(DIAGRAMS / "reality.yaml")
    assert reality.base == "push.yaml"
    expected = dc.replace(
        push,
        base="push.yaml",
        tool=dc.replace(push.tool, length=0.125),
        control=dc.replace(push.control, actuation_delay=0.04),
        robot=dc.replace(push.robot, conservative_limits=True),
        camera=dc.replace(push.camera, noise_sigma=5.0),
    )
    assert yaml_dump_typed(reality) == yaml_dump_typed(expected)


def test_a_layer_keeps_its_bases_values_in_a_group_it_changes(tmp_path):
    (tmp_path / "base.yaml").write_text("box:\n  mass: 0.5\n  friction: 0.6\n")
    (tmp_path / "child.yaml").write_text("base: base.yaml\nbox:\n  mass: 0.3\n")
    box = load_scenario(tmp_path / "child.yaml").box
    assert (box.mass, box.friction) == (0.3, 0.6)


def test_bases_that_form_a_cycle_are_an_error(tmp_path):
    (tmp_path / "a.yaml").write_text("base: b.yaml\n")
    (tmp_path / "b.yaml").write_text("base: a.yaml\n")
    with pytest.raises(ValueError, match="scenario bases form a cycle"):
        load_scenario(tmp_path / "a.yaml")


def test_a_missing_base_is_an_error_naming_it(tmp_path):
    (tmp_path / "a.yaml").write_text("base: gone.yaml\n")
    with pytest.raises(FileNotFoundError, match="gone.yaml"):
        load_scenario(tmp_path / "a.yaml")


@pytest.mark.parametrize(
    "text, message",
    [("tool: [1, 2\n", "not YAML"), ("- 1\n- 2\n", "must be a mapping of groups")],
)
def test_malformed_yaml_is_an_error_naming_the_file(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"bad.yaml.*{message}"):
        load_scenario(path)


def test_every_randomization_draw_is_a_valid_world(tmp_path):
    """The largest scaled box mass must stay in range, so no draw can fail at an env reset."""
    path = tmp_path / "heavy.yaml"
    path.write_text("box:\n  mass: 9.0\n")
    with pytest.raises(ValueError, match=r"box.mass x randomization.box_mass_scale\[1\]=11.7"):
        load_scenario(path)


def test_a_drawn_yaw_is_wrapped_into_range():
    import dataclasses as dc

    import numpy as np

    from drake_tooluse.world.randomization import apply_draw, draw_randomization

    s = Scenario()
    s = validate_scenario(dc.replace(s, box=dc.replace(s.box, yaw=3.1)))
    draw = dc.replace(draw_randomization(s, np.random.default_rng(0)), box_dyaw=0.1)
    yaw = apply_draw(s, draw).box.yaw
    assert yaw == pytest.approx(3.2 - 2 * np.pi)
