"""`train` takes the env's options directly (--env-kwargs, --tool-length, --scenario), merged
over the YAML's env kwargs and checked before anything runs."""

import pytest

from drake_tooluse.cli import main
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.paths import SHIPPED_POLICY

ENV = "drake_tooluse/ToolPush-v1"


def test_env_kwargs_merge_over_the_yaml():
    config = resolve_config(ENV, "ppo", 100, 1, 0, env_kwargs={"tool_length": 0.2})
    assert config.hyperparams["env_kwargs"] == {
        "action_mode": "position",
        "randomize": True,
        "tool_length": 0.2,
    }
    with pytest.raises(ValueError, match=r"tool_length=0.9 m is outside the allowed range"):
        resolve_config(ENV, "ppo", 100, 1, 0, env_kwargs={"tool_length": 0.9})


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--tool-length", "0.9"], "--tool-length=0.9 m is outside the allowed range (0, 0.6] m"),
        (["--env-kwargs", '{"bogus": 1}'], "unknown argument(s) ['bogus']"),
        (["--env-kwargs", "[1"], "--env-kwargs"),
        (["--scenario", "no/such.yaml"], "no/such.yaml"),
        (["--env-kwargs", '{"meshcat": 3}'], "meshcat=3 must be a pydrake.geometry.Meshcat"),
        (["--env-kwargs", '{"meshcat": "x"}'], "meshcat='x' must be a pydrake.geometry.Meshcat"),
        # Checked against the scenario's plant step before any env process starts.
        (
            ["--env-kwargs", '{"actuation_delay_range": [0.005, 0.015]}'],
            "holds no multiple of the plant's time step 0.02 s",
        ),
    ],
)
def test_bad_env_options_are_one_line_errors(argv, message, tmp_path, capsys):
    code = main(["train", "--out", str(tmp_path / "run"), "--timesteps", "10", *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err
    assert not (tmp_path / "run" / "config.json").exists()


def test_evaluate_refuses_a_meshcat_kwarg_of_the_wrong_type(capsys):
    code = main(
        [
            "evaluate",
            "--policy",
            str(SHIPPED_POLICY),
            "--episodes",
            "1",
            "--env-kwargs",
            '{"meshcat": 3}',
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "meshcat=3 must be a pydrake.geometry.Meshcat" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
