"""Independent runs on forked workers: the serial results, in order, whatever the workers."""

import os

import pytest

from drake_tooluse.experiments.parallel import available_cores, map_forked


def test_the_workers_give_the_serial_results_in_order():
    offset = 7  # a closure: the workers inherit it, nothing of it is pickled
    serial = map_forked(lambda x: x * x + offset, range(9), 1)
    assert serial == [x * x + offset for x in range(9)]
    for workers in (2, 3, 20):
        assert map_forked(lambda x: x * x + offset, range(9), workers) == serial


def test_the_runs_are_in_other_processes_and_one_worker_is_this_one():
    parent = os.getpid()
    assert set(map_forked(lambda _: os.getpid(), range(4), 1)) == {parent}
    assert parent not in map_forked(lambda _: os.getpid(), range(4), 2)


def test_a_run_s_error_is_raised_here():
    def run(x):
        if x == 3:
            raise ValueError(f"run {x} failed")
        return x

    with pytest.raises(ValueError, match="run 3 failed"):
        map_forked(run, range(5), 2)


def test_bad_worker_counts_are_refused():
    with pytest.raises(ValueError, match=r"workers=0 is outside the allowed range \[1, 64\]"):
        map_forked(abs, [1], 0)
    assert map_forked(abs, [], 2) == []
    assert available_cores() >= 1
