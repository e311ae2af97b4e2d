"""The stable-baselines3 state an exact resume reads and writes beyond SB3's public API
(`learning.sb3_state`, and the public attributes `learning.checkpoint` stores): every field
exists with its type on real SB3 objects, SB3 itself still uses it, and a save/restore round
trip through JSON gives equal values. A failure here after an SB3 upgrade means resume would
silently lose that state: adapt `sb3_state` (or `checkpoint`) to the new release. A replay
buffer file that is not whole is refused in one line that names it."""

import json
import re

import gymnasium as gym
import numpy as np
import pytest
from sb3_contrib import TRPO
from stable_baselines3 import A2C, DDPG, PPO
from stable_baselines3.common.callbacks import EvalCallback
from stable_baselines3.common.logger import KVWriter, Logger, TensorBoardOutputFormat
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

from drake_tooluse.learning import checkpoint, sb3_state
from drake_tooluse.learning.run_log import PurgingTensorBoardOutput


class Tiny(gym.Env):
    """A 2-dimensional observation, a 1-dimensional action, five steps an episode."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self.np_random.uniform(-1, 1, 2).astype(np.float32), {}

    def step(self, action):
        self.t += 1
        obs = self.np_random.uniform(-1, 1, 2).astype(np.float32)
        done = self.t >= 5
        return obs, -float(np.square(action).sum()), done, False, {"is_success": done}


ALGOS = {
    "ppo": (PPO, {"n_steps": 16, "batch_size": 16, "n_epochs": 1}),
    "a2c": (A2C, {"n_steps": 4}),
    "trpo": (TRPO, {"n_steps": 16, "batch_size": 16}),
    "ddpg": (DDPG, {"learning_starts": 8, "buffer_size": 100}),
}


def _model(algo: str, steps: int = 0, callback=None):
    cls, kwargs = ALGOS[algo]
    model = cls("MlpPolicy", Tiny(), seed=0, device="cpu", verbose=0, **kwargs)
    if steps:
        model.learn(steps, callback=callback)
    return model


def _json(value):
    return json.loads(json.dumps(value))


# -- the algorithm ------------------------------------------------------------------------


@pytest.mark.parametrize("algo", ALGOS)
def test_the_algorithm_s_fields_exist_with_their_types(algo):
    model = _model(algo, 48)
    for name, kind in sb3_state.ALGORITHM_FIELDS.items():
        assert isinstance(getattr(model, name), kind), f"{type(model).__name__}.{name}"
    # SB3 itself keeps them: counts the updates and episodes, fills the window's buffers.
    assert model._n_updates > 0 and model.num_timesteps == 48
    assert len(model.ep_info_buffer) > 0 and len(model.ep_success_buffer) > 0
    assert model.ep_info_buffer.maxlen == model._stats_window_size
    if algo == "ddpg":
        assert model._episode_num > 0  # counted by off-policy algorithms only


@pytest.mark.parametrize("algo", ALGOS)
def test_the_algorithm_s_state_round_trips(algo):
    trained = _model(algo, 48)
    state = _json(
        {
            "timesteps": trained.num_timesteps,
            **sb3_state.algorithm_counters(trained),
            **sb3_state.episode_statistics(trained),
        }
    )
    fresh = _model(algo)
    sb3_state.restore_algorithm(fresh, state)
    assert fresh.num_timesteps == trained.num_timesteps
    assert sb3_state.algorithm_counters(fresh) == sb3_state.algorithm_counters(trained)
    assert sb3_state.episode_statistics(fresh) == sb3_state.episode_statistics(trained)
    assert fresh.ep_info_buffer.maxlen == trained.ep_info_buffer.maxlen
    # SB3 carries on from them: a learn that does not reset counts on from the restored steps.
    fresh.learn(16, reset_num_timesteps=False)
    assert fresh.num_timesteps == trained.num_timesteps + 16
    assert fresh._n_updates > trained._n_updates


# -- the logger ---------------------------------------------------------------------------


class Rows(KVWriter):
    def __init__(self):
        self.rows = []

    def write(self, key_values, key_excluded, step=0):
        self.rows.append((dict(key_values), dict(key_excluded)))


def test_the_logger_s_fields_exist_and_pending_values_round_trip(tmp_path):
    logger = Logger(None, [])
    for name, kind in sb3_state.LOGGER_FIELDS.items():
        assert isinstance(getattr(logger, name), kind), f"Logger.{name}"
    logger.record("train/loss", np.float32(0.5))
    logger.record("time/iterations", 3, exclude="tensorboard")
    logger.record_mean("rollout/ep_rew_mean", 2.0)
    logger.record_mean("rollout/ep_rew_mean", 4.0)
    assert logger.name_to_value["train/loss"] == 0.5  # SB3 keeps them there

    pending = _json(sb3_state.pending_log_values(logger))
    assert pending["values"] == {
        "train/loss": 0.5,
        "time/iterations": 3,
        "rollout/ep_rew_mean": 3.0,
    }
    assert pending["counts"]["rollout/ep_rew_mean"] == 2
    restored = Logger(None, [Rows()])
    sb3_state.restore_pending_log_values(restored, pending)
    assert sb3_state.pending_log_values(restored) == pending
    # The next dump writes them, and a later mean goes on from the restored count.
    restored.record_mean("rollout/ep_rew_mean", 6.0)
    restored.dump()
    (values, excluded) = restored.output_formats[0].rows[0]
    assert values == {"train/loss": 0.5, "time/iterations": 3, "rollout/ep_rew_mean": 4.0}
    assert excluded["time/iterations"] == ("tensorboard",)


def test_the_tensorboard_output_s_fields_exist(tmp_path):
    stock = TensorBoardOutputFormat(str(tmp_path / "stock"))
    for name, kind in sb3_state.TENSORBOARD_OUTPUT_FIELDS.items():
        assert isinstance(getattr(stock, name), kind), f"TensorBoardOutputFormat.{name}"
    assert stock._is_closed is False
    stock.close()
    assert stock._is_closed is True  # SB3 keeps its state there
    ours = PurgingTensorBoardOutput(str(tmp_path / "ours"), purge_step=5)
    ours.write({"eval/mean_reward": 1.0}, {"eval/mean_reward": None}, step=6)
    ours.close()
    assert len(list((tmp_path / "ours").glob("events.out.tfevents.*"))) == 1


# -- the evaluation callback ----------------------------------------------------------------


def _evaluation(tmp_path, name: str):
    env = DummyVecEnv([lambda: Monitor(Tiny())])  # wrapped as the training env is
    return EvalCallback(
        env, n_eval_episodes=2, eval_freq=16, log_path=str(tmp_path / name), verbose=0
    )


def test_the_evaluation_callback_s_fields_exist_and_round_trip(tmp_path):
    evaluation = _evaluation(tmp_path, "a")
    _model("ppo", 48, callback=evaluation)
    for name, kind in sb3_state.EVAL_CALLBACK_FIELDS.items():
        assert isinstance(getattr(evaluation, name), kind), f"EvalCallback.{name}"
    history = sb3_state.evaluation_history(evaluation)
    assert history["timesteps"] == [16, 32, 48] and len(history["successes"]) == 3
    assert sb3_state.evaluation_lists(evaluation)["results"] == evaluation.evaluations_results
    best, last = sb3_state.mean_rewards(evaluation)
    assert best is not None and last is not None

    fresh = _evaluation(tmp_path, "b")
    assert sb3_state.mean_rewards(fresh) == (None, None)
    sb3_state.restore_evaluation_history(fresh, _json(history), best, last)
    assert sb3_state.evaluation_history(fresh) == history
    assert sb3_state.mean_rewards(fresh) == (best, last)


def test_the_evaluation_callback_is_due_by_the_call_count_set(tmp_path):
    evaluation = _evaluation(tmp_path, "c")
    model = _model("ppo")
    model.set_logger(Logger(None, []))
    evaluation.init_callback(model)
    sb3_state.set_call_count(evaluation, 15)  # SB3 adds this call: the 16th, due
    evaluation.on_step()
    assert len(evaluation.evaluations_timesteps) == 1
    sb3_state.set_call_count(evaluation, 16)
    evaluation.on_step()
    assert len(evaluation.evaluations_timesteps) == 1


# -- the public attributes the checkpoint stores --------------------------------------------


def test_the_replay_buffer_s_fields_exist_and_round_trip(tmp_path):
    model = _model("ddpg", 48)
    buffer = model.replay_buffer
    for name in checkpoint.REPLAY_BUFFER_ARRAYS:
        assert isinstance(getattr(buffer, name), np.ndarray), f"ReplayBuffer.{name}"
    assert isinstance(buffer.pos, int) and isinstance(buffer.full, bool)
    assert isinstance(buffer.buffer_size, int) and buffer.pos == 48
    path = tmp_path / "replay_buffer.npz"
    checkpoint._save_replay_buffer(buffer, path)
    with np.load(path) as saved:  # the filled part only: 48 of the 100
        assert {len(saved[name]) for name in checkpoint.REPLAY_BUFFER_ARRAYS} == {48}
    fresh = _model("ddpg").replay_buffer
    checkpoint._restore_replay_buffer(fresh, path)
    assert (fresh.pos, fresh.full) == (buffer.pos, buffer.full)
    for name in checkpoint.REPLAY_BUFFER_ARRAYS:
        np.testing.assert_array_equal(getattr(fresh, name), getattr(buffer, name))


def _damage(path, how: str) -> None:
    if how == "missing":
        path.unlink()
    elif how == "garbage":
        path.write_bytes(b"not a replay buffer")
    elif how == "truncated":
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    else:  # a whole .npz whose arrays and counters disagree
        with np.load(path) as saved:
            arrays = dict(saved)
        if how == "an array missing":
            del arrays["rewards"]
        else:
            arrays["pos"] = np.int64(40)
        np.savez(path, **arrays)


@pytest.mark.parametrize(
    "how, says",
    [
        ("missing", "No such file"),
        # ~1 s each (a DDPG model apiece): with the slow tests CI runs.
        pytest.param("garbage", "not an .npz file", marks=pytest.mark.slow),
        pytest.param("truncated", "not a zip file", marks=pytest.mark.slow),
        pytest.param("an array missing", "rewards is not a file", marks=pytest.mark.slow),
        ("pos disagrees", "holds 48 transitions where pos=40"),
    ],
)
def test_a_damaged_replay_buffer_is_refused_naming_the_file(tmp_path, how, says):
    """A resume from a checkpoint whose replay buffer is not whole stops with one line that
    names the file; it never trains on a buffer that lost its transitions."""
    model = _model("ddpg", 48)
    checkpoint.write_checkpoint(
        tmp_path,
        model,
        None,
        _evaluation(tmp_path, "e"),
        iterations=48,
        wall_time_s=1.0,
        resumes=[],
    )
    folder, state = checkpoint.latest_checkpoint(tmp_path)
    fresh = _model("ddpg")
    checkpoint.restore_checkpoint(fresh, None, folder, state)  # whole, it restores
    assert fresh.replay_buffer.pos == 48
    _damage(folder / "replay_buffer.npz", how)
    with pytest.raises(ValueError, match=re.escape(str(folder / "replay_buffer.npz"))) as e:
        checkpoint.restore_checkpoint(_model("ddpg"), None, folder, state)
    assert says in str(e.value) and "\n" not in str(e.value)


def test_the_normalisation_s_fields_exist_and_round_trip(tmp_path):
    def normalized():
        return VecNormalize(VecMonitor(DummyVecEnv([Tiny])), gamma=0.9)

    venv = normalized()
    for name in checkpoint.VECNORMALIZE_FIELDS:
        assert hasattr(venv, name), f"VecNormalize.{name}"
    for rms in (venv.obs_rms, venv.ret_rms):
        assert {"mean", "var", "count"} <= set(vars(rms)), "RunningMeanStd"
    venv.reset()
    for _ in range(7):
        venv.step(np.ones((1, 1), np.float32))
    state = _json(checkpoint._vecnormalize_state(venv))
    fresh = normalized()
    checkpoint._restore_vecnormalize(fresh, state, tmp_path / "vecnormalize.json")
    assert checkpoint._vecnormalize_state(fresh) == checkpoint._vecnormalize_state(venv)
    obs = np.array([[0.3, -0.2]], np.float32)
    np.testing.assert_array_equal(fresh.normalize_obs(obs), venv.normalize_obs(obs))
