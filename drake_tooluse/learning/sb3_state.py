"""The one module that reads and writes stable-baselines3's undocumented state, for an exact
resume. SB3's own way to save a run (`model.save`, `save_replay_buffer`) pickles and does not
cover the logger or the callbacks; its public API (`get_parameters`/`set_parameters`) covers
the tensors only. What else a resumed session must carry on from is named in the `*_FIELDS`
tables below, each field with why. tests/learning/test_sb3_state.py checks every one of them
on real SB3 objects, so an SB3 release that renames or removes one fails a test instead of
silently starting a counter, a statistic or a history over on a resume.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import EvalCallback
from stable_baselines3.common.logger import Logger, TensorBoardOutputFormat

# BaseAlgorithm: what `learn(reset_num_timesteps=False)` continues from.
ALGORITHM_FIELDS = {
    # The run's step count: learn() adds the session's budget to it, callbacks see it.
    "num_timesteps": int,
    # Gradient updates so far: logged as train/n_updates, and TD3/DDPG's `policy_delay` counts
    # it.
    "_n_updates": int,
    # Episodes so far (off-policy): logged as time/episodes, and `log_interval` counts it.
    "_episode_num": int,
    # The length of the two episode buffers below (read only: a restored buffer keeps it).
    "_stats_window_size": int,
    # The last episodes' infos (return, length, ...): rollout/ep_rew_mean and friends are
    # means over them, so a session that started them empty would log different values.
    "ep_info_buffer": deque,
    # The same episodes' successes: rollout/success_rate.
    "ep_success_buffer": deque,
}

# Logger: the values recorded and not yet dumped at a checkpoint (the train/* values of the
# last update, written with the next row); a resume puts them back so that row is the same.
LOGGER_FIELDS = {"name_to_value": dict, "name_to_count": dict, "name_to_excluded": dict}

# TensorBoardOutputFormat: its constructor makes a SummaryWriter that cannot purge a killed
# session's events, so `run_log` gives it one of its own (`writer`) and marks it open
# (`_is_closed`, which `write` asserts is False).
TENSORBOARD_OUTPUT_FIELDS = {"writer": object, "_is_closed": bool}

# EvalCallback: when an evaluation is due, and the history it writes to evaluations.npz and
# compares each new evaluation with.
EVAL_CALLBACK_FIELDS = {
    # BaseCallback's call count, which EvalCallback compares with `eval_freq`; it restarts at
    # 0 each session, so it is set from the run's step count instead.
    "n_calls": int,
    # The history of evaluations: each new one is appended, and all are written.
    "evaluations_timesteps": list,
    "evaluations_results": list,
    "evaluations_length": list,
    "evaluations_successes": list,
    # The best mean reward so far (a new best saves `best/`), and the last one.
    "best_mean_reward": float,
    "last_mean_reward": float,
}


# -- the algorithm ----------------------------------------------------------------------------


def algorithm_counters(model: BaseAlgorithm) -> dict:
    return {"n_updates": int(model._n_updates), "episode_num": int(model._episode_num)}


def episode_statistics(model: BaseAlgorithm) -> dict:
    # As JSON: VecMonitor's infos are numbers (numpy's among them).
    return {
        "ep_info_buffer": [
            {k: float(v) for k, v in e.items()} for e in (model.ep_info_buffer or [])
        ],
        "ep_success_buffer": [bool(x) for x in (model.ep_success_buffer or [])],
    }


def restore_algorithm(model: BaseAlgorithm, state: dict) -> None:
    """Puts back what `algorithm_counters` and `episode_statistics` returned (keys of
    `state`, missing ones as a new run has them) and the step count `state["timesteps"]`."""
    model.num_timesteps = int(state["timesteps"])
    model._n_updates = int(state.get("n_updates", 0))
    model._episode_num = int(state.get("episode_num", 0))
    window = model._stats_window_size
    model.ep_info_buffer = deque(state.get("ep_info_buffer", []), maxlen=window)
    model.ep_success_buffer = deque(state.get("ep_success_buffer", []), maxlen=window)


# -- the logger -------------------------------------------------------------------------------


def _plain(value):
    return value.item() if hasattr(value, "item") else value


def pending_log_values(logger: Logger) -> dict:
    """The numbers recorded and not yet written (they go with the next row), as JSON."""
    values = {
        k: _plain(v)
        for k, v in logger.name_to_value.items()
        if isinstance(_plain(v), (int, float)) and not isinstance(_plain(v), bool)
    }
    return {
        "values": values,
        "counts": {k: int(logger.name_to_count[k]) for k in values},
        "excluded": {
            k: list(e) if isinstance(e, (list, tuple)) else e
            for k, e in logger.name_to_excluded.items()
            if k in values
        },
    }


def restore_pending_log_values(logger: Logger, pending: dict) -> None:
    # Written directly, not through `record`: they are recorded already (and a RunLogger's
    # `record` would offset the per-session counters a second time).
    for k, v in pending.get("values", {}).items():
        logger.name_to_value[k] = v
        logger.name_to_count[k] = pending.get("counts", {}).get(k, 1)
        excluded = pending.get("excluded", {}).get(k)
        logger.name_to_excluded[k] = tuple(excluded) if isinstance(excluded, list) else excluded


def adopt_summary_writer(output: TensorBoardOutputFormat, writer) -> None:
    """Makes `output` (whose constructor was not run) write through `writer`."""
    output.writer = writer
    output._is_closed = False


# -- the evaluation callback ------------------------------------------------------------------


def set_call_count(callback: EvalCallback, n_calls: int) -> None:
    callback.n_calls = n_calls


def evaluation_lists(callback: EvalCallback) -> dict:
    """The evaluations so far, as EvalCallback keeps them (the arrays of evaluations.npz)."""
    return {
        "timesteps": callback.evaluations_timesteps,
        "results": callback.evaluations_results,
        "ep_lengths": callback.evaluations_length,
        "successes": callback.evaluations_successes,
    }


def evaluation_history(callback: EvalCallback) -> dict:
    """The evaluations so far, as JSON."""
    lists = evaluation_lists(callback)
    return {
        "timesteps": [int(t) for t in lists["timesteps"]],
        "results": [[float(r) for r in rs] for rs in lists["results"]],
        "ep_lengths": [[int(n) for n in ns] for ns in lists["ep_lengths"]],
        "successes": [[bool(x) for x in xs] for xs in lists["successes"]],
    }


def mean_rewards(callback: EvalCallback) -> tuple[float | None, float | None]:
    """The best and the last mean reward of the evaluations so far (None before the first)."""

    def finite(x):
        return float(x) if np.isfinite(x) else None

    return finite(callback.best_mean_reward), finite(callback.last_mean_reward)


def restore_evaluation_history(callback: EvalCallback, evaluations: dict, best, last) -> None:
    """Puts back what `evaluation_history` and `mean_rewards` returned."""
    callback.evaluations_timesteps = list(evaluations.get("timesteps", []))
    callback.evaluations_results = [list(r) for r in evaluations.get("results", [])]
    callback.evaluations_length = [list(n) for n in evaluations.get("ep_lengths", [])]
    callback.evaluations_successes = [list(s) for s in evaluations.get("successes", [])]
    callback.best_mean_reward = -np.inf if best is None else float(best)
    callback.last_mean_reward = -np.inf if last is None else float(last)
