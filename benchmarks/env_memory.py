"""Memory over a long run: random-action steps with resets; the process must not grow.

    python benchmarks/env_memory.py [--steps 200000] [--out FILE]

Prints the resident set size after a warm-up and at the end, and writes
docs/results/env_memory.json (or --out). Goal: growth <= 50 MB over 200,000 steps.
"""

import argparse
import platform
import time
from pathlib import Path

import gymnasium as gym

import drake_tooluse  # noqa: F401
from drake_tooluse.files import atomic_write_json

OUT = Path(__file__).resolve().parent.parent / "docs" / "results"


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    import os

    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--warmup", type=int, default=2000)
    ap.add_argument("--out", type=Path, help="JSON file (default docs/results/env_memory.json)")
    args = ap.parse_args()
    out = args.out or OUT / "env_memory.json"
    env = gym.make("drake_tooluse/ToolPush-v0")
    env.reset(seed=0)
    env.action_space.seed(0)
    resets = 0
    samples = []
    start = time.perf_counter()
    for i in range(args.warmup + args.steps):
        if i == args.warmup:
            base = rss_mb()
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
            resets += 1
        if i >= args.warmup and (i - args.warmup) % 20000 == 0:
            samples.append((i - args.warmup, rss_mb()))
    end = rss_mb()
    wall = time.perf_counter() - start
    print(
        f"{args.steps} steps, {resets} resets, {wall:.0f} s; "
        f"RSS {base:.1f} MB after {args.warmup} warm-up steps -> {end:.1f} MB "
        f"(growth {end - base:+.1f} MB)"
    )
    atomic_write_json(
        out,
        {
            "command": f"python benchmarks/env_memory.py --steps {args.steps}",
            "machine": platform.platform(),
            "steps": args.steps,
            "resets": resets,
            "rss_start_mb": base,
            "rss_end_mb": end,
            "growth_mb": end - base,
            "samples_steps_mb": samples,
            "wall_s": wall,
        },
    )


if __name__ == "__main__":
    main()
