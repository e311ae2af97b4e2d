"""The whole command line, walked: every command takes --json and prints human text without it,
every option has help, every default shows in --help, and the exit codes are in every --help;
argument errors come before the heavy libraries are imported."""

import argparse
import json
import subprocess
import sys

import pytest

from drake_tooluse.cli import EXIT_NOT_REACHED, EXIT_USAGE, commands, make_parser

PARSER = make_parser()
# Every command, a group's (`dev render-figures`) included, by its name after `drake-tooluse`.
COMMANDS = {
    p.prog.removeprefix("drake-tooluse "): p
    for p in commands(next(a for a in PARSER._actions if isinstance(a, argparse._SubParsersAction)))
}


def strict_json(text: str):
    """`text` parsed as strict JSON (NaN, Infinity and -Infinity are refused)."""
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} is not strict JSON"))


def options(p):
    return [a for a in p._actions if a.option_strings and not isinstance(a, argparse._HelpAction)]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_takes_json_and_has_a_human_formatter(name):
    p = COMMANDS[name]
    assert any("--json" in a.option_strings for a in options(p))
    defaults = p._defaults
    assert callable(defaults.get("run")) and callable(defaults.get("show")), name


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_option_has_help_and_its_default_shows(name):
    p = COMMANDS[name]
    text = " ".join(p.format_help().split())  # argparse wraps lines
    formatter = p._get_formatter()
    for a in options(p):
        assert a.help and a.help.strip(), f"{name} {a.option_strings[0]} has no help"
        if a.default is not None and a.default is not False:
            shown = formatter._expand_help(a)  # this option's help, as --help prints it
            value = a.default if not isinstance(a.default, list) else a.default[0]
            assert "default" in shown and str(value) in shown, (name, a.option_strings[0], shown)
    assert "exit codes: 0 success" in text and f"{EXIT_NOT_REACHED} target not reached" in text


def test_the_formatter_shows_a_default_the_help_does_not_state():
    text = " ".join(COMMANDS["evaluate"].format_help().split())
    assert "episodes to run (default: 100)" in text
    assert "(default: None)" not in " ".join(c.format_help() for c in COMMANDS.values())


def test_an_unreachable_ik_target_exits_3_and_says_so(capsys):
    from drake_tooluse.cli import main

    argv = ["ik", "--tool-length", "0.1", "--position", "3", "0", "0"]
    assert main(argv) == EXIT_NOT_REACHED
    assert "NOT REACHED (exit code 3)" in capsys.readouterr().out
    assert main([*argv, "--json"]) == EXIT_NOT_REACHED
    assert strict_json(capsys.readouterr().out)["success"] is False


