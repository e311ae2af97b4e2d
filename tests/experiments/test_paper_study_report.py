"""docs/TRAINING.md is the page `drake-tooluse study-report` makes from the committed results
(docs/results/paper_study.json and its archive), so a results file committed without its page
(or a page edited by hand) fails the suite."""

import json
from pathlib import Path

from drake_tooluse.cli import main as cli_main
from drake_tooluse.experiments import paper_study_report as report
from drake_tooluse.experiments.paper_study_cells import StudyFiles, load_cells

ROOT = Path(__file__).resolve().parents[2]


def test_committed_training_page_is_current():
    files = StudyFiles.docs(ROOT)
    cells, _, _ = load_cells()
    page = report.training_page(json.loads(files.results.read_text()), cells, files)
    committed = files.page.read_text()
    assert report.without_queue(committed) == report.without_queue(page)
    for name in ("training_env1_algorithms.png", "training_env1_trajectories.png"):
        assert f"]({Path('figures') / name})" in committed  # the page shows its figures
    assert "issue" not in committed.lower()


def test_only_the_list_of_runs_still_to_run_is_left_out_of_the_check():
    page = "# T\n\n| a | 1.00 |\n\n**Still to run**, …:\n\n- `x` seed 0: training now\n\n## What it shows\n\nz\n"
    assert report.without_queue(page) == report.without_queue(
        page.replace("training now", "last archived checkpoint at 5")
    )
    assert report.without_queue(page) != report.without_queue(page.replace("1.00", "1.01"))


def test_check_fails_on_a_stale_page_and_passes_on_a_current_one(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    (out / "paper_study.json").write_text("{}")
    page = out / "TRAINING.md"
    page.write_text("# an old page\n")
    assert cli_main(["study-report", "--out", str(out), "--check"]) == 2
    err = capsys.readouterr().err
    assert "is not the page of" in err and "study-report --out" in err
    assert page.read_text() == "# an old page\n"  # --check writes nothing
    assert cli_main(["study-report", "--out", str(out)]) == 0  # makes the page
    assert "Every cell has all its seeds" not in page.read_text()  # nothing has run
    capsys.readouterr()
    assert cli_main(["study-report", "--out", str(out), "--check"]) == 0
    assert ": current" in capsys.readouterr().out


def test_a_malformed_results_file_is_a_one_line_error(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    results = out / "paper_study.json"
    for text, says in (
        ("{bad", "not a readable JSON"),
        ("[1]", "not list"),
        ('{"c": {"seeds": {"0": {"x": NaN}}}}', "it holds NaN; a results file holds finite"),
        ('{"c": {"seeds": {"abc": {}}}}', "cell 'c' has seed 'abc'; seeds are non-negative"),
        ('{"c": {"seeds": []}}', "cell 'c' is not an object with a 'seeds' object"),
    ):
        results.write_text(text)
        assert cli_main(["study-report", "--out", str(out), "--check"]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1
        assert err.startswith(f"drake-tooluse study-report: error: {results}: ") and says in err
