"""Simulation failures injected into Drake's simulator: a `RuntimeError`
from `Simulator.AdvanceTo`, and a state gone NaN. Nothing non-finite reaches a learner, an
evaluation counts the failure, an experiment records it per run and goes on."""

import json

import gymnasium as gym
import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import drake_tooluse  # noqa: F401  (registers the ids)
import drake_tooluse.experiments.transfer as transfer
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.paths import TRANSFER_POLICY

ADVANCE = Simulator.AdvanceTo


def _poison(simulator) -> None:
    """Every state of the simulator's context becomes NaN (a diverged simulation)."""
    context = simulator.get_mutable_context()
    state = context.get_mutable_discrete_state()
    for i in range(state.num_groups()):
        vector = state.get_mutable_vector(i)
        vector.SetFromVector(np.full(vector.size(), np.nan))


def failing_advance(after: int, raises=True):
    """An AdvanceTo that works `after` times, then poisons the state and raises
    (`raises=True`), returns (False), or steps on from the poisoned state ("step"): Drake's
    systems and the package's Python systems then meet the NaN inside the step."""
    calls = {"n": 0}

    def advance(self, t):
        calls["n"] += 1
        if calls["n"] <= after:
            return ADVANCE(self, t)
        _poison(self)
        if raises == "step":
            return ADVANCE(self, t)
        if raises:
            raise RuntimeError("injected: the discrete solver failed to converge")
        return None

    return advance


@pytest.mark.parametrize(
    "raises", [True, False, "step"], ids=["RuntimeError", "NaN state", "NaN inside the step"]
)
def test_a_failed_step_returns_the_last_finite_state(monkeypatch, raises):
    env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position").unwrapped
    env.reset(seed=0)
    for _ in range(2):
        obs, reward, *_ = env.step(np.array([0.0, 0.5, 0.0]))
    monkeypatch.setattr(Simulator, "AdvanceTo", failing_advance(0, raises))
    failed_obs, failed_reward, terminated, truncated, info = env.step(np.array([0.0, 0.5, 0.0]))
    assert info["sim_error"] and truncated and not terminated and not info["is_success"]
    np.testing.assert_array_equal(failed_obs, obs)  # the last finite observation
    assert failed_reward == reward and np.isfinite(failed_reward)
    assert all(np.isfinite(v) for v in info.values() if isinstance(v, float))
    monkeypatch.setattr(Simulator, "AdvanceTo", ADVANCE)
    obs, _ = env.reset(seed=1)  # the next episode starts clean
    assert np.all(np.isfinite(obs)) and not env.step(np.zeros(3))[4]["sim_error"]
    env.close()


def test_a_simulation_failure_does_not_poison_the_normalisation(monkeypatch):
    def make():
        return gym.make("drake_tooluse/ToolPush-v1", action_mode="position")

    venv = VecNormalize(DummyVecEnv([make]), norm_obs=True, norm_reward=True)
    venv.seed(0)
    venv.reset()
    monkeypatch.setattr(Simulator, "AdvanceTo", failing_advance(3))
    for _ in range(6):
        obs, rewards, dones, infos = venv.step(np.zeros((1, 3)))
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rewards))
    assert np.all(np.isfinite(venv.obs_rms.mean)) and np.all(np.isfinite(venv.obs_rms.var))
    assert np.isfinite(venv.ret_rms.var)
    venv.close()


def test_evaluate_counts_the_episodes_the_simulation_failed_in(monkeypatch):
    monkeypatch.setattr(Simulator, "AdvanceTo", failing_advance(5))
    result = evaluate(TRANSFER_POLICY, episodes=2, seed=1000)
    assert result.sim_errors == 2
    first = result.per_episode[0]
    assert first["sim_error"] and not first["success"] and first["length"] == 6
    assert np.isfinite(result.metrics["final_object_to_goal_mean_m"]) and result.success_rate == 0.0


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_a_failed_transfer_run_is_recorded_and_the_experiment_goes_on(monkeypatch, tmp_path):
    run_closed_loop = transfer.run_closed_loop
    failing = {"reality": 0}

    def flaky(scenario, policy, belief):  # the first reality run's simulation fails
        if scenario.control.actuation_delay > 0 and failing["reality"] == 0:
            failing["reality"] += 1
            monkeypatch.setattr(Simulator, "AdvanceTo", failing_advance(3))
            try:
                return run_closed_loop(scenario, policy, belief)
            finally:
                monkeypatch.setattr(Simulator, "AdvanceTo", ADVANCE)
        return run_closed_loop(scenario, policy, belief)

    measure = transfer.measure
    measured = {"n": 0}

    def flaky_measure(*args, **kwargs):  # the camera finds nothing in the second run
        measured["n"] += 1
        if measured["n"] == 2:
            raise ValueError("injected: no marker in any view")
        return measure(*args, **kwargs)

    monkeypatch.setattr(transfer, "run_closed_loop", flaky)
    monkeypatch.setattr(transfer, "measure", flaky_measure)
    result = transfer.transfer_experiment(
        tmp_path / "t", TRANSFER_POLICY, tools=[0.15], runs=3, log=lambda text: None
    )
    (tool,) = result["tools"]
    reality = tool["reality"]
    assert reality["runs"] == 3 and reality["failed_runs"] == 2 and reality["completed_runs"] == 1
    assert reality["sim_errors"] == 1 and result["sim_errors"] == 1 and result["failed_runs"] == 2
    runs = reality["per_run"]
    assert runs[0]["sim_error"] and runs[0]["failed"] and "simulation failed" in runs[0]["error"]
    assert runs[1]["failed"] and "no marker" in runs[1]["error"]
    assert not runs[2]["failed"] and reality["object_travel_mean_m"] == runs[2]["object_travel_m"]
    assert tool["nominal"]["failed_runs"] == 0 and tool["nominal"]["completed_runs"] == 3
    written = json.loads((tmp_path / "t" / "transfer.json").read_text())
    assert written["tools"][0]["reality"]["failed_runs"] == 2


