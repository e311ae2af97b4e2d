"""docs/TRANSFER.md's table is what `benchmarks/transfer_experiments.py --report` prints from the
stored results, the stored results hold no machine's absolute paths, and the script writes
tracked files only when asked (`--update-docs`), with paths relative to the run."""

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.benchmark_scripts import benchmark_script
from tests.docs.common import strings

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "transfer_experiments.py"
STORED = ROOT / "docs" / "results" / "transfer"


def _script():
    return benchmark_script("transfer_experiments")


def test_the_transfer_page_quotes_the_table_the_report_prints():
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--report"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if line.startswith("| ")]
    assert len(rows) == 2 + 18  # header, rule, 3 policies x 3 modes x 2 tools
    page = (ROOT / "docs" / "TRANSFER.md").read_text()
    assert "\n".join(rows) in page


def test_the_stored_results_hold_no_absolute_paths():
    files = sorted(STORED.glob("*/transfer.json"))
    assert files
    for file in files:
        absolute = [s for s in strings(json.loads(file.read_text())) if os.path.isabs(s)]
        assert not absolute, (file, absolute[:3])


def test_update_docs_copies_a_run_with_paths_relative_to_it(tmp_path, monkeypatch):
    script = _script()
    docs = tmp_path / "docs_results"
    monkeypatch.setattr(script, "DOCS_RESULTS", docs)
    monkeypatch.setattr(script, "ROOT", tmp_path)
    run = tmp_path / "runs" / "x" / "tip_closed-loop"
    run.mkdir(parents=True)
    (run / "transfer_boxplot.png").write_bytes(b"png")
    result = {
        "json": str(run / "transfer.json"),
        "tools": [{"file": str(run / "trajectory-125mm.npz")}],
        "policy": str(tmp_path / "models" / "policies" / "p"),
        "elsewhere": "/nowhere/else.yaml",
        "runs": 10,
    }
    (run / "transfer.json").write_text(json.dumps(result))
    script.update_docs(run.parent, ["tip_closed-loop"])
    copied = json.loads((docs / "tip_closed-loop" / "transfer.json").read_text())
    assert copied == {
        "json": "transfer.json",
        "tools": [{"file": "trajectory-125mm.npz"}],
        "policy": "models/policies/p",
        "elsewhere": "/nowhere/else.yaml",  # outside the run and the repository: as it was
        "runs": 10,
    }
    assert (docs / "tip_closed-loop" / "transfer_boxplot.png").read_bytes() == b"png"
