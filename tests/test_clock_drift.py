"""benchmarks/clock_drift.py: a clock counted in integer steps holds every control step on
the period grid with exactly one controller update; the script prints its table."""

from tests.benchmark_scripts import benchmark_script


def test_an_integer_counted_clock_holds_one_update_per_step():
    clock_drift = benchmark_script("clock_drift")
    assert clock_drift.minimal(1000, summed=False) == (0, 0, 0)
    off_grid, _, _ = clock_drift.minimal(1000, summed=True)
    assert 0 <= off_grid <= 1000


def test_drakes_own_step_drifts_on_the_envs_and_theirs_does_not():
    clock_drift = benchmark_script("clock_drift")
    below, none, two = clock_drift.env_clock("drake_tooluse/ToolPush-v1", 100, drake_step=True)
    assert below > 0 and none > 0 and two > 0
    assert clock_drift.env_clock("drake_tooluse/ToolPush-v1", 100, drake_step=False) == (0, 0, 0)


def test_the_script_prints_its_table(capsys):
    clock_drift = benchmark_script("clock_drift")
    assert clock_drift.main(["--steps", "20"]) == 0
    out = capsys.readouterr().out
    assert "k * period (integer count)" in out and "drake_tooluse/ToolPull-v1, 20" in out
    assert "DrakeGymEnv.step" in out


def test_the_upstream_reproduction_in_the_docs_runs(capsys):
    import re
    from pathlib import Path

    page = Path(__file__).resolve().parents[1] / "docs" / "CLOCK.md"
    (reproduction,) = re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
    exec(compile(reproduction, str(page), "exec"), {"__name__": "clock_md"})
    assert capsys.readouterr().out.startswith("steps without an update: ")
