"""Copies a trained run's best (or final) policy, or a policy directory `drake-tooluse
distill` wrote, into models/policies/NAME with its metrics and the exact commands that made
and evaluated it.

    python benchmarks/ship_policy.py --run runs/paper/ppo_env1_fullik --name ppo_toolpush
        [--out DIR]    # default models/policies/NAME
        [--which final]    # the run's final policy (default its best)
    python benchmarks/ship_policy.py --policy runs/student --name ppo_toolpush

The metrics are re-measured here with `drake-tooluse evaluate` on the copied policy, so the
shipped metrics.json is what that command prints for the shipped files.
"""

import argparse
import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from drake_tooluse import compat
from drake_tooluse.cli.common import run_script
from drake_tooluse.files import atomic_write_json
from drake_tooluse.learning.jobs import this_interpreter
from drake_tooluse.learning.task_envs import episode_metrics

ROOT = Path(__file__).resolve().parent.parent


def command_chain(meta: dict) -> list[str]:
    """The commands that made a policy, first to last: its own, after those of the policy it
    went on from (`--init-from DIR`, as long as DIR still holds a policy.json; all of them
    where DIR is a shipped policy, its metrics.json's `made_with`)."""
    chain = [meta["command"]]
    seen = set()
    while True:
        words = shlex.split(chain[0])
        if "--init-from" not in words:
            return chain
        earlier = Path(words[words.index("--init-from") + 1])
        if earlier in seen or not (earlier / "policy.json").is_file():
            return chain
        seen.add(earlier)
        shipped = earlier / "metrics.json"  # a shipped policy's whole chain
        made_with = json.loads(shipped.read_text()).get("made_with") if shipped.is_file() else None
        if made_with:
            return list(made_with) + chain
        chain.insert(0, json.loads((earlier / "policy.json").read_text())["command"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    given = ap.add_mutually_exclusive_group(required=True)
    given.add_argument("--run", type=Path, help="a training run directory")
    given.add_argument(
        "--policy", type=Path, help="a policy directory made otherwise (drake-tooluse distill)"
    )
    ap.add_argument("--name", required=True, help="directory name under models/policies")
    ap.add_argument(
        "--which",
        choices=("best", "final"),
        default="best",
        help="the run's best policy (by its periodic evaluation) or its final one",
    )
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument(
        "--out", type=Path, help="the policy directory to write (default models/policies/NAME)"
    )
    args = ap.parse_args()
    if args.policy is not None:
        source, wall_time = args.policy, None
        if not (source / "policy.json").is_file():
            ap.error(f"--policy {source}: not a policy directory (no policy.json)")
    else:
        source = args.run / args.which
        if not (source / "policy.json").is_file():
            ap.error(
                f"--run {args.run}: no {args.which} policy in it ({source} has no policy.json)"
            )
        if not (args.run / "summary.json").is_file():
            ap.error(f"--run {args.run}: the run has not finished (no summary.json)")
        wall_time = json.loads((args.run / "summary.json").read_text())["wall_time_s"]
    target = (args.out or ROOT / "models" / "policies" / args.name).resolve()
    # As the command is recorded: relative to the repository (its cwd) where it lies in it.
    shown = target.relative_to(ROOT) if target.is_relative_to(ROOT) else target
    tmp = target.with_name(f".{target.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(source, tmp)
    meta = json.loads((tmp / "policy.json").read_text())
    # Before the target is replaced: the policy it went on from may be the one shipped there.
    made_with = command_chain(meta)
    evaluate = [
        "drake-tooluse",
        "evaluate",
        "--policy",
        str(shown),
        "--episodes",
        str(args.episodes),
        "--seed",
        str(args.seed),
        "--json",
        "--per-episode",
    ]
    if target.exists():
        shutil.rmtree(target)
    tmp.rename(target)
    metrics = json.loads(
        subprocess.run(
            this_interpreter(evaluate),
            capture_output=True,
            text=True,
            check=True,
            cwd=ROOT,
        ).stdout
    )
    atomic_write_json(
        target / "metrics.json",
        {
            "trained_with": meta["command"],  # as run (cwd: the repository)
            # Where it went on from an earlier policy: the commands that made that one first.
            "made_with": made_with,
            "trained_timesteps": meta["trained_timesteps"],
            "training_wall_time_s": wall_time,  # None: not a training run's
            "evaluated_with": " ".join(evaluate),
            # Reproduced exactly on this release only (tests/learning/test_shipped_policy.py).
            "evaluated_with_drake": compat.DRAKE_VERSION,
            "evaluation": metrics,
        },
    )
    # The task's headline figure's mean (final_object_to_goal_mean_m, final_object_to_goal_…).
    mean_key = next(iter(episode_metrics(meta["env_id"])[0].summary([0.0])))
    print(
        f"shipped {source} -> {target}: {mean_key} "
        f"{metrics[mean_key] * 100:.2f} cm, success {metrics['success_rate'] * 100:.0f} %"
    )


if __name__ == "__main__":
    sys.exit(run_script(main))
