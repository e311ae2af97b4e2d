"""benchmarks/pull_scripted.py: the scripted pull in the pull world or in reality's limits with a
drawn delay, its table with the episodes a physical-sanity flag was raised in; bad options are
one-line errors."""

import re

import pytest

from drake_tooluse.paths import SCENARIOS_DIR
from tests.benchmark_scripts import benchmark_script


def test_the_scripted_pull_runs_in_reality_s_limits_with_a_drawn_delay(capsys):
    script = benchmark_script("pull_scripted")
    limits = str(SCENARIOS_DIR / "pull_limits.yaml")
    script.main(["--episodes", "1", "--scenario", limits, "--delay-range", "0", "0.06"])
    out = capsys.readouterr().out
    assert "actuation_delay_range=[0.0, 0.06]" in out and "pull_limits.yaml" in out
    row = next(line for line in out.splitlines() if line.startswith("| 1 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert len(cells) == 6 and 0.0 <= float(cells[1]) <= 1.0 and cells[5] in ("0", "1")


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--delay-range", "0", "0.5"], r"actuation_delay_range\[1\]=0.5 s is outside"),
        (["--episodes", "0"], r"--episodes=0 must be at least 1"),
        (["--seed", "-1"], r"--seed=-1 is outside the allowed range \[0, 4294967295\]"),
        (["--scenario", "no_such_world.yaml"], r"scenario file not found: 'no_such_world.yaml'"),
    ],
)
def test_bad_options_are_one_line_errors(capsys, argv, message):
    script = benchmark_script("pull_scripted")
    with pytest.raises(SystemExit) as exit_info:
        script.main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert re.search(message, err) and "Traceback" not in err
