"""docs/TRAINING.md is the page benchmarks/paper_report.py makes from the committed results, so a
results file committed without its page (or a page edited by hand) fails the suite."""

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / "benchmarks" / "paper_report.py"


@pytest.fixture(scope="module")
def report():
    sys.path.insert(0, str(REPORT.parent))  # paper_report imports paper_experiments beside it
    try:
        import paper_report

        yield paper_report
    finally:
        sys.path.remove(str(REPORT.parent))


def test_committed_training_page_is_current(report):
    results = json.loads(report.RESULTS.read_text())
    page = report.training_page(results, report.ARCHIVE, report.FIGURES, report.REPORT)
    committed = report.REPORT.read_text()
    assert report.without_queue(committed) == report.without_queue(page)
    for name in ("training_env1_algorithms.png", "training_env1_trajectories.png"):
        assert f"]({Path('figures') / name})" in committed  # the page shows its figures


def test_only_the_list_of_runs_still_to_run_is_left_out_of_the_check(report):
    page = "# T\n\n| a | 1.00 |\n\n**Still to run**, …:\n\n- `x` seed 0: training now\n\n## What it shows\n\nz\n"
    assert report.without_queue(page) == report.without_queue(
        page.replace("training now", "last archived checkpoint at 5")
    )
    assert report.without_queue(page) != report.without_queue(page.replace("1.00", "1.01"))


def test_check_exits_1_on_a_stale_page_and_0_on_a_current_one(
    report, tmp_path, monkeypatch, capsys
):
    results, doc = tmp_path / "paper_study.json", tmp_path / "TRAINING.md"
    results.write_text("{}")
    args = ["paper_report.py", "--results", str(results), "--doc", str(doc)]
    args += ["--runs-dir", str(tmp_path / "runs"), "--figures", str(tmp_path / "figures")]

    def main(*extra) -> int:
        monkeypatch.setattr(sys, "argv", [*args, *extra])
        try:
            report.main()
        except SystemExit as e:
            return e.code
        return 0

    doc.write_text("# an old page\n")
    assert main("--check") == 1 and "NOT current" in capsys.readouterr().out
    assert doc.read_text() == "# an old page\n"  # --check writes nothing
    assert main() == 0  # makes the page
    assert main("--check") == 0 and ": current" in capsys.readouterr().out


@pytest.mark.parametrize("text, says", [("{bad", "not a readable JSON"), ("[1]", "not list")])
def test_a_malformed_results_file_is_a_one_line_error(
    report, tmp_path, monkeypatch, capsys, text, says
):
    results = tmp_path / "paper_study.json"
    results.write_text(text)
    monkeypatch.setattr(sys, "argv", ["paper_report.py", "--check", "--results", str(results)])
    with pytest.raises(SystemExit) as e:
        report.main()
    err = capsys.readouterr().err
    assert e.value.code == 2 and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith(f"paper_report.py: error: {results}: ")
    assert says in err
