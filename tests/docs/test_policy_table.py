"""The user guide's table of the shipped policies (docs/guide/evaluation.md, the README's until
it moved there) quotes what their `metrics.json` holds (the evaluation
`tests/learning/test_shipped_policy.py` re-runs), so it cannot drift from them."""

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_shipped_policies_table_is_their_metrics():
    page = (ROOT / "docs" / "guide" / "evaluation.md").read_text()
    rows = re.findall(r"^\| `models/policies/(\w+)`.*\| ([0-9.]+) cm, ([0-9]+) % \|$", page, re.M)
    assert {name for name, *_ in rows} == {
        p.name for p in (ROOT / "models" / "policies").iterdir() if p.is_dir()
    }
    for name, cm, percent in rows:
        metrics = json.loads((ROOT / "models" / "policies" / name / "metrics.json").read_text())
        evaluation = metrics["evaluation"]
        assert (evaluation["episodes"], evaluation["seed"]) == (100, 1000)
        # The task's headline distance: the box's (push) or the cube's (pull) to the goal.
        final = next(v for k, v in evaluation.items() if re.fullmatch(r"final_\w+_mean_m", k))
        assert cm == f"{final * 100:.2f}", name
        assert int(percent) == round(evaluation["success_rate"] * 100), name
