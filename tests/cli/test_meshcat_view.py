"""`--meshcat`: the commands that show a scene start Meshcat, print its URL, and keep the view
open after the result until the user is done (Enter; a line or the end of stdin when stdin is
not a terminal)."""

import argparse
import io
import json
import os
import subprocess
import sys
import threading

import pytest

from drake_tooluse.cli import make_parser
from drake_tooluse.cli.common import wait_for_user

SHOWN = ("demo", "simulate", "evaluate")


@pytest.mark.parametrize("command", SHOWN)
def test_the_commands_that_show_a_scene_offer_meshcat(command):
    sub = next(a for a in make_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert "--meshcat" in sub.choices[command].format_help()


class _Meshcat:
    def web_url(self):
        return "http://localhost:7000"


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_at_a_terminal_it_waits_for_enter(capsys):
    stdin = _Terminal("\nnot read\n")
    wait_for_user(_Meshcat(), stdin)
    assert stdin.read() == "not read\n"  # one line read: the Enter
    assert "http://localhost:7000 stays open; press Enter to close it" in capsys.readouterr().err


def test_without_a_terminal_the_end_of_stdin_ends_the_wait(capsys):
    wait_for_user(_Meshcat(), io.StringIO(""))  # (at once: no one will press Enter)
    assert "send a line or close stdin to close it" in capsys.readouterr().err


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_simulate_keeps_its_view_open_until_stdin_says_so():
    argv = [sys.executable, "-m", "drake_tooluse.cli", "simulate", "--tip-waypoints"]
    argv += ["0.66,-0.2,-0.12", "--move-time", "0.1", "--dwell", "0", "--meshcat", "--json"]
    proc = subprocess.Popen(
        argv,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": os.getcwd()},
    )
    killer = threading.Timer(240, proc.kill)  # a hang fails the test, not the suite
    killer.start()
    try:
        lines = []
        while not any("stays open" in line for line in lines):
            line = proc.stderr.readline()
            assert line, "".join(lines)  # it ended without waiting
            lines.append(line)
        url = next(x for x in lines if x.startswith("Meshcat: open ")).split()[2]
        assert url.startswith("http://localhost:")
        result = ""
        while True:  # the result is printed (and flushed) before the wait
            result += proc.stdout.readline()
            if result.rstrip().endswith("}") and result.count("{") == result.count("}"):
                break
        assert json.loads(result)["meshcat_url"] == url
        assert proc.poll() is None  # still open: the view with it
        proc.stdin.write("\n")
        proc.stdin.flush()
        assert proc.wait(timeout=60) == 0
    finally:
        killer.cancel()
        proc.kill()


def test_evaluate_draws_its_episodes_in_meshcat_and_ends_with_stdin(capsys, monkeypatch):
    from drake_tooluse.cli import main
    from drake_tooluse.paths import TRANSFER_POLICY

    monkeypatch.setattr(sys, "stdin", io.StringIO(""))  # no terminal, nothing to read: no wait
    argv = ["evaluate", "--policy", str(TRANSFER_POLICY), "--episodes", "1", "--meshcat"]
    assert main([*argv, "--json"]) == 0
    captured = capsys.readouterr()
    url = json.loads(captured.out)["meshcat_url"]
    assert f"Meshcat: open {url} in a browser" in captured.err
    assert f"Meshcat: {url} stays open; send a line or close stdin" in captured.err
