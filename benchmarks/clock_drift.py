"""How far a control clock summed step by step drifts, and what it costs: prints, for a
minimal Drake diagram and for the project's push and pull envs, how many control steps end off
the period grid and how many hold no control update or two.

`pydrake.gym.DrakeGymEnv.step` (1.51.1) advances with
`AdvanceTo(context.get_time() + time_step)`: each step's end is the sum of the ones before, so
floating-point error accumulates, and a step that ends a few 1e-15 s before its period leaves
that period's controller update (the IK) to the next step: one action never acts, the next
acts twice. Each env is stepped both ways: by Drake's own `DrakeGymEnv.step` called on it, and
by its own step, which advances to `k * time_step` (k the integer step count,
`builders.task_gym_env.CountedClockGymEnv`) and holds every step on the grid. The minimal
diagram is the reproduction written up for Drake in docs/CLOCK.md.

    python benchmarks/clock_drift.py [--steps 300]
"""

from __future__ import annotations

import argparse
import sys

import gymnasium as gym
from pydrake.gym import DrakeGymEnv
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.cli.common import run_script
from drake_tooluse.limits import MAX_BENCHMARK_PERIODS
from drake_tooluse.validation import check_int

PERIOD, PLANT_STEP = 0.04, 0.02  # the envs' control period and plant step (s)
ENV_IDS = ("drake_tooluse/ToolPush-v1", "drake_tooluse/ToolPull-v1")  # one per task


class UpdateCounter(LeafSystem):
    """Counts its periodic discrete updates (a controller updating once a period)."""

    def __init__(self, period: float):
        super().__init__()
        self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, state):
        state.get_mutable_vector().SetAtIndex(0, context.get_discrete_state_vector()[0] + 1)

    def count(self, root_context) -> float:
        return self.GetMyContextFromRoot(root_context).get_discrete_state_vector()[0]


def minimal(steps: int, summed: bool) -> tuple[int, int, int]:
    """(steps ending off the grid, steps holding no control update, steps holding two) of a
    diagram of two periodic systems: a controller at PERIOD, a stand-in plant at PLANT_STEP."""
    builder = DiagramBuilder()
    control = builder.AddSystem(UpdateCounter(PERIOD))
    builder.AddSystem(UpdateCounter(PLANT_STEP))
    simulator = Simulator(builder.Build())
    context = simulator.get_mutable_context()
    off_grid, updates = 0, []
    for k in range(1, steps + 1):
        before = control.count(context)
        simulator.AdvanceTo(context.get_time() + PERIOD if summed else k * PERIOD)
        off_grid += context.get_time() != k * PERIOD
        updates.append(control.count(context) - before)
    return off_grid, updates.count(0), updates.count(2)


def env_clock(env_id: str, steps: int, drake_step: bool) -> tuple[int, int, int]:
    """(steps ending below k * period, steps holding no IK solve, steps holding two) of
    `env_id`, random actions from seed 0, reset every episode's step limit (k counts the steps
    of the episode), each step `DrakeGymEnv.step` (`drake_step`) or the env's own."""
    env = gym.make(env_id)
    inner, limit = env.unwrapped, env.spec.max_episode_steps
    step = (lambda a: DrakeGymEnv.step(inner, a)) if drake_step else inner.step
    solves = [0]
    env.action_space.seed(0)
    below, solved = 0, []
    try:
        for n in range(steps):
            k = n % limit
            if k == 0:
                env.reset(seed=n)
                _count_solves(inner.ik_system.ik, solves)
            before = solves[0]
            step(env.action_space.sample())
            below += inner.simulator.get_context().get_time() < (k + 1) * PERIOD
            solved.append(solves[0] - before)
        return below, solved.count(0), solved.count(2)
    finally:
        env.close()


def _count_solves(ik, solves: list) -> None:
    """Counts `ik`'s solves into solves[0] (wrapped once: an env may keep its IK)."""
    if getattr(ik.solve, "counted", False):
        return
    solve = ik.solve

    def counted(*args, **kwargs):
        solves[0] += 1
        return solve(*args, **kwargs)

    counted.counted = True
    ik.solve = counted


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=300, help="control steps (default 300)")
    args = parser.parse_args(argv)
    try:
        steps = check_int(args.steps, 10, MAX_BENCHMARK_PERIODS, "--steps")
    except ValueError as e:
        parser.error(str(e))
    print(f"minimal diagram, {steps} steps of {PERIOD} s (plant {PLANT_STEP} s):")
    for summed in (True, False):
        off, none, two = minimal(steps, summed)
        how = "context.get_time() + period" if summed else "k * period (integer count)"
        print(f"  {how:30s} {off:5d} end off the grid; {none} hold no update, {two} hold two")
    for env_id in ENV_IDS:
        print(f"{env_id}, {steps} random steps:")
        for drake_step in (True, False):
            below, none, two = env_clock(env_id, steps, drake_step)
            how = "DrakeGymEnv.step" if drake_step else "its own step (integer count)"
            print(
                f"  {how:30s} {below:5d} end below their period; {none} hold no IK solve, "
                f"{two} hold two"
            )
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
