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
