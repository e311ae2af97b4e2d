"""benchmarks/tool_choice.py checks its arguments as `drake-tooluse choose-tool` does: a bad
value is one line naming it and its range, exit 2, before any work."""

import pytest

from tests.benchmark_scripts import benchmark_script


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--tools", "hook:a,b"], "tool 'hook:a,b' is not straight:L"),
        (["--tools", "straight:-1"], "tool length=-1 m is outside the allowed range"),
        (["--seed", "-1"], "--seed=-1 is outside the allowed range [0, 4294967295]"),
        (["--seed", "99999999999"], "--seed=99999999999 is outside the allowed range"),
        (["--rollouts", "0"], "--rollouts=0 is outside the allowed range [1, 20]"),
        (["--delay-margin", "nan"], "--delay-margin=nan must be a finite number"),
        (["--instances", "0"], "--instances=0 is outside the allowed range"),
        (["--generated-racks", "2", "--tools", "straight:0.3"], "give no --tools with it"),
        (["--instances", "3", "--generated-racks", "4"], "--generated-racks=4 is outside"),
        (["--generated-racks", "2", "--out", "x.txt"], "--out 'x.txt' must be a .json file"),
        (["--workers", "0"], "--workers=0 is outside the allowed range [1, 64]"),
        (["--resume"], "--resume needs --out"),
        (["--resume", "--out", "/no/such/run.json"], "--resume: cannot read '/no/such/run.json'"),
    ],
)
def test_bad_arguments_are_one_line_errors(argv, says, monkeypatch, capsys):
    tool_choice = benchmark_script("tool_choice")
    monkeypatch.setattr("sys.argv", ["tool_choice.py", *argv])
    monkeypatch.setattr(tool_choice, "Policies", lambda: pytest.fail("work started"))
    with pytest.raises(SystemExit) as exited:
        tool_choice.main()
    assert exited.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert says in err[-1] and "Traceback" not in "\n".join(err)


def test_a_resume_of_other_arguments_is_refused(tmp_path, monkeypatch, capsys):
    tool_choice = benchmark_script("tool_choice")
    out = tmp_path / "run.json"
    args = ["--tasks", "pull", "--instances", "4"]
    recorded = tool_choice.recorded_args(tool_choice.parser().parse_args(args))
    out.write_text(tool_choice.json.dumps({"args": {**recorded, "rollouts": 1}, "results": []}))
    monkeypatch.setattr("sys.argv", ["tool_choice.py", *args, "--out", str(out), "--resume"])
    monkeypatch.setattr(tool_choice, "Policies", lambda: pytest.fail("work started"))
    with pytest.raises(SystemExit) as exited:
        tool_choice.main()
    assert exited.value.code == 2
    assert "holds a run of other arguments" in capsys.readouterr().err
    out.write_text("[]")  # JSON, but no run's file
    with pytest.raises(SystemExit) as exited:
        tool_choice.main()
    assert exited.value.code == 2
    assert "holds a run of other arguments: None" in capsys.readouterr().err


@pytest.mark.slow
def test_a_resumed_run_keeps_the_results_written_and_runs_the_rest(tmp_path, monkeypatch):
    tool_choice = benchmark_script("tool_choice")
    out = tmp_path / "run.json"
    argv = ["tool_choice.py", "--tasks", "push", "--instances", "2", "--rollouts", "1"]
    argv += ["--tools", "straight:0.3", "--workers", "1", "--out", str(out)]
    monkeypatch.setattr("sys.argv", argv)
    tool_choice.main()
    whole = tool_choice.json.loads(out.read_text())
    killed = {**whole, "results": whole["results"][:1]}  # as a kill in the second leaves it
    killed["results"][0]["kept"] = True
    out.write_text(tool_choice.json.dumps(killed))
    monkeypatch.setattr("sys.argv", [*argv, "--resume"])
    tool_choice.main()
    resumed = tool_choice.json.loads(out.read_text())["results"]
    assert resumed[0].get("kept") and "kept" not in resumed[1]
    assert [r["seed"] for r in resumed] == [r["seed"] for r in whole["results"]]
    assert resumed[1]["success"] == whole["results"][1]["success"]
