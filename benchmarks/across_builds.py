"""How far a shipped policy's evaluation moves between two builds of its libraries: compares
two `drake-tooluse evaluate --json --per-episode` outputs of the same policy, seeds and episode
count (one of them may be the policy's metrics.json), episode by episode.

Prints how many episodes differ (by more than 1 µm), the largest difference, how many differ by
more than the default suite's per-episode tolerance, the shift of the mean and of the success
rate, and the successes that flipped. The tolerances of tests/learning/test_shipped_policy.py
were measured with it: the shipped metrics (Drake 1.51.1) against the same command run in
`.ci/py313_check.sh`'s venv (Python 3.13, the newest Drake).

    python benchmarks/across_builds.py models/policies/ppo_toolpull/metrics.json other.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from drake_tooluse.cli.common import run_script

SAME_M = 1e-6  # m: closer than this, two episodes are the same
EPISODE_TOLERANCE_M = 0.015  # the default suite's per-episode tolerance (m)


def load_evaluation(path: Path) -> dict:
    """The evaluation in `path`: evaluate's JSON, or a policy's metrics.json (its
    `evaluation`). A ValueError names a file that is neither."""
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: not a readable JSON file ({e})") from None
    data = data.get("evaluation", data) if isinstance(data, dict) else None
    if not isinstance(data, dict) or not isinstance(data.get("per_episode"), list):
        raise ValueError(f"{path}: no per-episode evaluation (evaluate --json --per-episode)")
    return data


def compare(a: dict, b: dict, key: str) -> dict:
    """The differences between evaluations `a` and `b` of the same seeds, on `key`."""
    ea, eb = a["per_episode"], b["per_episode"]
    if [e["seed"] for e in ea] != [e["seed"] for e in eb]:
        raise ValueError("the two evaluations ran different seeds")
    d = np.abs([x[key] - y[key] for x, y in zip(ea, eb)])
    return {
        "episodes": len(d),
        "differ": int((d > SAME_M).sum()),
        "max_m": float(d.max(initial=0.0)),
        "beyond_tolerance": int((d > EPISODE_TOLERANCE_M).sum()),
        "mean_shift_m": float(np.mean([x[key] for x in ea]) - np.mean([y[key] for y in eb])),
        "success_rate_shift": float(
            np.mean([x["success"] for x in ea]) - np.mean([y["success"] for y in eb])
        ),
        "flipped": [x["seed"] for x, y in zip(ea, eb) if x["success"] != y["success"]],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first", type=Path)
    parser.add_argument("second", type=Path)
    parser.add_argument("--key", default="final_object_to_goal_m", help="per-episode figure")
    args = parser.parse_args(argv)
    try:
        r = compare(load_evaluation(args.first), load_evaluation(args.second), args.key)
    except (ValueError, KeyError) as e:
        print(f"across_builds: {e}", file=sys.stderr)
        return 2
    print(
        f"{r['differ']} of {r['episodes']} episodes differ (largest {r['max_m'] * 1000:.2f} mm; "
        f"{r['beyond_tolerance']} beyond {EPISODE_TOLERANCE_M * 1000:.0f} mm); mean "
        f"{r['mean_shift_m'] * 1000:+.2f} mm, success rate {r['success_rate_shift'] * 100:+.0f} "
        f"points; flipped: {r['flipped'] or 'none'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
