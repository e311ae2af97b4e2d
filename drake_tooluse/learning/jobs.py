"""A job of runs on this machine: each run's commands (`drake-tooluse train`, `evaluate`) as
subprocesses, N runs at a time, a run waiting while another it needs is still to run, and each
run's result recorded on the calling thread as it ends.

It keeps what a long job needs from the machine under it: no command outlives the job (an error
in a run, Ctrl-C, SIGTERM or SIGHUP kills every command still running, and no new one starts;
SIGKILL cannot be caught: kill the job's process group), and a result is recorded before the
next one is taken, so a job stopped at any point has written every run it finished. What a run
is, how it resumes and what its result holds are the caller's (`experiments.paper_study`).

`learning.sweep` runs its grid on Ray Tune instead: any node, every cell in-process, its own
table. This runner is for a study whose runs are commands with a recorded command line, that
depend on each other (a fine-tuning starts from another run's policy), on one machine.
"""

from __future__ import annotations

import shlex
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Hashable
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)  # stop the job as Ctrl-C does


def this_interpreter(cmd: list[str]) -> list[str]:
    """`cmd` as this Python runs it: `drake-tooluse …` as `python -m drake_tooluse.cli …`, so
    a job started from a virtual environment that is not activated (`.venv/bin/drake-tooluse
    study`) finds its commands as one from an activated one does. What the job logs and
    records stays `drake-tooluse …`."""
    if cmd and cmd[0] == "drake-tooluse":
        return [sys.executable, "-m", "drake_tooluse.cli", *cmd[1:]]
    return list(cmd)


class Commands:
    """The job's running commands: started through it, killed together when the job stops."""

    def __init__(self):
        self._live: set[subprocess.Popen] = set()
        self._lock = threading.Lock()
        self._stopping = threading.Event()

    def start(self, cmd: list[str]) -> subprocess.Popen:
        """Starts `cmd` (its stdout and stderr piped, as text); refused once the job stops."""
        with self._lock:
            if self._stopping.is_set():
                raise RuntimeError(f"the job is stopping: {shlex.join(cmd)} not started")
            job = subprocess.Popen(
                this_interpreter(cmd), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            self._live.add(job)
        return job

    def end(self, job: subprocess.Popen) -> None:
        """Kills `job` if it still runs, and forgets it."""
        if job.poll() is None:
            job.kill()
            job.wait()
        with self._lock:
            self._live.discard(job)

    def run(self, cmd: list[str]) -> subprocess.CompletedProcess:
        """Runs `cmd` to its end; what it printed and its exit code."""
        job = self.start(cmd)
        try:
            stdout, stderr = job.communicate()
        finally:
            self.end(job)
        return subprocess.CompletedProcess(cmd, job.returncode, stdout, stderr)

    def stop(self) -> None:
        """Kills every running command and lets no new one start."""
        with self._lock:
            self._stopping.set()
            for job in self._live:
                if job.poll() is None:
                    job.kill()


def last_line(done: subprocess.CompletedProcess) -> str:
    """A failed command's error: the last line of its stderr (or its exit code)."""
    return (done.stderr.strip().splitlines() or [f"exit code {done.returncode}"])[-1]


def _interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


def run_queue(
    pending: list[Hashable],
    parallel: int,
    ready: Callable,
    prepare: Callable,
    record: Callable,
    commands: Commands,
) -> None:
    """Runs `pending` in its order, `parallel` at a time, on threads of this process.

    `ready(run, pending, running)` says whether `run` may start now (`running`: the runs
    started and not yet recorded); `prepare(run)`, called on this thread as `run` starts, gives
    `(work, about)`: `work()` runs on a worker thread (its commands started through `commands`)
    and returns the run's result; `record(run, result, about)` is called on this thread as it
    ends. An exception in `work` stops the job and is raised here; so does a signal (SIGINT,
    SIGTERM, SIGHUP: as KeyboardInterrupt). Either way every command still running is killed
    first, and the signal handlers are put back.
    """
    if parallel < 1:
        raise ValueError(f"parallel={parallel}: runs at a time must be at least 1")
    pending = list(pending)
    running = {}  # future -> (run, about)
    handlers = {signum: signal.signal(signum, _interrupt) for signum in STOP_SIGNALS}
    try:
        with ThreadPoolExecutor(max_workers=parallel) as pool:

            def start_ready():
                for run in list(pending):
                    busy = [r for r, _ in running.values()]
                    if len(running) < parallel and ready(run, pending, busy):
                        pending.remove(run)
                        work, about = prepare(run)
                        running[pool.submit(work)] = (run, about)

            try:
                start_ready()
                while running:
                    finished, _ = wait(running, return_when=FIRST_COMPLETED)
                    ended = [(future, running.pop(future)) for future in finished]
                    failed = [future.exception() for future, _ in ended if future.exception()]
                    if not failed:  # before the records: a record may take minutes (a report)
                        start_ready()
                    for future, (run, about) in ended:
                        if future.exception() is None:
                            record(run, future.result(), about)
                    if failed:
                        raise failed[0]
            except BaseException:  # no run goes on without the job that records it
                commands.stop()
                raise
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
