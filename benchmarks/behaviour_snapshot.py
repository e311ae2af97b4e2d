"""Behaviour snapshot: replay two commits side by side: behaviour must stay bit-identical across a
refactor.

`capture` runs a fixed set of `drake-tooluse ... --json` commands in one checkout (only the
command line, never an import of the package, so it runs unchanged on the old and the refactored
layout) and writes their results to one JSON file; `compare` checks two such files figure by
figure, exactly (per-episode values included), and exits 1 if anything differs.

    python benchmarks/behaviour_snapshot.py capture --out FILE.json [--repo DIR] [--quick]
    python benchmarks/behaviour_snapshot.py compare A.json B.json [--allow-added]

Each command runs with cwd = --repo (default: this file's checkout) and the `drake-tooluse` next
to --python (default: this interpreter), one BLAS/OpenMP thread. Left out of the comparison: wall
clock times (keys with "time" ending in `_s` other than `sim_time_s`, and `times`), which differ
run to run. Absolute paths are written as <repo> and <out>. A full capture takes ~2.5 min on 2
cores; two captures of one commit are identical. With `--allow-added`, figures only B has (outputs
a change added, e.g. new `info` figures) are listed apart and not counted as differing; every
figure A has must still be in B with the same value.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

POLICIES = ("ppo_toolpush", "ppo_toolpush_tip", "ppo_toolpush_paper_action")
TOOL = ["--tool-length", "0.175"]
DOWN = ["--rpy", "3.14159", "0", "1.5708"]
IK_POSES = {  # the README's pose, three more, one warm-started, one out of reach (exit 3)
    "readme": [*TOOL, "--position", "0.65", "-0.25", "-0.10", *DOWN],
    "near": [*TOOL, "--position", "0.55", "-0.35", "-0.05", *DOWN],
    "far": [*TOOL, "--position", "0.80", "-0.10", "-0.12", *DOWN],
    "tilted": ["--tool-length", "0.125", "--position", "0.70", "-0.30", "-0.08"]
    + ["--rpy", "2.8", "0.2", "1.4"],
    "quaternion_seeded": [*TOOL, "--position", "0.60", "-0.20", "0.0"]
    + ["--quaternion", "0", "0.70710678", "0.70710678", "0"]
    + ["--seed-q", "0.7", "-1.1", "0", "1.8", "0", "0.9", "1.5"],
    "no_tool": ["--no-tool", "--position", "0.65", "-0.25", "0.05", *DOWN],
    "unreachable": [*TOOL, "--position", "1.6", "0", "0.3", *DOWN],
}
FK_QS = {
    "readme": [*TOOL, "--q", "0.7", "-1.1", "0", "1.8", "0", "0.9", "1.5"],
    "zero_short": ["--tool-length", "0.125", "--q", "0", "0", "0", "0", "0", "0", "0"],
    "bent_no_tool": ["--no-tool", "--q", "-0.4", "-0.6", "0.5", "1.2", "-0.8", "1.1", "-2.0"],
}


def is_wall_time(key: str) -> bool:
    """A key holding seconds of wall clock (differs run to run), not simulated time."""
    return key == "times" or ("time" in key and key.endswith("_s") and key != "sim_time_s")


def clean(value, subs: dict[str, str]):
    """`value` without wall-clock times, with the machine's absolute paths made symbolic."""
    if isinstance(value, dict):
        return {k: clean(v, subs) for k, v in value.items() if not is_wall_time(k)}
    if isinstance(value, list):
        return [clean(v, subs) for v in value]
    if isinstance(value, str):
        for path, name in subs.items():
            value = value.replace(path, name)
    return value


def npz_arrays(directory: Path) -> dict:
    """The arrays of every .npz file in `directory` as lists (the zip's own bytes hold dates)."""
    out = {}
    for path in sorted(directory.glob("*.npz")):
        with np.load(path, allow_pickle=False) as z:
            out[path.name] = {k: z[k].tolist() for k in sorted(z.files)}
    return out


def commands(quick: bool, tmp: Path) -> dict[str, tuple[list[str], Path | None]]:
    """Name -> (the drake-tooluse arguments, the file it writes whose JSON is captured, if any)."""
    episodes, limit_episodes = (10, 10) if quick else (100, 20)
    cmds = {}
    for name in POLICIES:
        ev = ["evaluate", "--policy", f"models/policies/{name}", "--seed", "1000", "--json"]
        ev += ["--per-episode", "--no-progress"]
        cmds[f"evaluate/{name}"] = ([*ev, "--episodes", str(episodes)], None)
        cmds[f"evaluate_to_time_limit/{name}"] = (
            [*ev, "--episodes", str(limit_episodes), "--to-time-limit"],
            None,
        )
    runs = ["--runs", "1" if quick else "5"]
    cmds["transfer/closed-loop"] = (
        ["transfer", "--mode", "closed-loop", *runs, "--seed", "0", "--out", str(tmp / "tcl")],
        tmp / "tcl" / "transfer.json",
    )
    runs = ["--runs", "1" if quick else "3"]
    cmds["transfer/open-loop"] = (
        ["transfer", "--mode", "open-loop", *runs, "--seed", "0", "--episodes", "20"]
        + ["--calibration-draws", "4", "--out", str(tmp / "tol")],
        tmp / "tol" / "transfer.json",
    )
    for name, args in IK_POSES.items():
        cmds[f"ik/{name}"] = (["ik", *args], None)
    cmds["ik/measured"] = (["ik", "--measure", *IK_POSES["readme"]], None)
    for name, args in FK_QS.items():
        cmds[f"fk/{name}"] = (["fk", *args], None)
    cmds["demo"] = (
        ["demo", "--no-progress", "--out", str(tmp / "demo")],
        tmp / "demo" / "metrics.json",
    )
    cmds["measure/push"] = (["measure"], None)
    cmds["measure/reality_pixel"] = (
        ["measure", "--scenario", "diagrams/reality.yaml", "--method", "pixel"]
        + ["--tool-length", "0.125"],
        None,
    )
    cmds["measure_box/push"] = (["measure-box"], None)
    for args, _ in cmds.values():
        if "--json" not in args:
            args.append("--json")
    return cmds


