"""benchmarks/push_policies_hold.py refuses bad arguments with one line naming the value,
before any policy runs (its measurement runs in the docs tests, with small budgets)."""

from pathlib import Path

import pytest

from tests.benchmark_scripts import benchmark_script

ROOT = Path(__file__).resolve().parents[2]


def _script():
    return benchmark_script("push_policies_hold")


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--policies", "no/such/policy"], "'no/such/policy' is not a policy directory"),
        (
            ["--policies", str(ROOT / "models" / "policies" / "ppo_toolpull")],
            "is a policy for drake_tooluse/ToolPull-v",
        ),
        (["--episodes", "0"], "--episodes=0 is outside the allowed range [1, 100000]"),
        (["--tools", "0.9"], "tool length=0.9 m is outside the allowed range (0, 0.6] m"),
    ],
)
def test_bad_arguments_are_one_line_errors(argv, message, monkeypatch, capsys):
    monkeypatch.setattr("sys.argv", ["push_policies_hold.py", *argv])
    with pytest.raises(SystemExit) as exit:
        _script().main()
    out, err = capsys.readouterr()
    assert exit.value.code == 2 and message in err and out == ""
    assert err.strip().splitlines()[-1].startswith("push_policies_hold.py: error: ")
