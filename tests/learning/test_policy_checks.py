"""A policy directory's files are checked against each other and against the env they name,
the same way in every command."""

import json
import re
import shutil

import numpy as np
import pytest

from drake_tooluse.cli import main
from drake_tooluse.learning.policy_dir import build_model, load_policy, parse_meta
from drake_tooluse.paths import TRANSFER_POLICY


@pytest.fixture
def policy(tmp_path):
    """A copy of the shipped tool-tip policy to break."""
    copy = tmp_path / "policy"
    shutil.copytree(TRANSFER_POLICY, copy)
    return copy


def _edit(directory, **changes):
    path = directory / "policy.json"
    meta = json.loads(path.read_text())
    meta.update(changes)
    path.write_text(json.dumps(meta))


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"algo": "a2c"}, r"says algo 'a2c' but .*policy.safetensors' holds a 'ppo' policy"),
        ({"algo": "sac"}, r"policy.json': unknown algorithm 'sac'"),
        ({"env_id": "Nope-v0"}, r"policy.json': unknown env 'Nope-v0'"),
        ({"env_kwargs": "x"}, r"policy.json': env_kwargs must be a mapping"),
        ({"env_kwargs": {"colour": 1}}, r"policy.json': unknown argument\(s\) \['colour'\]"),
        ({"env_kwargs": {"randomize": "yes"}}, r"randomize='yes' must be True or False"),
        ({"action_shape": [7]}, r"action_shape \[7\] do not fit its env_kwargs"),
        ({"observation_shape": [30]}, r"observation_shape \[30\] .* observes \[12\]"),
        ({"normalized": False}, r"says normalized: false but .*normalization.json' is there"),
        ({"normalized": "yes"}, r"normalized='yes' must be true or false"),
        ({"surprise": 1}, r"unknown keys \['surprise'\]"),
    ],
)
def test_inconsistent_metadata_is_refused(policy, changes, message):
    _edit(policy, **changes)
    with pytest.raises(ValueError, match=message):
        load_policy(policy)


@pytest.mark.parametrize(
    "changes, message",
    [
        (
            {"env_id": "drake_tooluse/ToolPush-v0"},
            r"'drake_tooluse/ToolPush-v0' is an earlier version of 'drake_tooluse/ToolPush-v1'",
        ),
        (
            {"env_kwargs": {"observation_mode": "paper", "action_mode": "position"}},
            r"observation_mode='paper' is the earlier version's name of 'gripper_joints'",
        ),
        (
            {"env_kwargs": {"ik_mode": "full", "action_mode": "position"}},
            r"ik_mode='full' is not an option of the push envs",
        ),
    ],
)
def test_a_policy_of_the_earlier_version_is_refused_in_one_line_naming_its_tag(
    policy, changes, message, capsys
):
    _edit(policy, **changes)
    argv = ["evaluate", "--policy", str(policy), "--episodes", "1", "--no-progress"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert re.search(message, err) and "git tag figures-v0" in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_weights_of_other_spaces_are_refused(policy):
    """A 3-action policy's weights under metadata that says 7 actions (the 7-d mode)."""
    _edit(
        policy,
        action_shape=[7],
        env_kwargs={
            "action_mode": "position_quaternion",
            "observation_mode": "tip",
            "randomize": True,
        },
    )
    with pytest.raises(ValueError, match=r"says action_shape \[7\] but .* was saved for \[3\]"):
        load_policy(policy)
    # Without the header's record, the tensors themselves say it.
    meta = parse_meta(json.loads((policy / "policy.json").read_text()), policy / "policy.json")
    from safetensors.torch import load_file

    from drake_tooluse.learning.policy_dir import _set_weights

    with pytest.raises(
        ValueError, match=r"action_net.weight: file \[3, 128\], the policy \[7, 128\]"
    ):
        _set_weights(build_model(meta), load_file(str(policy / "policy.safetensors")), "w", meta)


def test_a_missing_or_wrong_normaliser_is_refused(policy):
    norm = json.loads((policy / "normalization.json").read_text())
    (policy / "normalization.json").write_text(json.dumps({**norm, "obs_mean": [0.0] * 30}))
    with pytest.raises(ValueError, match=r"normalises \[30\] / \[12\] values but the policy"):
        load_policy(policy)
    (policy / "normalization.json").unlink()
    with pytest.raises(
        ValueError, match=r"says normalized: true but normalization.json is missing"
    ):
        load_policy(policy)


def test_missing_weights_are_named(policy, capsys):
    (policy / "policy.safetensors").unlink()
    assert main(["evaluate", "--policy", str(policy)]) == 2
    err = capsys.readouterr().err
    assert "has no policy.safetensors" in err and ".zip.zip" not in err


def test_an_observation_of_the_wrong_size_is_a_clear_error():
    policy = load_policy(TRANSFER_POLICY)
    with pytest.raises(ValueError, match=r"observes 12 values; this observation has shape \[30\]"):
        policy.act(np.zeros(30))


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--env-kwargs", '{"colour": 1}'], r"unknown argument\(s\) \['colour'\]"),
        (
            ["--env-kwargs", '{"action_mode": "position_quaternion"}'],
            r"trained for observations \[12\] and actions \[3\]",
        ),
        (
            ["--env-kwargs", '{"observation_mode": "gripper_joints"}'],
            r"this env has observations \[30\]",
        ),
        (["--env", "Nope-v0"], r"unknown env 'Nope-v0'"),
    ],
)
def test_evaluate_checks_the_env_it_is_given(argv, message, capsys):
    assert main(["evaluate", "--policy", str(TRANSFER_POLICY), "--episodes", "1", *argv]) == 2
    assert re.search(message, capsys.readouterr().err)


@pytest.mark.parametrize("command", ["transfer", "demo", "trajectory"])
def test_every_command_checks_a_policy_the_same_way(policy, command, capsys, tmp_path):
    _edit(policy, env_id="Nope-v0")
    argv = {
        "transfer": ["transfer", "--runs", "1", "--out", str(tmp_path / "o")],
        "demo": ["demo", "--no-progress", "--out", str(tmp_path / "o")],
        "trajectory": ["trajectory", "--episodes", "1", "--out", str(tmp_path / "o")],
    }[command]
    assert main([*argv, "--policy", str(policy)]) == 2
    assert "unknown env 'Nope-v0'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_policy_saves_and_loads_at_a_path_of_non_utf8_bytes(tmp_path):
    """(safetensors' own file calls take only UTF-8 paths; a file name may be any bytes)"""
    from drake_tooluse.learning.policy_dir import convert_policy

    where = convert_policy(TRANSFER_POLICY, tmp_path / "a\udcffb" / "policy", trust_pickle=True)
    assert load_policy(where).meta == load_policy(TRANSFER_POLICY).meta