def capture(args) -> int:
    repo = args.repo.resolve()
    exe = str(Path(args.python).parent / "drake-tooluse")
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}
    git = ["git", "-C", str(repo)]
    meta = {
        "commit": subprocess.run(
            [*git, "rev-parse", "HEAD"], capture_output=True, text=True
        ).stdout.strip(),
        "dirty": bool(subprocess.run([*git, "status", "--porcelain"], capture_output=True).stdout),
        "repo": str(repo),
        "quick": args.quick,
        "commands": {},
        "wall_s": {},
    }
    results, start = {}, time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix="snapshot-"))
    subs = {str(tmp): "<out>", str(repo): "<repo>"}
    try:
        for name, (cmd, written) in commands(args.quick, tmp).items():
            argv = [exe, *cmd]
            meta["commands"][name] = shlex.join(argv)
            t0 = time.perf_counter()
            proc = subprocess.run(argv, cwd=repo, env=env, capture_output=True, text=True)
            meta["wall_s"][name] = round(time.perf_counter() - t0, 1)
            print(f"{name}: exit {proc.returncode}, {meta['wall_s'][name]} s", file=sys.stderr)
            if proc.returncode not in (0, 3):  # 3: ik's "not reached", a result
                sys.exit(f"{shlex.join(argv)} failed:\n{proc.stderr[-2000:]}")
            out = json.loads(written.read_text() if written else proc.stdout)
            if written is not None:
                out["npz"] = npz_arrays(written.parent)
            results[name] = {"exit_code": proc.returncode, **clean(out, subs)}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    meta["total_wall_s"] = round(time.perf_counter() - start, 1)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    part = args.out.with_name(args.out.name + ".tmp")
    part.write_text(json.dumps({"meta": meta, "results": results}, indent=1) + "\n")
    os.replace(part, args.out)
    print(f"{args.out}: {len(results)} commands in {meta['total_wall_s']:.0f} s", file=sys.stderr)
    return 0


def leaves(value, path: str = ""):
    """(path, leaf) of a JSON value; list indices are `[i]`."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from leaves(v, f"{path}/{k}" if path else k)
    elif isinstance(value, list) and value:
        for i, v in enumerate(value):
            yield from leaves(v, f"{path}[{i}]")
    else:
        yield path, value


def number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def compare(args) -> int:
    a, b = (json.loads(Path(p).read_text()) for p in (args.a, args.b))
    for side, snap in (("A", a), ("B", b)):
        m = snap["meta"]
        print(f"{side}: {m['commit'][:10]}{' (dirty)' if m['dirty'] else ''} {m['repo']}")
    if a["meta"]["quick"] != b["meta"]["quick"]:
        print("warning: one snapshot is --quick, the other not")
    la, lb = dict(leaves(a["results"])), dict(leaves(b["results"]))
    added = [p for p in lb if p not in la] if args.allow_added else []
    rows, bad = {}, []  # figure (list indices as [*]) -> [count, differing, max |a - b|]
    for path in [*la, *(p for p in lb if p not in la and p not in added)]:
        row = rows.setdefault(re.sub(r"\[\d+\]", "[*]", path), [0, 0, 0.0])
        row[0] += 1
        x, y = la.get(path, "<absent>"), lb.get(path, "<absent>")
        if type(x) is type(y) and x == y:
            continue
        row[1] += 1
        bad.append(f"  {path}: {x!r} != {y!r}")
        if number(x) and number(y):
            row[2] = max(row[2], abs(x - y))
        else:
            row[2] = float("nan")
    width = max(len(k) for k in rows)
    print(f"{'figure':<{width}}  {'n':>5}  {'status':<10} max |A-B|")
    for fig, (n, diff, worst) in rows.items():
        status = f"DIFFERS {diff}" if diff else "equal"
        shown = "" if not diff else "not numbers" if worst != worst else f"{worst:.3g}"
        print(f"{fig:<{width}}  {n:>5}  {status:<10} {shown}")
    total = sum(r[0] for r in rows.values())
    print(
        f"\n{len(bad)} of {total} values differ in {sum(1 for r in rows.values() if r[1])} figures"
    )
    print("\n".join(bad[:40]) + ("\n  ..." if len(bad) > 40 else ""))
    if added:
        figures = sorted({re.sub(r"\[\d+\]", "[*]", p) for p in added})
        print(f"\n{len(added)} values only in B (added), in {len(figures)} figures:")
        print("\n".join(f"  {f}" for f in figures))
    return 1 if bad else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("capture", help="run the commands in one checkout, write a snapshot")
    p.add_argument("--out", type=Path, required=True, help="snapshot JSON to write")
    p.add_argument("--repo", type=Path, default=Path(__file__).resolve().parent.parent)
    p.add_argument("--python", default=sys.executable, help="its venv's drake-tooluse is used")
    p.add_argument("--quick", action="store_true", help="10 episodes, 1 transfer run: a smoke test")
    p.set_defaults(run=capture)
    p = sub.add_parser("compare", help="compare two snapshots exactly (exit 1 if any differs)")
    p.add_argument("a", type=Path)
    p.add_argument("b", type=Path)
    p.add_argument(
        "--allow-added", action="store_true", help="figures only B has are listed, not differing"
    )
    p.set_defaults(run=compare)
    args = parser.parse_args()
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
