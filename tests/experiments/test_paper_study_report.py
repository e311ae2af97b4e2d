"""docs/TRAINING.md is the page `drake-tooluse study-report` makes from the committed results
(docs/results/paper_study.json and its archive), so a results file committed without its page
(or a page edited by hand) fails CI's slow tests; a results file of the -v1 cells makes the page's
parts: the IQM/CI table beside the paper, the curves, the costs and the earlier study's tag."""

import json
from pathlib import Path

import numpy as np
import pytest

from drake_tooluse.cli import main as cli_main
from drake_tooluse.experiments import paper_study_report as report
from drake_tooluse.experiments.paper_study_cells import StudyFiles, load_cells

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow  # ~5 s; CI runs it with the slow tests
def test_committed_training_page_is_current():
    files = StudyFiles.docs(ROOT)
    cells, _, _ = load_cells()
    page = report.training_page(json.loads(files.results.read_text()), cells, files)
    committed = files.page.read_text()
    assert report.without_queue(committed) == report.without_queue(page)
    for name in ("training_curves.png", "training_trajectories.png"):
        assert f"]({Path('figures') / name})" in committed  # the page shows its figures
        assert (files.figures / name).is_file()
    assert "issue" not in committed.lower()


def _run(distances_cm, successes, wall_min: float) -> dict:
    """A run's entry as the runner records it (the fields the page reads)."""
    evaluation = {
        "final_object_to_goal_mean_m": float(np.mean(distances_cm)) / 100,
        "success_rate": float(np.mean(successes)),
        "per_episode": {
            "final_object_to_goal_m": [d / 100 for d in distances_cm],
            "success": list(successes),
        },
    }
    train = {
        "timesteps": 1_251_328,
        "wall_time_s": wall_min * 60,
        "steps_per_s": 1_251_328 / (wall_min * 60),
    }
    return {"train": train, "evaluate_best": evaluation, "evaluate_best_time_limit": evaluation}


def _row(page: str, cell: str) -> str:
    """The cell's row of the study's table (the first table)."""
    return next(line for line in page.splitlines() if line.startswith(f"| {cell} |"))


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_a_v1_results_file_makes_the_page_of_its_cells(tmp_path):
    """The shipped cells (DDPG's at a smaller budget): a row per cell with its IQM, mean
    and success CIs, its seeds and the paper's figure for its algorithm; the runs still to run
    with an estimate; a learning-curve figure with a band; the costs; the earlier tables' tag.
    (No policy in the archive: no rollouts here.)"""
    cells = load_cells()[0]
    assert cells["v1_ddpg"]["timesteps"] == 300_000
    results = {
        "v1_ppo": {
            "seeds": {
                str(s): _run([1.0 + s * 0.2, 1.4], [1, 1 - (s == 2)], 30 + s) for s in (0, 1, 2)
            }
        },
        "v1_ddpg": {"seeds": {"0": _run([30.0, 40.0], [0, 0], 90), "1": {"error": "x"}}},
    }
    files = StudyFiles.under(tmp_path / "study")
    files.results.parent.mkdir(parents=True)
    files.results.write_text(json.dumps(results))
    for seed in (0, 1, 2):  # training curves in the archive, as progress.csv logs them
        log = files.archive / "v1_ppo" / f"s{seed}" / "logs" / "progress.csv"
        log.parent.mkdir(parents=True)
        rows = [f"{t},{-30 + t / 1e5 + seed}" for t in range(0, 1_250_001, 50_000)]
        log.write_text("time/total_timesteps,rollout/ep_rew_mean\n" + "\n".join(rows) + "\n")

    out = report.make_report(cells, files)
    page = files.page.read_text()
    prose = " ".join(page.split())  # the page's paragraphs, unwrapped
    stats = report.cell_stats(results, "v1_ppo")
    lo, hi = stats["distance_cm"]["iqm_ci"]
    assert lo < stats["distance_cm"]["iqm"] < hi
    ppo = _row(page, "v1_ppo")
    assert f"{stats['distance_cm']['iqm']:.2f} [{lo:.2f}, {hi:.2f}]" in ppo
    assert "| 3 of 5 |" in ppo and "s2: 1.40 / 50 %" in ppo and "| 7.74 |" in ppo
    assert "lower: the CI's upper end is below it" in ppo
    ddpg = _row(page, "v1_ddpg")
    assert "1 of 3" in ddpg and "one seed: no CI" in ddpg and "| 35.1 |" in ddpg
    trpo = _row(page, "v1_trpo")
    assert "0 of 3" in trpo and "| 11.9 |" in trpo
    assert "`v1_ddpg` trains 300,000 steps, not the paper's 1,250,000" in page
    assert "- `v1_ppo` seed 3: missing; ~" in page and "(at the study's rate)" in page
    assert "runs to its 100-step limit and is judged where the box ends" in prose
    assert "`drake_tooluse/ToolPush-v1`" in page and "tag `figures-v0`" in prose
    assert "`v1_ppo` at `7de66a6`" in page and "Not known for `v1_ddpg`" in prose
    # The costs: each run's wall time, and the CPU hours of the 2-core machine.
    assert "| v1_ppo | 3 | 1,251,328 | s0: 30, s1: 31, s2: 32 |" in page
    assert f"In all: 4 runs, {(93 + 90) / 60:.1f} h of wall time, {183 / 30:.1f} CPU hours" in prose
    assert out["figures"] == [str(files.figures / "training_curves.png")]
    assert "](figures/training_curves.png)" in page and "training_trajectories" not in page
    assert report.page_is_current(cells, files)


def test_only_the_list_of_runs_still_to_run_is_left_out_of_the_check():
    page = "# T\n\n| a | 1.00 |\n\n**Still to run**, …:\n\n- `x` seed 0: training now\n\n## Figures\n\nz\n"
    assert report.without_queue(page) == report.without_queue(
        page.replace("training now", "last archived checkpoint at 5")
    )
    assert report.without_queue(page) != report.without_queue(page.replace("1.00", "1.01"))
    assert report.without_queue(page) != report.without_queue(page.replace("z", "y"))


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


def test_the_commit_is_what_the_runs_record_else_what_the_job_knew():
    from drake_tooluse.experiments import paper_study_report as report

    def entry(code):
        return {report.EVALUATION: {}, "train": {"code": code} if code else {}}

    results = {
        "a": {"seeds": {"0": entry({"commit": "abcdef0123", "modified": False})}},
        "b": {"seeds": {"0": entry({"commit": "1234567890", "modified": True})}},
        "v1_ppo": {"seeds": {"0": entry(None)}},
        "c": {"seeds": {"0": entry(None)}},
    }
    text = " ".join(report._commit(results, dict.fromkeys(results)).split())
    assert "`a` at `abcdef0`" in text and "`b` at `1234567 +changes`" in text
    assert f"`v1_ppo` at `{report.TRAINED_AT['v1_ppo']}`" in text and "Not known for `c`" in text