def test_argument_errors_come_before_torch_and_drake_are_imported(tmp_path):
    cases = [
        ["train", "--out", str(tmp_path / "r"), "--timesteps", "0"],
        ["evaluate", "--policy", str(tmp_path), "--episodes", "0"],
        ["sweep", "--out", str(tmp_path / "s"), "--episodes", "0"],
        ["transfer", "--runs", "0", "--out", str(tmp_path / "t")],
        ["demo", "--seed", "-1", "--out", str(tmp_path / "d")],
        ["trajectory", "--policy", str(tmp_path), "--tool-length", "0.7", "--out", str(tmp_path)],
        ["export-csv", "--trajectory", "x.npz", "--tool-length", "0", "--out", "x.csv"],
        ["demo", "--tool-length", "0.9", "--out", str(tmp_path / "d")],
        ["train", "--out", str(tmp_path / "r"), "--algo", "bogus"],
        ["train", "--out", str(tmp_path / "r"), "--env", "bogus"],
        ["train", "--out", str(tmp_path / "r"), "--init-from", str(tmp_path / "none")],
        ["evaluate", "--policy", str(tmp_path / "none")],
        ["evaluate", "--policy", str(tmp_path), "--env", "bogus"],
        ["sweep", "--out", str(tmp_path / "s"), "--algos", "ppo", "bogus"],
        ["sweep", "--out", str(tmp_path / "s"), "--envs", "bogus"],
        ["convert-policy", "--policy", str(tmp_path / "none"), "--out", str(tmp_path / "c")],
        ["transfer", "--mode", "bogus", "--out", str(tmp_path / "t")],
        ["transfer", "--tools", "0.125", "0.9", "--out", str(tmp_path / "t")],
        ["transfer", "--align", "middle", "--out", str(tmp_path / "t")],
        ["trajectory", "--policy", str(tmp_path), "--tip-poses", "bogus", "--out", str(tmp_path)],
        ["study", "--out", str(tmp_path / "st"), "--parallel", "0"],
        ["study", "--out", str(tmp_path / "st"), "--only", "bogus"],
        ["study", "--out", str(tmp_path / "st"), "--update-docs"],
        ["study-report", "--out", str(tmp_path / "st"), "--trajectories", "0"],
    ]
    code = (
        "import sys\nfrom drake_tooluse.cli import main\n"
        f"codes = [main(a) for a in {cases!r}]\n"
        "heavy = [m for m in ('torch', 'pydrake', 'ray', 'stable_baselines3') if m in sys.modules]"
        "\nprint(codes, heavy)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == f"{[EXIT_USAGE] * len(cases)} []", out.stdout + out.stderr


@pytest.mark.parametrize(
    "argv, message",
    [
        (["train", "--algo", "bogus"], "--algo: unknown algorithm 'bogus'; choose one of ['ppo',"),
        (["train", "--env", "bogus"], "--env: unknown env 'bogus'; choose one of ['drake_tooluse/"),
        (["sweep", "--algos", "bogus"], "--algos: unknown algorithm 'bogus'; choose one of"),
        (
            ["train", "--init-from", "{d}/none"],
            "--init-from '{d}/none' is not a policy directory: it does not exist",
        ),
        (
            ["evaluate", "--policy", "{d}"],
            "--policy '{d}' is not a policy directory: it has no policy.json",
        ),
        (
            ["evaluate", "--policy", "{d}/f"],
            "--policy '{d}/f' is not a policy directory: it is a file",
        ),
    ],
)
def test_unknown_names_and_policy_directories_are_refused_naming_what_is_allowed(
    tmp_path, capsys, argv, message
):
    from drake_tooluse.cli import main

    (tmp_path / "f").write_text("")
    out = ["--out", str(tmp_path / "run")] if argv[0] in ("train", "sweep") else []
    assert main([a.replace("{d}", str(tmp_path)) for a in argv] + out) == EXIT_USAGE
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message.replace("{d}", str(tmp_path)) in err, err


def test_the_cli_names_the_algorithms_the_library_has():
    from drake_tooluse.cli.learning import ALGOS
    from drake_tooluse.learning import config

    assert ALGOS == config.ALGOS


def test_the_cli_names_the_modes_alignments_and_recordings_the_library_has():
    from drake_tooluse.cli import experiments as cli
    from drake_tooluse.experiments import trajectory_extraction as trajectory
    from drake_tooluse.experiments import transfer

    assert cli.MODES == transfer.MODES
    assert (cli.ALIGNMENTS, cli.RECORDS) == (trajectory.ALIGNMENTS, trajectory.RECORDS)


def test_the_cli_checks_tool_lengths_in_the_robot_models_range():
    from drake_tooluse.cli.common import tool_length_arg
    from drake_tooluse.robot.tool import TOOL_LENGTH_RANGE

    lo, hi = TOOL_LENGTH_RANGE
    assert tool_length_arg(hi) == hi
    for bad in (lo, hi + 1e-9):
        with pytest.raises(ValueError, match="--tool-length"):
            tool_length_arg(bad)


def test_the_new_human_formatters_say_what_was_done():
    from drake_tooluse.cli import experiments, learning, maintenance

    text = learning.format_train(
        {"timesteps": 2048, "wall_time_s": 90.0, "steps_per_s": 22.8, "sessions": 2, "out": "r"}
    )
    assert text.startswith("trained 2048 steps in 1.5 min (23 steps/s), 2 sessions: r")
    text = experiments.format_export_csv(
        {
            "csv": "x.csv",
            "rows": 40,
            "duration_s": 4.0,
            "clearance": {"arms_m": 0.21, "table_m": 0.05, "tool_tip_above_table_m": 0.012},
        }
    )
    assert "40 rows" in text and "tool tip above the table 1.2 cm" in text
    assert maintenance.format_rendered({"a": {"current": True}, "b": {"dot": "b.dot"}}) == (
        "a: current\nb: b.dot"
    )
    assert maintenance.format_generate_models({"written": "u.urdf"}) == "wrote u.urdf"
    with pytest.raises(json.JSONDecodeError):  # human text, not JSON
        json.loads(text)


@pytest.mark.parametrize("value", ["-inf", "-nan", "-1e-3", "-Infinity"])
def test_a_negative_or_non_finite_value_reaches_the_options_range_check(value, capsys):
    """argparse took `--hook-length -inf` for a missing value ("expected one argument")."""
    from drake_tooluse.cli import main

    assert main(["measure", "--tool-kind", "hook", "--hook-length", value]) == 2
    err = capsys.readouterr().err
    assert "--hook-length=" in err and "expected one argument" not in err
