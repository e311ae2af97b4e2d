"""A grid of training runs (algorithms × envs × seeds) on Ray: all local cores by default, or
an existing Ray cluster by `address`. Optional: the `cluster` extra (`pip install ".[cluster]"`).

Each run is a `train` + `evaluate` in its own Ray task, written to `OUT/<algo>_<env>_s<seed>/`;
the results table is written atomically to `OUT/sweep.json` and `OUT/sweep.md` at the end.
"""

from __future__ import annotations

import itertools
from dataclasses import asdict
from pathlib import Path

import torch

from drake_tooluse.files import atomic_write_json, atomic_write_text
from drake_tooluse.learning.config import check_algo, check_env_id, resolve_config
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.train import train


def _run_name(algo: str, env_id: str, seed: int) -> str:
    return f"{algo}_{env_id.split('/')[-1]}_s{seed}"


def _train_and_evaluate(
    algo: str,
    env_id: str,
    seed: int,
    timesteps: int,
    out: str,
    overrides: dict | None,
    episodes: int,
) -> dict:
    """One grid cell; runs inside a Ray worker process (single-threaded torch: the cell's env
    processes are its parallelism, as in `drake-tooluse train`)."""
    torch.set_num_threads(1)
    config = resolve_config(env_id, algo, timesteps, None, seed, overrides=overrides)
    run_dir = Path(out) / _run_name(algo, env_id, seed)
    summary = train(config, run_dir, progress_bar=False)
    result = asdict(evaluate(run_dir / "best", env_id, episodes, seed=1000))
    result.pop("per_episode")
    return {
        "algo": algo,
        "env": env_id,
        "seed": seed,
        "run": str(run_dir),
        **summary,
        "evaluation": result,
    }


def sweep(
    algos,
    envs,
    seeds,
    timesteps: int,
    out,
    *,
    address: str | None = None,
    num_cpus: int | None = None,
    overrides: dict | None = None,
    episodes: int = 20,
) -> list[dict]:
    """Trains and evaluates every (algo, env, seed) on Ray; returns one row per run."""
    try:
        import ray
    except ImportError:
        raise RuntimeError(
            "the sweep needs Ray: install the cluster extra (pip install '.[cluster]')"
        ) from None
    for a in algos:
        check_algo(a)
    for e in envs:
        check_env_id(e)
    grid = list(itertools.product(algos, envs, seeds))
    # Each task reserves as many CPUs as its run has env processes.
    cpus = {
        (a, e): resolve_config(e, a, timesteps, None, 0, overrides=overrides).n_envs
        for a, e, _ in grid
    }
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ray.init(
        address=address,
        num_cpus=num_cpus if address is None else None,
        include_dashboard=False,
        ignore_reinit_error=True,
        log_to_driver=False,
    )
    try:
        task = ray.remote(_train_and_evaluate)
        futures = [
            task.options(num_cpus=cpus[(a, e)]).remote(
                a, e, s, timesteps, str(out), overrides, episodes
            )
            for a, e, s in grid
        ]
        rows = ray.get(futures)
    finally:
        ray.shutdown()
    atomic_write_json(out / "sweep.json", rows)
    atomic_write_text(out / "sweep.md", results_table(rows))
    return rows


def results_table(rows: list[dict]) -> str:
    lines = [
        "| algo | env | seed | steps | wall (min) | final box–goal mean (cm) | success |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        e = r["evaluation"]
        lines.append(
            f"| {r['algo']} | {r['env']} | {r['seed']} | {r['timesteps']} | "
            f"{r['wall_time_s'] / 60:.1f} | {e['final_box_to_goal_mean_m'] * 100:.2f} | "
            f"{e['success_rate'] * 100:.0f} % |"
        )
    return "\n".join(lines) + "\n"