def test_a_policy_diagram_run_that_fails_is_flagged_with_finite_figures(monkeypatch):
    from drake_tooluse.learning.policy_dir import load_policy
    from drake_tooluse.tasks.deploy import build_policy_diagram, run_policy
    from drake_tooluse.world.scenario import Scenario

    built = build_policy_diagram(Scenario(), load_policy(TRANSFER_POLICY))
    monkeypatch.setattr(Simulator, "AdvanceTo", failing_advance(4, raises="step"))
    run = run_policy(built, max_steps=20)
    assert run.sim_error and run.steps == 5 and not run.success
    assert "step 5" in run.error
    assert np.all(np.isfinite(run.tool_path)) and np.all(np.isfinite(run.object_path))
    assert np.isfinite(run.final_object_to_goal) and run.as_dict()["sim_error"]


def flinging_advance(world_now):
    """`Simulator.AdvanceTo` that, after its third call, moves the object of `world_now()` 2 m
    away: a blow-up that stays finite."""
    calls = {"n": 0}

    def advance(self, t):
        status = ADVANCE(self, t)
        calls["n"] += 1
        if calls["n"] == 3:
            world = world_now()
            plant, box = world.plant, world.box
            context = plant.GetMyMutableContextFromRoot(self.get_mutable_context())
            X_WB = box.EvalPoseInWorld(context)
            X_WB.set_translation(X_WB.translation() + [2.0, 0.0, 0.0])
            plant.SetFreeBodyPose(context, box, X_WB)
        return status

    return advance


def test_a_box_flung_by_a_diverged_solve_is_a_simulation_failure(monkeypatch):
    """A blow-up that stays finite (the box thrown metres in one step) is flagged too, and its
    travel is not counted as a push."""
    from drake_tooluse.builders.failures import MAX_OBJECT_SPEED
    from drake_tooluse.learning.policy_dir import load_policy
    from drake_tooluse.tasks.deploy import build_policy_diagram, run_policy
    from drake_tooluse.world.scenario import Scenario

    built = build_policy_diagram(Scenario(), load_policy(TRANSFER_POLICY))
    monkeypatch.setattr(Simulator, "AdvanceTo", flinging_advance(lambda: built.world))
    run = run_policy(built, max_steps=20)
    assert run.sim_error and run.steps == 3 and not run.success
    assert f"more than {MAX_OBJECT_SPEED:g} m/s" in run.error and "step 3" in run.error
    assert (
        run.object_travel < 0.1 and np.linalg.norm(run.object_path[-1] - run.object_path[0]) < 0.1
    )


@pytest.mark.parametrize("env_id", ["drake_tooluse/ToolPush-v1", "drake_tooluse/ToolPull-v1"])
def test_every_env_judges_an_object_flung_by_a_diverged_solve_as_its_deployed_run_does(
    env_id, monkeypatch
):
    """The object thrown metres in one step ends the env's episode as a simulation failure,
    as it ends a deployed run (the same check: `builders.failures.object_diverged`)."""

    env = gym.make(env_id)
    inner = env.unwrapped
    env.reset(seed=0)
    monkeypatch.setattr(Simulator, "AdvanceTo", flinging_advance(lambda: inner.world))
    action = np.zeros(env.action_space.shape, np.float32)
    infos = [env.step(action) for _ in range(3)]
    env.close()
    assert [i[3] for i in infos] == [False, False, True]  # truncated at the third step
    assert [i[4]["sim_error"] for i in infos] == [False, False, True]
