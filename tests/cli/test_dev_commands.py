"""Maintainers' commands live under `dev`, apart from the users' (their old names still run,
with a line naming the new); a flag name means one thing (`--record`: simulate's recording
file; the tip poses a trajectory averages are `--tip-poses`)."""

import pytest

from drake_tooluse.cli import EXIT_USAGE, main, make_parser
from drake_tooluse.cli.maintenance import COMMANDS as DEV_COMMANDS


def test_the_users_command_list_holds_dev_not_the_maintainers_commands():
    import argparse

    parser = make_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert "dev" in sub.choices and not set(DEV_COMMANDS) & set(sub.choices)
    usage = parser.format_usage()  # the list of commands `drake-tooluse` shows
    assert ",dev}" in usage and not any(f",{name}" in usage for name in DEV_COMMANDS)


@pytest.mark.parametrize(
    "argv", [["dev", "generate-models", "--check"], ["generate-models", "--check"]]
)
def test_dev_commands_run_and_their_old_names_still_do(capsys, argv):
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "is current" in captured.out
    moved = "drake-tooluse generate-models is now `drake-tooluse dev generate-models`"
    assert (moved in captured.err) == (argv[0] != "dev")


def test_a_dev_command_s_errors_name_it(capsys, tmp_path):
    argv = ["dev", "render-figures", "--check", "--figures-dir", str(tmp_path / "none"), "--json"]
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err
    assert err.startswith("drake-tooluse dev render-figures: error: ") and err.count("\n") == 1


def test_dev_alone_asks_for_a_command(capsys):
    assert main(["dev"]) == EXIT_USAGE
    assert "the following arguments are required: COMMAND" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["transfer", "trajectory"])
def test_record_is_refused_where_it_once_meant_tip_poses_naming_the_new_flag(capsys, command):
    argv = [command, "--record", "commanded"]
    if command == "trajectory":
        argv += ["--policy", "x", "--out", "y"]
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err.splitlines()[-1]
    assert err == (
        f"drake-tooluse {command}: error: --record is now --tip-poses (achieved or commanded); "
        "--record names a Meshcat recording file, in `simulate`"
    )


def test_record_is_a_recording_file_wherever_it_is_offered():
    import argparse

    from drake_tooluse.cli import commands

    sub = next(a for a in make_parser()._actions if isinstance(a, argparse._SubParsersAction))
    offered = {
        p.prog: a.metavar
        for p in commands(sub)
        for a in p._actions
        if "--record" in a.option_strings and a.help != argparse.SUPPRESS
    }
    assert offered == {"drake-tooluse simulate": "HTML", "drake-tooluse choose-tool": "HTML"}
