"""benchmarks/unseen_tools.py: bad arguments are one-line errors before any episode, and a small
run measures each policy on the held-out tools, one episode per tool, the JSON the table's."""

import json
import shutil
from pathlib import Path

import pytest

from drake_tooluse.robot.tool_fit import OTHER
from drake_tooluse.robot.tool_generator import FAMILIES, HELD_OUT_FAMILY, in_corner
from tests.benchmark_scripts import benchmark_script

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--policies", "no/such/policy"], "'no/such/policy' is not a policy directory"),
        (["--tools", "0"], "--tools=0 is outside the allowed range [1, 100000]"),
        (["--out", "x.txt"], "--out 'x.txt' must be a .json file"),
        (["--told"], "--told goes with --reality"),
        (["--max-steps", "0"], "--max-steps=0 is outside the allowed range [1, 100000]"),
    ],
)
def test_bad_arguments_are_one_line_errors(argv, message, monkeypatch, capsys):
    monkeypatch.setattr("sys.argv", ["unseen_tools.py", *argv])
    with pytest.raises(SystemExit) as exit:
        benchmark_script("unseen_tools").main()
    out, err = capsys.readouterr()
    assert exit.value.code == 2 and message in err and out == ""


def test_a_policy_no_tool_task_deploys_is_refused(tmp_path, monkeypatch, capsys):
    policy = tmp_path / "box_reward"
    shutil.copytree(ROOT / "models" / "policies" / "ppo_toolpush_tip", policy)
    meta = policy / "policy.json"
    text = meta.read_text().replace("ToolPush-v1", "ToolPushBoxReward-v1")
    meta.write_text(text)
    monkeypatch.setattr("sys.argv", ["unseen_tools.py", "--policies", str(policy)])
    with pytest.raises(SystemExit) as exit:
        benchmark_script("unseen_tools").main()
    assert exit.value.code == 2
    assert "ToolPushBoxReward-v1, which no tool task deploys" in capsys.readouterr().err


def test_the_pull_runs_on_the_held_out_tools_it_serves(tmp_path, monkeypatch, capsys):
    """The hook policy on held-out hooks and arcs (as their equivalent hooks); the draws of
    the families it does not serve passed over and counted."""
    out_file = tmp_path / "unseen.json"
    policy = str(ROOT / "models" / "policies" / "ppo_toolpull")
    argv = ["--policies", policy, "--tools", "3", "--max-steps", "120", "--out", str(out_file)]
    monkeypatch.setattr("sys.argv", ["unseen_tools.py", *argv])
    assert benchmark_script("unseen_tools").main() == 0
    out = capsys.readouterr().out
    assert "pull: the draws of families its policy does not serve" in out
    assert "to 120 steps" in out and "at the step limit, 100" in out
    assert "median first success step" in out
    figures = json.loads(out_file.read_text())
    assert figures["max_steps"] == 120
    (result,) = figures["policies"].values()
    assert result["task"] == "pull" and len(result["episodes"]) == 3
    for row in result["episodes"]:
        first = row["first_success_step"]
        assert first is None or 1 <= first <= 120
        assert row["success"] or first is None or first < 120  # a success that did not hold
    assert {row["family"] for row in result["episodes"]} <= {"hook", "arc"}
    assert sum(figures["passed_over"]["pull"].values()) > 0


def test_a_small_run_measures_the_policy_on_held_out_tools(tmp_path, monkeypatch, capsys):
    out_file = tmp_path / "unseen.json"
    monkeypatch.setattr(
        "sys.argv", ["unseen_tools.py", "--tools", "2", "--tool-seed", "5", "--out", str(out_file)]
    )
    assert benchmark_script("unseen_tools").main() == 0
    table = capsys.readouterr().out
    assert "2 held-out tools per task drawn from tool seed 5" in table
    figures = json.loads(out_file.read_text())
    # The shipped policy over shapes and the tip policy, side by side on the same tools.
    assert [Path(p).name for p in figures["policies"]] == [
        "ppo_toolpush_shapes",
        "ppo_toolpush_tip",
    ]
    for name, policy in figures["policies"].items():
        assert Path(name).name in table
        episodes = policy["episodes"]
        assert len(episodes) == 2 and policy["tools"] == 2
        for row in episodes:
            assert row["family"] == HELD_OUT_FAMILY or in_corner(row["family"], row["params"])
            assert 0 <= row["object_to_goal_m"] < 1 and isinstance(row["success"], bool)
        assert policy["success_rate"] == sum(r["success"] for r in episodes) / 2


@pytest.mark.slow
def test_in_reality_each_tool_is_measured_by_the_camera(tmp_path, monkeypatch, capsys):
    out_file = tmp_path / "unseen.json"
    argv = ["--tools", "1", "--tool-seed", "5", "--reality", "--out", str(out_file)]
    monkeypatch.setattr("sys.argv", ["unseen_tools.py", *argv])
    assert benchmark_script("unseen_tools").main() == 0
    assert (
        "in the perturbed reality, each tool measured by the head camera" in capsys.readouterr().out
    )
    figures = json.loads(out_file.read_text())
    assert figures["reality"] and figures["success_goal"] == 0.75
    for policy in figures["policies"].values():
        (row,) = policy["episodes"]
        assert row["measured_family"] in {*FAMILIES, OTHER}
        assert 0 <= row["object_to_goal_m"] < 1


def test_told_in_reality_deploys_the_true_geometry_in_the_perturbed_world(tmp_path, monkeypatch):
    """--reality --told: the reality's scenario (its actuation delay), the robot told the tool,
    nothing measured."""
    out_file = tmp_path / "told.json"
    policy = str(ROOT / "models" / "policies" / "ppo_toolpull")
    argv = ["--policies", policy, "--tools", "1", "--reality", "--told", "--out", str(out_file)]
    monkeypatch.setattr("sys.argv", ["unseen_tools.py", *argv])
    module = benchmark_script("unseen_tools")
    worlds = []
    told = module.told_worlds
    monkeypatch.setattr(module, "told_worlds", lambda *a: worlds.append(told(*a)) or worlds[-1])
    monkeypatch.setattr(module, "measured_realities", None)  # would raise if called
    assert module.main() == 0
    ((scenario, belief, figures),) = worlds[0]
    assert scenario.control.actuation_delay > 0 and figures == {}
    figures = json.loads(out_file.read_text())
    assert figures["reality"] and figures["told"]
