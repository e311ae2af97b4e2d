"""Independent runs spread over the machine's cores: forked worker processes, which inherit
what the parent has loaded (policies, worlds), so nothing is pickled but each run's index and
its result.

Each run must be deterministic on its own (its own seeds): the results are the same, in the
same order, for any number of workers.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Sequence

from drake_tooluse.limits import MAX_WORKERS
from drake_tooluse.validation import check_int

# The runs of the map in progress: set before the workers fork, read by them.
_RUNS: tuple[Callable, Sequence] | None = None


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity, which a container or `taskset`
    may narrow)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def _run(i: int):
    function, items = _RUNS
    return function(items[i])


def _worker_start() -> None:
    """Each worker is one core's worth: torch (where the parent loaded it, with a policy)
    runs no intra-op threads beside the other workers. Ctrl-C is the parent's to handle (it
    ends the pool, and the command says so in one line); a worker ignores it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


def map_forked(function: Callable, items: Sequence, workers: int) -> list:
    """[function(item) for item in items], run by up to `workers` forked processes (in this
    process where one is enough). An exception a run raises is raised here."""
    global _RUNS
    check_int(workers, 1, MAX_WORKERS, "workers")
    items = list(items)
    workers = min(workers, len(items))
    if workers <= 1:
        return [function(item) for item in items]
    _RUNS = (function, items)
    try:
        with multiprocessing.get_context("fork").Pool(workers, _worker_start) as pool:
            return pool.map(_run, range(len(items)), chunksize=1)
    finally:
        _RUNS = None
