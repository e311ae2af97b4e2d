"""One clock: every control step of every task's env, and of its deployed diagram, ends at
exactly k · period and holds one IK solve and period / time_step plant steps (docs/CLOCK.md).
A clock summed step by step (`context.get_time() + period`, as `DrakeGymEnv.step`) fails this."""

import gymnasium as gym
import numpy as np
import pytest
from pydrake.gym import DrakeGymEnv

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.paths import PULL_POLICY, PULL_SCENARIO, TRANSFER_POLICY
from drake_tooluse.tasks import rollout
from drake_tooluse.tasks.deploy import build_policy_diagram, run_policy
from drake_tooluse.world.scenario import Scenario, load_scenario
from tests.tasks import toy_touch

STEPS = 1000


class SolveCounter:
    """Counts the solves of an IK (`ToolTipIK.solve`, wrapped on the instance)."""

    def __init__(self):
        self.count = 0

    def wrap(self, ik) -> None:
        """Counts `ik`'s solves from now on (once: an env keeps its IK across resets)."""
        solve = ik.solve
        if getattr(solve, "counter", None) is self:
            return

        def counted(*args, **kwargs):
            self.count += 1
            return solve(*args, **kwargs)

        counted.counter = self
        ik.solve = counted


def _per_step(simulator, period: float, k: int, solves: int, state: dict) -> None:
    """Checks control step k: its end time, its IK solves and its plant steps."""
    context = simulator.get_context()
    assert context.get_time() == k * period, (k, context.get_time())
    assert solves - state["solves"] == 1, k
    taken = simulator.get_num_steps_taken()
    assert taken - state["taken"] == state["plant_steps"], (k, taken - state["taken"])
    state.update(solves=solves, taken=taken)


@pytest.fixture(scope="module", autouse=True)
def toy_registered():
    toy_touch.register()


@pytest.mark.parametrize(
    "env_id, kwargs",
    [
        ("drake_tooluse/ToolPush-v1", {"action_mode": "position"}),
        ("drake_tooluse/ToolPull-v1", {}),
        (toy_touch.ENV_ID, {}),
    ],
)
def test_every_env_step_ends_on_the_period_grid_with_one_ik_solve(env_id, kwargs):
    check_env_clock(env_id, kwargs)


def test_drakes_own_step_fails_the_check():
    """The same env stepped by Drake's `DrakeGymEnv.step` (1.51.1), whose clock is summed."""
    with pytest.raises(AssertionError):
        check_env_clock("drake_tooluse/ToolPush-v1", {"action_mode": "position"}, drake_step=True)


def check_env_clock(env_id: str, kwargs: dict, drake_step: bool = False) -> None:
    """STEPS random steps of `env_id`, each checked (`_per_step`), reset at each episode's end;
    each step the env's own or (`drake_step`) `DrakeGymEnv.step` called on it."""
    env = gym.make(env_id, **kwargs)
    inner = env.unwrapped
    period = inner.time_step
    rng = np.random.default_rng(0)
    counter, k, state, done = SolveCounter(), 0, {}, True
    try:
        for step in range(STEPS):
            if done:
                env.reset(seed=step)
                simulator = inner.simulator
                counter.wrap(_ik(inner))
                plant_step = _plant(inner).time_step()
                k = 0
                state = {
                    "solves": counter.count,
                    "taken": simulator.get_num_steps_taken(),
                    "plant_steps": round(period / plant_step),
                }
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            step = DrakeGymEnv.step(inner, action) if drake_step else env.step(action)
            _, _, terminated, truncated, _ = step
            k += 1
            _per_step(simulator, period, k, counter.count, state)
            done = terminated or truncated
    finally:
        env.close()


def _ik(env):
    """The env's IK (the project's envs keep `ik_system`; the toy keeps its `_control`)."""
    system = getattr(env, "ik_system", None) or env._control.ik_system
    return system.ik


def _plant(env):
    world = getattr(env, "world", None)
    if world is not None:
        return world.plant
    return env.simulator.get_system().GetSubsystemByName("plant")


class _AdvanceRecorder:
    """Wraps a module's `advance` to check each control step of a deployed run."""

    def __init__(self, advance, period: float, counter: SolveCounter):
        self._advance, self.period, self.counter = advance, period, counter
        self.k, self.state = 0, None

    def __call__(self, simulator, t):
        if self.state is None:
            plant = simulator.get_system().GetSubsystemByName("plant")
            self.state = {
                "solves": self.counter.count,
                "taken": simulator.get_num_steps_taken(),
                "plant_steps": round(self.period / plant.time_step()),
            }
        failure = self._advance(simulator, t)
        self.k += 1
        _per_step(simulator, self.period, self.k, self.counter.count, self.state)
        return failure


@pytest.mark.parametrize(
    "policy_dir, scenario",
    [(TRANSFER_POLICY, Scenario()), (PULL_POLICY, load_scenario(PULL_SCENARIO))],
    ids=["push", "pull"],
)
def test_every_step_of_the_deployed_policy_diagram_is_on_the_grid(
    monkeypatch, policy_dir, scenario
):
    built = build_policy_diagram(scenario, load_policy(policy_dir))
    counter = SolveCounter()
    counter.wrap(built.control.ik_system.ik)
    recorder = _AdvanceRecorder(rollout.advance, scenario.control.control_period, counter)
    monkeypatch.setattr(rollout, "advance", recorder)
    run = run_policy(built, max_steps=STEPS)
    assert run.steps == recorder.k == STEPS and not run.sim_error
