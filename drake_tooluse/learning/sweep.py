"""A grid of training runs (algorithms × envs × seeds) on Ray Tune: all local cores by default,
or an existing Ray cluster by `address`. Optional: the `cluster` extra (`pip install ".[cluster]"`).

Each cell is a Tune trial (`train` + `evaluate`, reserving one CPU per env process) that can run
on any node. Everything lands on the driver's disk, under `OUT`:

```
OUT/sweep_config.json        the grid and its settings (what `resume` reads back)
OUT/runs/<algo>_<env>_s<seed>/   each cell's run directory (`learning.train`'s layout) and
                             cell.json (its row of the table) once it has finished
OUT/sweep.json, sweep.md     the table: every cell finished, failed (with its error) or pending,
                             rewritten as each cell finishes or fails
OUT/tune-<time>/             Tune's own logs of each session
```

**Any node.** A cell trains in a scratch directory on its node and sends the run directory to a
store actor on the driver's node after every checkpoint and when it ends; the store swaps it in
atomically (`files.atomic_dir`). No shared file system is needed.

**Failures.** Tune retries a cell whose trial failed (a lost node, a crash) up to `max_failures`
times, on any node, from its last checkpoint on the driver's disk; a cell that still fails is a
`failed` row with its error, and the other cells go on. A cell the library refuses (a
`ValueError`: hyperparameters the algorithm rejects, a checkpoint it cannot read) is not
retried — a retry starts from the same settings and the same checkpoint on the driver's disk,
and would be refused again: it ends at once as a `failed` row with the refusal.

**Resume.** `sweep(resume=True)` (`drake-tooluse sweep --resume OUT`) reads
`sweep_config.json`, keeps every finished cell and runs the others again, each continuing from its
last checkpoint (`train(resume=True)`). It reads only JSON and the pickle-free checkpoints, never
Tune's pickled experiment state. A cell whose run the (edited) configuration no longer matches
is refused before Ray starts, naming the settings that differ.

**Interrupts.** Ctrl-C stops the sweep at once (Tune's own handler, which would end the
fit as if it were done, is off): the table lists the cells that had started as `interrupted`
(each resumes from its last checkpoint), the others as `pending`, and the sweep raises
KeyboardInterrupt, which the command line reports (exit 130) with the command that resumes it.

Every argument is checked before Ray starts (`check_sweep`, in time linear in the grid's cells,
at most `MAX_CELLS`), and the CPUs Ray sees before Tune starts: a cell's env processes must fit
on one node (else Ray would wait for the lease forever). One sweep process at a time holds `OUT` (`files.run_lock`). The driver must run on a
node of the cluster (Ray Client `ray://` addresses are refused): that node's disk holds `OUT`.
A cell is retried on any failure, a deterministic one included (Tune cannot tell them apart).
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses as dc
import io
import itertools
import logging
import os
import re
import shutil
import socket
import tarfile
import tempfile
import time
from pathlib import Path

import torch

from drake_tooluse.files import (
    atomic_dir,
    atomic_write_json,
    atomic_write_text,
    check_output_dir,
    read_json,
    recover_dir,
    run_lock,
)
from drake_tooluse.learning.config import (
    check_algo,
    config_differences,
    read_run_config,
    resolve_config,
)
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.learning.task_envs import check_env_id
from drake_tooluse.learning.train import train
from drake_tooluse.limits import MAX_CELLS, MAX_CPUS, MAX_EPISODES, MAX_FAILURES, MAX_TIMESTEPS
from drake_tooluse.validation import (
    EnvironmentProblem,
    check_int,
    check_mapping,
    check_seed,
    clipped,
    shown,
)

EVALUATION_SEED = 1000
CONFIG_FILE = "sweep_config.json"
CELL_FILE = "cell.json"  # in a cell's run directory once it has finished
REFUSED = "refused"  # the metric a refused cell reports to Tune instead of its evaluation
# The addresses `ray.init` joins a cluster by: 'auto', 'local', or HOST:PORT (IPv6 in brackets).
RAY_ADDRESS = re.compile(r"auto|local|([\w.-]+|\[[0-9A-Fa-f:.]+\]):\d{1,5}")


def _run_name(algo: str, env_id: str, seed: int) -> str:
    return f"{algo}_{env_id.split('/')[-1]}_s{seed}"


def _pack(directory: Path) -> bytes:
    """A run directory as an uncompressed tar (its lock file left out)."""
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w") as tar:
        for path in sorted(directory.rglob("*")):
            if path.name != ".lock":
                tar.add(path, arcname=str(path.relative_to(directory)), recursive=False)
    return buffer.getvalue()


def _unpack(data: bytes, directory: Path) -> None:
    with tarfile.open(fileobj=io.BytesIO(data), mode="r") as tar:
        tar.extractall(directory, filter="data")  # no links out, no absolute paths


class RunStore:
    """The cells' run directories on the driver's disk (a Ray actor placed on the driver's
    node): a cell on any node gets its run back to resume it and puts it after each
    checkpoint; each put replaces the whole directory atomically."""

    def __init__(self, runs_dir: str):
        self.runs_dir = Path(runs_dir)

    def get(self, name: str) -> bytes | None:
        run = self.runs_dir / name
        recover_dir(run)
        return _pack(run) if (run / "config.json").is_file() else None

    def put(self, name: str, data: bytes) -> None:
        with atomic_dir(self.runs_dir / name, replace=True) as tmp:
            _unpack(data, tmp)


SCRATCH_PREFIX = "drake_tooluse_cell_"


def _scratch_owner() -> str:
    """This process's part of a scratch directory's name: host and pid (a /tmp may be shared
    by hosts or pid namespaces; only this host's names are judged)."""
    return f"{socket.gethostname()}_pid{os.getpid()}_"


def scratch_dir() -> Path:
    """A new scratch directory for a cell on this node, named by its host and pid. This host's
    ones of processes that are gone (a SIGKILLed sweep never ran its clean-up; a DDPG run's
    replay buffer is hundreds of MB) are removed first."""
    tmp = Path(tempfile.gettempdir())
    host = f"{SCRATCH_PREFIX}{socket.gethostname()}_pid"
    for old in tmp.glob(f"{SCRATCH_PREFIX}*"):
        pid = old.name[len(host) :].split("_", 1)[0] if old.name.startswith(host) else ""
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(old, ignore_errors=True)
    return Path(tempfile.mkdtemp(prefix=SCRATCH_PREFIX + _scratch_owner()))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _cell(config: dict, store) -> None:
    """One grid cell: a Tune trial on any node. Trains in a scratch directory, continuing the
    driver's copy of the run if there is one, sends the run to the store after each checkpoint
    and at the end (with its row, `cell.json`), and reports the evaluation to Tune."""
    import ray
    from ray import tune

    spec = config["cell"]
    torch.set_num_threads(1)  # the cell's env processes are its parallelism
    algo, env_id, seed = spec["algo"], spec["env"], spec["seed"]
    name = _run_name(algo, env_id, seed)
    node_id = ray.get_runtime_context().get_node_id()
    # What continues the cell, and (a comment in the run's history) where this session ran.
    command = f"{spec['command']}  # cell {name} on node {node_id}"
    config = resolve_config(
        env_id, algo, spec["timesteps"], None, seed, overrides=spec["overrides"]
    )
    scratch = scratch_dir()
    refused = None
    try:
        run_dir = scratch / name
        saved = ray.get(store.get.remote(name))
        if saved is not None:
            run_dir.mkdir()
            _unpack(saved, run_dir)

        def send(directory: Path) -> None:
            ray.get(store.put.remote(name, _pack(directory)))

        summary = train(
            config,
            run_dir,
            resume=saved is not None,
            progress_bar=False,
            command=command,
            on_checkpoint=send,
        )
        evaluation = evaluate(run_dir / "best", env_id, spec["episodes"], seed=EVALUATION_SEED)
        # The task's first metric is the headline (the push task: the final box–goal mean).
        headline = next(iter(evaluation.metrics))
        result = evaluation.as_dict()
        result.pop("per_episode")
        summary.pop("out")
        row = {
            "algo": algo,
            "env": env_id,
            "seed": seed,
            "status": "finished",
            "run": f"runs/{name}",
            "node": socket.gethostname(),
            "node_id": node_id,
            **summary,
            "headline": headline,
            "evaluation": result,
        }
        atomic_write_json(run_dir / CELL_FILE, row)
        send(run_dir)
    except ValueError as e:  # deterministic: reported as the cell's end, so Tune retries nothing
        refused = _one_line(f"{type(e).__name__}: {e}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    if refused is not None:
        tune.report({REFUSED: refused})
        return
    tune.report(
        {
            headline: result[headline],
            "success_rate": result["success_rate"],
        }
    )


def _refusal(metrics) -> str | None:
    """The refusal a cell reported instead of its evaluation (see `_cell`), if any."""
    return (metrics or {}).get(REFUSED)


def _table_writer(out: Path, grid: list, errors: dict):
    """A Tune callback on the driver: the table rewritten from the disk whenever a cell
    finishes or fails."""
    from ray import tune

    class TableWriter(tune.Callback):
        def on_trial_complete(self, iteration, trials, trial, **info):
            if _refusal(trial.last_result):
                errors[_cell_name(trial.config)] = _refusal(trial.last_result)
            write_table(out, grid, errors)

        def on_trial_error(self, iteration, trials, trial, **info):
            error = trial.get_error()  # (or not yet written: `sweep` reads it after the fit)
            errors[_cell_name(trial.config)] = _one_line(error) if error else "failed"
            write_table(out, grid, errors)

    return TableWriter()


def _cell_name(config: dict) -> str:
    spec = config["cell"]
    return _run_name(spec["algo"], spec["env"], spec["seed"])


@contextlib.contextmanager
def _quiet_tune():
    """While the sweep runs: no console tables from Tune (the table is ours), none of its
    tracebacks (each failed cell is one line in the table) and not its SIGINT handler; all
    restored after."""
    tune_logger = logging.getLogger("ray.tune")
    level = tune_logger.level
    # No Tune SIGINT handler: Ctrl-C is a KeyboardInterrupt here, not a fit that looks done.
    settings = {"RAY_AIR_NEW_OUTPUT": "0", "TUNE_DISABLE_SIGINT_HANDLER": "1"}
    saved = {name: os.environ.get(name) for name in settings}
    os.environ.update(settings)
    tune_logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        tune_logger.setLevel(level)
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _one_line(error) -> str:
    """The last line of a trial's error (Ray's carry the remote traceback above it)."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    return lines[-1] if lines else type(error).__name__


def sweep(
    algos=None,
    envs=None,
    seeds=None,
    timesteps: int | None = None,
    out=None,
    *,
    address: str | None = None,
    num_cpus: int | None = None,
    overrides: dict | None = None,
    episodes: int = 20,
    max_failures: int = 2,
    resume: bool = False,
) -> list[dict]:
    """Trains and evaluates every (algo, env, seed) as a Ray Tune trial; returns the table's
    rows (one per cell: finished or failed). With `resume`, the grid and its settings are read
    from `out` (only `address`, `num_cpus` and `max_failures` may be given again)."""
    try:
        import ray
        from ray import tune
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy
    except ImportError:
        raise EnvironmentProblem(
            "the sweep needs Ray Tune: install the cluster extra (pip install '.[cluster]')"
        ) from None
    if resume:
        settings = read_sweep_config(out)
    else:
        settings = {
            "algos": algos if algos is not None else ["ppo"],
            "envs": envs if envs is not None else ["drake_tooluse/ToolPush-v1"],
            "seeds": seeds if seeds is not None else [0],
            "timesteps": timesteps if timesteps is not None else 300_000,
            "overrides": overrides,
            "episodes": episodes,
        }
    check_int(max_failures, 0, MAX_FAILURES, "max_failures")
    grid, cpus = check_sweep(**settings, out=out, address=address, num_cpus=num_cpus, resume=resume)
    if ray.is_initialized():
        raise EnvironmentProblem(
            "Ray is already initialized in this process; the sweep connects and disconnects on "
            "its own: call it before ray.init() or after ray.shutdown()"
        )
    out = Path(out).absolute()
    runs_dir = out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    with run_lock(out), contextlib.ExitStack() as stack:  # one sweep process per directory
        for cell in grid:
            recover_dir(runs_dir / _run_name(*cell))  # a replace a crash cut in two
        todo = [c for c in grid if not (runs_dir / _run_name(*c) / CELL_FILE).is_file()]
        errors: dict = {}
        if not todo:
            write_table(out, grid, errors)
            return _rows(out, grid, errors)
        stack.enter_context(_quiet_tune())
        ray.init(
            address=address,
            num_cpus=num_cpus if address is None else None,
            include_dashboard=False,
            log_to_driver=False,
            logging_level=logging.WARNING,
        )
        stack.callback(ray.shutdown)
        # The CPUs Ray sees (a container's limit, a cluster's nodes): a cell fits on one node.
        per_node = [n["Resources"].get("CPU", 0) for n in ray.nodes() if n["Alive"]]
        where = f"the largest node at {address!r} has" if address else "the local Ray has"
        _check_cpus(cpus, int(max(per_node, default=0)), where)
        if not resume:
            atomic_write_json(out / CONFIG_FILE, settings)
        write_table(out, grid, errors)
        here = ray.get_runtime_context().get_node_id()
        store = (
            ray.remote(RunStore)
            .options(
                num_cpus=0,
                scheduling_strategy=NodeAffinitySchedulingStrategy(node_id=here, soft=False),
            )
            .remote(str(runs_dir))
        )
        command = "drake-tooluse sweep --resume " + str(out)
        cells = [
            {
                "algo": a,
                "env": e,
                "seed": s,
                "timesteps": settings["timesteps"],
                "overrides": settings["overrides"],
                "episodes": settings["episodes"],
                "command": command,
            }
            for a, e, s in todo
        ]
        trainable = tune.with_resources(
            tune.with_parameters(_cell, store=store),
            lambda config: {"cpu": cpus[(config["cell"]["algo"], config["cell"]["env"])]},
        )
        tuner = tune.Tuner(
            trainable,
            param_space={"cell": tune.grid_search(cells)},
            run_config=tune.RunConfig(
                name=time.strftime("tune-%Y%m%d-%H%M%S"),
                storage_path=str(out),
                verbose=0,
                failure_config=tune.FailureConfig(max_failures=max_failures),
                callbacks=[_table_writer(out, grid, errors)],
            ),
        )
        try:
            results = tuner.fit()
        except KeyboardInterrupt:
            write_table(out, grid, errors, interrupted=True)
            raise KeyboardInterrupt(
                f"the sweep in {str(out)!r} stopped; its finished cells are kept, and "
                f"`{command}` continues the others from their last checkpoints"
            ) from None
        for result in results:
            if result.error is not None:
                errors[_cell_name(result.config)] = _one_line(result.error)
            elif _refusal(result.metrics):
                errors[_cell_name(result.config)] = _refusal(result.metrics)
        write_table(out, grid, errors)
    return _rows(out, grid, errors)


def read_sweep_config(out) -> dict:
    path = Path(out) / CONFIG_FILE
    if not path.is_file():
        raise FileNotFoundError(f"nothing to resume in {str(out)!r}: it has no {CONFIG_FILE}")
    settings = _read_json(path)
    keys = {"algos", "envs", "seeds", "timesteps", "overrides", "episodes"}
    if not isinstance(settings, dict) or set(settings) != keys:
        raise ValueError(
            f"{str(path)!r} is not a sweep configuration: it needs keys {sorted(keys)}"
        )
    return settings


def _read_json(path: Path):
    try:
        return read_json(path, "sweep file")
    except OSError as e:
        raise ValueError(f"cannot read {str(path)!r}: {e}") from None


def _rows(out: Path, grid: list, errors: dict, interrupted: bool = False) -> list[dict]:
    """The table's rows: each cell finished (its cell.json), failed (with its error), or not
    yet: `interrupted` when the sweep was and the cell's run had started, else `pending`."""
    rows = []
    for algo, env_id, seed in grid:
        name = _run_name(algo, env_id, seed)
        cell = out / "runs" / name / CELL_FILE
        if cell.is_file():
            rows.append(_read_json(cell))
        else:
            status = "pending"
            if name in errors:
                status = "failed"
            elif interrupted and (out / "runs" / name / "config.json").is_file():  # started
                status = "interrupted"
            rows.append(
                {"algo": algo, "env": env_id, "seed": seed, "status": status, "run": f"runs/{name}"}
                | ({"error": errors[name]} if name in errors else {})
            )
    return rows


def write_table(out: Path, grid: list, errors: dict, interrupted: bool = False) -> None:
    rows = _rows(out, grid, errors, interrupted)
    atomic_write_json(out / "sweep.json", rows)
    atomic_write_text(out / "sweep.md", results_table(rows))


def _list(values, name: str) -> list:
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name}={shown(values)} must be a list")
    values = list(values)
    if not values:
        raise ValueError(f"{name} is empty; give at least one")
    if len(values) > MAX_CELLS:
        raise ValueError(f"{name} has {len(values)} values; a grid has at most {MAX_CELLS} runs")
    counts = collections.Counter(repr(v) for v in values)  # (linear: 10,000 seeds in ms)
    repeated = sorted(v for v, n in counts.items() if n > 1)
    if repeated:
        raise ValueError(f"{name} repeats {clipped(', '.join(repeated))}: each run needs its own")
    return values


def _check_cpus(cpus: dict, available: int, where: str) -> None:
    (algo, env), need = max(cpus.items(), key=lambda kv: kv[1])
    if need > available:
        raise ValueError(
            f"a {algo} run on {env} has {need} env processes and reserves {need} CPUs, but "
            f"{where} {available}: Ray would wait for them forever; give more CPUs "
            f"(num_cpus, --num-cpus) or fewer env processes (overrides={{'n_envs': "
            f"{available}}}, --hyperparams '{{\"n_envs\": {available}}}')"
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
    resume: bool = False,
) -> tuple[list, dict]:
    """Checks every argument of `sweep` (see the module docstring) before anything runs;
    returns the grid and the CPUs each (algo, env) cell reserves."""
    algos = [check_algo(a) for a in _list(algos, "algos")]
    envs = [check_env_id(e) for e in _list(envs, "envs")]
    seeds = [check_seed(s, "seed") for s in _list(seeds, "seeds")]
    check_int(timesteps, 1, MAX_TIMESTEPS, "timesteps")
    check_int(episodes, 1, MAX_EPISODES, "episodes")
    check_mapping(overrides, "hyperparameter overrides")
    out = check_output_dir(out, "out", must_be_new=False)
    if not resume and (out / CONFIG_FILE).exists():
        raise FileExistsError(
            f"{str(out)!r} already holds a sweep; resume it (resume=True) or give a new directory"
        )
    if len(algos) * len(envs) * len(seeds) > MAX_CELLS:
        raise ValueError(
            f"the grid of {len(algos)} algos x {len(envs)} envs x {len(seeds)} seeds has "
            f"{len(algos) * len(envs) * len(seeds)} runs; at most {MAX_CELLS} are allowed"
        )
    grid = list(itertools.product(algos, envs, seeds))
    configs = {  # the seed changes nothing else of a run's configuration
        (a, e): resolve_config(e, a, timesteps, None, seeds[0], overrides=overrides)
        for a in algos
        for e in envs
    }
    cpus = {key: config.n_envs for key, config in configs.items()}  # a CPU per env process
    for a, e, s in grid:
        run_dir = out / "runs" / _run_name(a, e, s)
        if not (run_dir / "config.json").exists():
            continue
        if not resume:
            raise FileExistsError(
                f"{str(run_dir)!r} already holds a run; give the sweep a new directory"
            )
        if not (run_dir / CELL_FILE).exists():  # a cell to continue: the same settings
            _check_same_run(run_dir, dc.replace(configs[(a, e)], seed=s))
    if address is not None and address.startswith("ray://"):
        raise ValueError(
            f"address={address!r} is a Ray Client address, which is not supported: start the "
            "sweep on a node of the cluster (address 'auto' or 'HEAD_IP:6379'), where its "
            "results are written"
        )
    if address is not None and not RAY_ADDRESS.fullmatch(address):
        raise ValueError(
            f"address={shown(address)} is not a Ray cluster's address: 'auto' (the cluster "
            "this node is in) or HEAD_IP:PORT, e.g. 10.0.0.1:6379"
        )
    if address is None:  # the CPUs this process may use (taskset, a container's cpuset)
        local = num_cpus if num_cpus is not None else len(os.sched_getaffinity(0))
        check_int(local, 1, MAX_CPUS, "num_cpus")
        _check_cpus(
            cpus,
            local,
            "num_cpus (--num-cpus) gives" if num_cpus is not None else "this machine has",
        )
    return grid, cpus


def _check_same_run(run_dir: Path, config) -> None:
    """A cell's run (started) continues only with the settings it started with (as `train`
    checks, but before Ray starts: an edited sweep_config.json is refused at once)."""
    saved, _ = read_run_config(run_dir / "config.json")
    differences = config_differences(saved.comparable(), config.comparable())
    if differences:
        raise ValueError(
            f"the sweep's configuration no longer matches its run {str(run_dir)!r}: "
            + "; ".join(differences)
            + " (was sweep_config.json edited? put it back, or start a new sweep)"
        )


def _headline(row: dict) -> str:
    """The task's headline metric of a finished cell, lengths (`_m`) in cm."""
    key = row.get("headline", "final_object_to_goal_mean_m")  # rows written before it was named
    value = row["evaluation"][key]
    if key.endswith("_m"):
        return f"{key[:-2]} {value * 100:.2f} cm"
    return f"{key} {value:.4g}"


def results_table(rows: list[dict]) -> str:
    lines = [
        "| algo | env | seed | status | steps | wall (min) | headline metric | success |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        status = r["status"] + (f": {r['error']}" if "error" in r else "")
        head = f"| {r['algo']} | {r['env']} | {r['seed']} | {status} |"
        if r["status"] != "finished":
            lines.append(head + " | | | |")
            continue
        e = r["evaluation"]
        lines.append(
            head + f" {r['timesteps']} | {r['wall_time_s'] / 60:.1f} | "
            f"{_headline(r)} | {e['success_rate'] * 100:.0f} % |"
        )
    return "\n".join(lines) + "\n"
