"""A grid of training runs (algorithms × envs × seeds) on Ray: all local cores by default, or
an existing Ray cluster by `address`. Optional: the `cluster` extra (`pip install ".[cluster]"`).

Each run is a `train` + `evaluate` in its own Ray task, written to `OUT/<algo>_<env>_s<seed>/`;
the results table is written atomically to `OUT/sweep.json` and `OUT/sweep.md` at the end.

Every argument is checked before Ray starts (`check_sweep`): the algorithms, envs, seeds and
budgets, each cell's hyperparameters, that no cell's run directory already holds a run, and
that the CPUs Ray has can hold the largest cell (a task reserves one CPU per env process; Ray
would otherwise wait forever for a lease that never comes).
"""

from __future__ import annotations

import itertools
import os
from dataclasses import asdict
from pathlib import Path

import torch

from drake_tooluse.files import atomic_write_json, atomic_write_text, check_output_dir
from drake_tooluse.learning.config import check_algo, check_env_id, resolve_config
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.train import train
from drake_tooluse.validation import check_int, check_mapping, check_seed

EVALUATION_SEED = 1000
MAX_EPISODES = 100_000


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
    result = asdict(evaluate(run_dir / "best", env_id, episodes, seed=EVALUATION_SEED))
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
    grid, cpus = check_sweep(
        algos,
        envs,
        seeds,
        timesteps,
        out,
        address=address,
        num_cpus=num_cpus,
        overrides=overrides,
        episodes=episodes,
    )
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
        if address is not None:  # a cluster's CPUs are known once connected
            available = int(ray.cluster_resources().get("CPU", 0))
            _check_cpus(cpus, available, f"the Ray cluster at {address!r} has")
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


def _list(values, name: str) -> list:
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name}={values!r} must be a list")
    values = list(values)
    if not values:
        raise ValueError(f"{name} is empty; give at least one")
    repeated = sorted({repr(v) for v in values if values.count(v) > 1})
    if repeated:
        raise ValueError(f"{name} repeats {', '.join(repeated)}: each run needs its own")
    return values


def _check_cpus(cpus: dict, available: int, where: str) -> None:
    (algo, env), need = max(cpus.items(), key=lambda kv: kv[1])
    if need > available:
        raise ValueError(
            f"a {algo} run on {env} has {need} env processes and reserves {need} CPUs, but "
            f"{where} {available}: Ray would wait for them forever; give more CPUs "
            f"(--num-cpus) or fewer env processes (--hyperparams '{{\"n_envs\": {available}}}')"
        )


def check_sweep(
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
) -> tuple[list, dict]:
    """Checks every argument of `sweep` (see the module docstring) before anything runs;
    returns the grid and the CPUs each (algo, env) cell reserves."""
    algos = [check_algo(a) for a in _list(algos, "algos")]
    envs = [check_env_id(e) for e in _list(envs, "envs")]
    seeds = [check_seed(s, "seed") for s in _list(seeds, "seeds")]
    check_int(timesteps, 1, 10**10, "timesteps")
    check_int(episodes, 1, MAX_EPISODES, "episodes")
    check_mapping(overrides, "hyperparameter overrides")
    out = check_output_dir(out, "out", must_be_new=False)
    grid = list(itertools.product(algos, envs, seeds))
    cpus = {}
    for a, e, s in grid:
        config = resolve_config(e, a, timesteps, None, s, overrides=overrides)
        cpus[(a, e)] = config.n_envs  # a task reserves a CPU per env process
        run_dir = out / _run_name(a, e, s)
        if (run_dir / "config.json").exists():
            raise FileExistsError(
                f"{str(run_dir)!r} already holds a run; give the sweep a new directory"
            )
    if address is None:
        local = num_cpus if num_cpus is not None else (os.cpu_count() or 1)
        check_int(local, 1, 4096, "num_cpus")
        _check_cpus(cpus, local, "--num-cpus gives" if num_cpus is not None else "this machine has")
    return grid, cpus


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
