"""How far a control clock summed step by step drifts, and what it costs: prints, for a
minimal Drake diagram and for the project's push and pull envs, how many control steps end off
the period grid and how many hold no control update or two.

`pydrake.gym.DrakeGymEnv.step` (1.51.1) and this project's -v0 envs advance with
`AdvanceTo(context.get_time() + time_step)`: each step's end is the sum of the ones before, so
floating-point error accumulates, and a step that ends a few 1e-15 s before its period leaves
that period's controller update (the IK) to the next step: one action never acts, the next
acts twice. Advancing to `k * time_step` (k the integer step count), as the -v1 envs do
(`builders.task_gym_env.CountedClockGymEnv`), holds every step on the grid. The minimal
diagram is the reproduction written up for Drake in docs/CLOCK.md.

    python benchmarks/clock_drift.py [--steps 300]
"""

from __future__ import annotations

import argparse
import sys
import warnings

import gymnasium as gym
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.cli.common import count_arg, run_script

PERIOD, PLANT_STEP = 0.04, 0.02  # the envs' control period and plant step (s)
ENV_IDS = (  # the summed clock (-v0) and the counted one (-v1), per task
    "drake_tooluse/ToolPush-v0",
    "drake_tooluse/ToolPush-v1",
    "drake_tooluse/ToolPull-v0",
    "drake_tooluse/ToolPull-v1",
)


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


def env_off_grid(env_id: str, steps: int) -> int:
    """Steps of `env_id` (random actions, seed 0, reset at each episode's end) whose
    simulated time ends below k * period, k the step's count in its episode."""
    with warnings.catch_warnings():  # Gymnasium's "out of date" warning of the -v0 ids
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(env_id)
    try:
        env.reset(seed=0)
        env.action_space.seed(0)
        inner, k, below = env.unwrapped, 0, 0
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            k += 1
            t = inner.simulator.get_context().get_time()
            below += t < k * PERIOD
            if terminated or truncated:
                env.reset()
                k = 0
        return below
    finally:
        env.close()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=300, help="control steps (default 300)")
    args = parser.parse_args(argv)
    try:
        steps = count_arg(args.steps, "--steps", 10, 100_000)
    except ValueError as e:
        parser.error(str(e))
    print(f"minimal diagram, {steps} steps of {PERIOD} s (plant {PLANT_STEP} s):")
    for summed in (True, False):
        off, none, two = minimal(steps, summed)
        how = "context.get_time() + period" if summed else "k * period (integer count)"
        print(f"  {how:30s} {off:5d} end off the grid; {none} hold no update, {two} hold two")
    for env_id in ENV_IDS:
        below = env_off_grid(env_id, steps)
        print(f"{env_id}: {below} of {steps} random steps end below their period")
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
