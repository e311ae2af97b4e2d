"""Memory over a long run and over env rebuilds; the process must not grow.

    python benchmarks/env_memory.py [--steps 200000] [--rebuilds 40] [--without-release]
        [--out FILE | --update-docs]

Two loops, each after a warm-up:

- steps: random-action steps with resets in one env (goal: growth <= 50 MB over 200,000);
- rebuilds: `gym.make` … reset, a step … `close()` cycles, as a sweep, a test suite or an
  evaluation loop rebuilds envs (goal: growth <= 10 MB over 40). pydrake 1.51 keeps a diagram
  with Python systems alive forever (`systems.lifetime`); `close()` releases it
  (`--without-release` measures pydrake's own behaviour: close() not releasing). Also
  reported, from a second pass under tracemalloc: the growth of Python's own allocations, and
  the drake_tooluse systems still alive (their attributes cleared: empty shells).

Prints the resident set sizes and writes them as JSON to a new
runs/env_memory-<time>/env_memory.json (or --out; `--update-docs`: docs/results/env_memory.json,
which docs/BENCHMARKS.md quotes).
"""

import argparse
import gc
import os
import platform
import sys
import time
import tracemalloc
from pathlib import Path

import gymnasium as gym
from pydrake.systems.framework import LeafSystem

import drake_tooluse  # noqa: F401
from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.files import atomic_write_json

OUTPUT = BenchmarkOutput(Path(__file__))


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def step_loop(steps: int, warmup: int) -> dict:
    env = gym.make("drake_tooluse/ToolPush-v1")
    env.reset(seed=0)
    env.action_space.seed(0)
    resets, samples = 0, []
    start = time.perf_counter()
    for i in range(warmup + steps):
        if i == warmup:
            base = rss_mb()
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
            resets += 1
        if i >= warmup and (i - warmup) % 20000 == 0:
            samples.append((i - warmup, rss_mb()))
    end = rss_mb()
    env.close()
    return {
        "steps": steps,
        "resets": resets,
        "rss_start_mb": base,
        "rss_end_mb": end,
        "growth_mb": end - base,
        "samples_steps_mb": samples,
        "wall_s": time.perf_counter() - start,
    }


def _cycle() -> None:
    env = gym.make("drake_tooluse/ToolPush-v1")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()


def _live_python_systems() -> int:
    return sum(
        isinstance(o, LeafSystem) and type(o).__module__.startswith("drake_tooluse")
        for o in gc.get_objects()
    )


def rebuild_loop(rebuilds: int, warmup: int = 3) -> dict:
    for _ in range(warmup):
        _cycle()
    gc.collect()
    base, systems = rss_mb(), _live_python_systems()
    start = time.perf_counter()
    samples = []
    for i in range(rebuilds):
        _cycle()
        if (i + 1) % 10 == 0:
            gc.collect()
            samples.append((i + 1, rss_mb()))
    gc.collect()
    end = rss_mb()
    wall = time.perf_counter() - start
    systems = _live_python_systems() - systems
    # Python's own share, on a second pass (tracemalloc's bookkeeping would count in the RSS).
    tracemalloc.start()
    python_base = tracemalloc.get_traced_memory()[0]
    for _ in range(10):
        _cycle()
    gc.collect()
    python_growth = (tracemalloc.get_traced_memory()[0] - python_base) / 2**20
    tracemalloc.stop()
    return {
        "rebuilds": rebuilds,
        "rss_start_mb": base,
        "rss_end_mb": end,
        "growth_mb": end - base,
        "growth_per_rebuild_mb": (end - base) / rebuilds,
        "python_allocations_growth_per_10_mb": python_growth,
        "python_systems_left": systems,
        "samples_rebuilds_mb": samples,
        "wall_s": wall,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--warmup", type=int, default=2000)
    ap.add_argument("--rebuilds", type=int, default=40)
    ap.add_argument(
        "--without-release", action="store_true", help="close() does not release the diagram"
    )
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    out = OUTPUT.path(args)
    if args.without_release:
        import drake_tooluse.tasks.push.env as push_env

        push_env.release_diagram = lambda diagram: None
    rebuilds = rebuild_loop(args.rebuilds)
    print(
        f"{args.rebuilds} rebuilds: RSS {rebuilds['rss_start_mb']:.1f} -> "
        f"{rebuilds['rss_end_mb']:.1f} MB (growth {rebuilds['growth_mb']:+.1f} MB, goal <= 10; "
        f"Python allocations {rebuilds['python_allocations_growth_per_10_mb']:+.2f} MB per 10; "
        f"{rebuilds['python_systems_left']} emptied Python systems left), "
        f"{rebuilds['wall_s']:.0f} s"
    )
    steps = step_loop(args.steps, args.warmup) if args.steps > 0 else None
    if steps is not None:
        print(
            f"{args.steps} steps, {steps['resets']} resets, {steps['wall_s']:.0f} s; RSS "
            f"{steps['rss_start_mb']:.1f} MB after {args.warmup} warm-up steps -> "
            f"{steps['rss_end_mb']:.1f} MB (growth {steps['growth_mb']:+.1f} MB, goal <= 50)"
        )
    atomic_write_json(
        out,
        {
            "command": (
                f"python benchmarks/env_memory.py --steps {args.steps} --rebuilds {args.rebuilds}"
                + (" --without-release" if args.without_release else "")
            ),
            "release": not args.without_release,
            "machine": platform.platform(),
            "step_loop": steps,
            "rebuild_loop": rebuilds,
        },
    )


if __name__ == "__main__":
    sys.exit(run_script(main))
