"""benchmarks/distill_gap.py refuses bad arguments with one line naming the value, before any
episode runs (its measurement runs in the docs tests, with small budgets), and finds the
teacher a student was distilled from."""

from pathlib import Path

import pytest

from drake_tooluse.learning.policy_dir import load_policy
from tests.benchmark_scripts import benchmark_script

ROOT = Path(__file__).resolve().parents[2]
STUDENT = ROOT / "models" / "policies" / "ppo_toolpush_paper_action"


def _script():
    return benchmark_script("distill_gap")


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--student", "no/such/policy"], "'no/such/policy' is not a policy directory"),
        (["--student", str(STUDENT), "--episodes", "0"], "--episodes=0 is outside"),
        (["--student", str(STUDENT), "--delays", "0.5"], "--delays 0.5 is outside [0, 0.2] s"),
        (
            ["--student", str(STUDENT), "--teacher", str(STUDENT)],
            "the teacher must be a push policy of action_mode 'position'",
        ),
    ],
)
def test_bad_arguments_are_one_line_errors(argv, message, monkeypatch, capsys):
    monkeypatch.setattr("sys.argv", ["distill_gap.py", *argv])
    with pytest.raises(SystemExit) as exit:
        _script().main()
    out, err = capsys.readouterr()
    assert exit.value.code == 2 and message in err and out == ""
    assert err.strip().splitlines()[-1].startswith("distill_gap.py: error: ")


def test_the_teacher_is_the_one_the_student_was_distilled_from(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    teacher = Path("models/policies/ppo_toolpush_tip")
    assert _script().teacher_of(load_policy(STUDENT), STUDENT) == teacher
    monkeypatch.chdir(tmp_path)  # elsewhere: the student's checkout's
    assert _script().teacher_of(load_policy(STUDENT), STUDENT) == ROOT / teacher
