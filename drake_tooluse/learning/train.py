"""Training with stable-baselines3 (TRPO from sb3-contrib) through the Gymnasium envs; a run
killed at any moment resumes with the history of one that never was.

A run directory holds everything a run needs and makes:

```
OUT/config.json                     what was asked for, resolved, and the command that asked
OUT/checkpoints/ckpt-<steps>/       the latest checkpoint (one directory, complete or absent)
OUT/checkpoints/latest.json         which one it is
OUT/best/                           the best policy by periodic evaluation (a policy directory)
OUT/final/                          the policy at the end (a policy directory)
OUT/logs/                           progress.csv and TensorBoard events
OUT/eval/evaluations.npz            every periodic evaluation (SB3's EvalCallback format)
OUT/summary.json                    steps, wall time over all sessions, resumes
```

**Checkpoints** are written at the first rollout boundary after every `checkpoint_freq`
steps, when the algorithm's state is clean (after an update, before the next rollout), each
into a new directory that appears complete in one rename; the previous one is removed after.
A kill at any moment leaves the newest complete checkpoint where `resume` looks, and the
temporary files of the killed process are deleted when the run resumes. A checkpoint holds
no pickle: the model's and optimisers' tensors (`parameters.pt`, read with
`torch.load(weights_only=True)`), the normalisation statistics and counters as JSON, the
replay buffer as `.npz`, and a copy of `best/` as it was.

**Resume** rebuilds the model from the configuration and the checkpoint, then puts the run's
history back as it was at the checkpoint: the rows of `progress.csv` and the evaluations after
it are dropped (and TensorBoard's events after it purged), the best reward so far and the
`best/` policy are those of the kept evaluations, pending log values, episode statistics,
iteration count and wall time carry on, and the random generators continue. Only the work
after the last checkpoint (at most one interval) is done again. Each evaluation runs the same
seeded episodes, so evaluations are comparable across a run and across a resume.

Policy directories: `learning.policy_dir`. Hyperparameters: `learning.config`. The
`drake-tooluse train` command (and each sweep cell) runs torch single-threaded: the env
processes are the parallelism; a caller of `train` from Python chooses for its own process.
"""

from __future__ import annotations

import contextlib
import copy
import csv
import dataclasses
import io
import json
import random
import re
import shutil
import time
from collections import deque
from dataclasses import asdict
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
from stable_baselines3.common.logger import (
    CSVOutputFormat,
    Logger,
    TensorBoardOutputFormat,
    filter_excluded_keys,
)
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor, VecNormalize
from torch.utils.tensorboard import SummaryWriter

from drake_tooluse.files import (
    atomic_dir,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    discard_dir,
    recover_dir,
    remove_orphans,
    run_lock,
    to_json,
)
from drake_tooluse.learning.config import (
    OFF_POLICY,
    RUN_KEYS,
    TrainConfig,
    check_hyperparams,
    config_differences,
)
from drake_tooluse.learning.policy_dir import (
    PolicyMeta,
    algorithm_class,
    check_policy_spaces,
    load_policy,
    save_policy,
)
from drake_tooluse.learning.task_envs import env_spaces, episode_metrics
from drake_tooluse.validation import check_int, check_seed

CHECKPOINTS = "checkpoints"
_CKPT = re.compile(r"^ckpt-(\d{12})$")
CHECKPOINT_FORMAT = 1
STEPS_KEY = "time/total_timesteps"  # every row SB3 dumps has it


def _make_env(env_id: str, env_kwargs: dict):
    def thunk():
        # "module:id": a fresh worker process imports the package and its registrations.
        return gym.make(f"drake_tooluse:{env_id}", **env_kwargs)

    return thunk


def make_vec_env(env_id: str, n_envs: int, seed: int, env_kwargs: dict):
    fns = [_make_env(env_id, env_kwargs) for _ in range(n_envs)]
    vec = SubprocVecEnv(fns) if n_envs > 1 else DummyVecEnv(fns)
    vec.seed(seed)
    # Each finished episode's success and the task's headline figure (the push task: the
    # box-goal distance) go into its "episode" info.
    headline = episode_metrics(env_id)[0].info_key
    return VecMonitor(vec, info_keywords=("is_success", headline))


def _algo_kwargs(config: TrainConfig, action_dim: int) -> dict:
    # A copy: SB3 writes into policy_kwargs (A2C adds its optimiser class).
    kwargs = copy.deepcopy({k: v for k, v in config.hyperparams.items() if k not in RUN_KEYS})
    if config.algo == "ddpg":
        std = float(config.hyperparams.get("noise_std", 0.1))
        kwargs["action_noise"] = NormalActionNoise(np.zeros(action_dim), std * np.ones(action_dim))
    return kwargs


def _resume_seed(seed: int, timesteps: int) -> int:
    """The envs' seed for a session that starts at `timesteps` (its own stream, not a replay of
    the first session's episodes)."""
    if timesteps == 0:
        return seed
    return int(np.random.SeedSequence([seed, timesteps]).generate_state(1)[0])


# -- logs -----------------------------------------------------------------------------------


def _kept_rows(path: Path, until: int) -> tuple[list[str], list[str], int | None]:
    """The header and the complete rows of an SB3 progress.csv up to `until` steps (a row cut
    by a kill is dropped), and the most steps a dropped row reached."""
    lines = path.read_text().splitlines(keepends=True)
    if not lines or not lines[0].endswith("\n"):
        return [], [], None
    header = next(csv.reader([lines[0]]))
    column = header.index(STEPS_KEY) if STEPS_KEY in header else None
    kept, dropped = [], None
    for line in lines[1:]:
        fields = next(csv.reader([line]), [])
        ok = line.endswith("\n") and len(fields) == len(header) and column is not None
        try:
            steps = int(float(fields[column])) if ok else None
        except ValueError:
            steps = None
        if steps is not None and steps <= until and dropped is None:
            kept.append(line)
        elif steps is not None:
            dropped = max(dropped or steps, steps)
    return header, kept, dropped


class _CSV(CSVOutputFormat):
    """SB3's CSV output, resumable and safe to kill: it appends to the rows kept at the
    checkpoint (`keep_until` steps) and, when new columns appear, rewrites the file atomically
    (SB3's rewrites it in place)."""

    def __init__(self, path: Path, keep_until: int | None):
        self.path = Path(path)
        self.separator, self.quotechar = ",", '"'
        self.keys: list[str] = []
        self.dropped_until = None
        rows = []
        if keep_until is not None and self.path.is_file():
            self.keys, rows, self.dropped_until = _kept_rows(self.path, keep_until)
        self._rewrite(rows)
        self.file = open(self.path, "a+")

    def _rewrite(self, rows: list[str]) -> None:
        header = ",".join(self.keys) + "\n" if self.keys else ""
        atomic_write_text(self.path, header + "".join(rows))

    def write(self, key_values, key_excluded, step: int = 0) -> None:
        extra = [
            k for k in filter_excluded_keys(key_values, key_excluded, "csv") if k not in self.keys
        ]
        if extra:
            self.file.close()
            old = self.path.read_text().splitlines(keepends=True)[1:]
            rows = [line[:-1] + self.separator * len(extra) + "\n" for line in old]
            self.keys.extend(extra)
            self._rewrite(rows)
            self.file = open(self.path, "a+")
        super().write(key_values, key_excluded, step)


class _TensorBoard(TensorBoardOutputFormat):
    """SB3's TensorBoard output; on a resume its writer purges the events after the checkpoint
    (`SummaryWriter(purge_step=...)`: TensorBoard hides the killed session's later events)."""

    def __init__(self, folder: str, purge_step: int | None):
        self.writer = SummaryWriter(log_dir=folder, purge_step=purge_step)
        self._is_closed = False


class _RunLogger(Logger):
    """SB3's logger, with the counters it restarts per session continued: `time/iterations`
    and `time/time_elapsed` are offset by their values at the checkpoint."""

    def __init__(self, folder: str, output_formats, offsets: dict):
        super().__init__(folder, output_formats)
        self.offsets = offsets

    def dump(self, step: int = 0) -> None:
        for key, offset in self.offsets.items():
            if key in self.name_to_value:
                self.name_to_value[key] += offset
        super().dump(step)

    def pending(self) -> dict:
        """The values recorded and not yet written (they go with the next row)."""

        def plain(v):
            return v.item() if hasattr(v, "item") else v

        values = {
            k: plain(v)
            for k, v in self.name_to_value.items()
            if isinstance(plain(v), (int, float)) and not isinstance(plain(v), bool)
        }
        return {
            "values": values,
            "counts": {k: int(self.name_to_count[k]) for k in values},
            "excluded": {
                k: list(e) if isinstance(e, (list, tuple)) else e
                for k, e in self.name_to_excluded.items()
                if k in values
            },
        }

    def restore_pending(self, pending: dict) -> None:
        for k, v in pending.get("values", {}).items():
            self.name_to_value[k] = v
            self.name_to_count[k] = pending.get("counts", {}).get(k, 1)
            excluded = pending.get("excluded", {}).get(k)
            self.name_to_excluded[k] = tuple(excluded) if isinstance(excluded, list) else excluded


# -- checkpoints ----------------------------------------------------------------------------


def checkpoint_dirs(out) -> list[Path]:
    """The run's complete checkpoints, oldest first (a directory appears only when whole)."""
    folder = Path(out) / CHECKPOINTS
    if not folder.is_dir():
        return []
    found = [p for p in folder.iterdir() if p.is_dir() and _CKPT.match(p.name)]
    return sorted(found, key=lambda p: int(_CKPT.match(p.name)[1]))


def latest_checkpoint(out) -> tuple[Path, dict] | None:
    """(directory, its checkpoint.json) of the run's newest checkpoint, or None."""
    dirs = checkpoint_dirs(out)
    if not dirs:
        return None
    path = dirs[-1] / "checkpoint.json"
    try:
        state = json.loads(path.read_text())
        check_int(state["timesteps"], 0, 10**12, "timesteps")
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(
            f"corrupt checkpoint {str(path)!r}: {e}; remove {str(dirs[-1])!r} to resume from "
            "an older one, if any, or start a new run"
        ) from None
    return dirs[-1], state


def _vecnormalize_state(venv: VecNormalize) -> dict:
    return {
        "obs_mean": venv.obs_rms.mean.tolist(),
        "obs_var": venv.obs_rms.var.tolist(),
        "obs_count": float(venv.obs_rms.count),
        "ret_mean": float(np.asarray(venv.ret_rms.mean)),
        "ret_var": float(np.asarray(venv.ret_rms.var)),
        "ret_count": float(venv.ret_rms.count),
        "clip_obs": venv.clip_obs,
        "clip_reward": venv.clip_reward,
        "gamma": venv.gamma,
        "epsilon": venv.epsilon,
    }


def _restore_vecnormalize(venv: VecNormalize, state: dict, path: Path) -> None:
    mean = np.asarray(state["obs_mean"], float)
    if mean.shape != venv.obs_rms.mean.shape:
        raise ValueError(
            f"{str(path)!r} normalises {list(mean.shape)} values; the env observes "
            f"{list(venv.obs_rms.mean.shape)}"
        )
    venv.obs_rms.mean, venv.obs_rms.var = mean, np.asarray(state["obs_var"], float)
    venv.obs_rms.count = float(state["obs_count"])
    venv.ret_rms.mean = np.asarray(state["ret_mean"], float)
    venv.ret_rms.var = np.asarray(state["ret_var"], float)
    venv.ret_rms.count = float(state["ret_count"])


_BUFFER_ARRAYS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def _save_replay_buffer(buffer, path: Path) -> None:
    size = buffer.buffer_size if buffer.full else buffer.pos
    arrays = {
        name: getattr(buffer, name)[:size]
        for name in _BUFFER_ARRAYS
        if getattr(buffer, name, None) is not None
    }
    np.savez(path, pos=buffer.pos, full=buffer.full, **arrays)


def _restore_replay_buffer(buffer, path: Path) -> None:
    with np.load(path, allow_pickle=False) as data:
        for name in _BUFFER_ARRAYS:
            if name in data and getattr(buffer, name, None) is not None:
                target = getattr(buffer, name)
                saved = data[name]
                if saved.shape[1:] != target.shape[1:] or len(saved) > len(target):
                    raise ValueError(
                        f"{str(path)!r}: {name} {list(saved.shape)} does not fit the replay "
                        f"buffer {list(target.shape)} (was buffer_size changed?)"
                    )
                target[: len(saved)] = saved
        buffer.pos, buffer.full = int(data["pos"]), bool(data["full"])


class _Run(BaseCallback):
    """Writes the run's checkpoints at rollout boundaries, and counts rollouts and wall time.

    The evaluation callback (`eval_callback`) and the best policy's directory are part of what
    a checkpoint keeps."""

    def __init__(
        self, out: Path, every: int, vec_normalize, eval_callback, state: dict, on_checkpoint
    ):
        super().__init__()
        self.out, self.every, self.on_checkpoint = out, every, on_checkpoint
        self.vec_normalize, self.eval_callback = vec_normalize, eval_callback
        self.iterations = int(state.get("iterations", 0))
        self.wall_before = float(state.get("wall_time_s", 0.0))
        self.resumes = list(state.get("resumes", []))
        self.last_saved = int(state.get("timesteps", 0))
        self.started = time.perf_counter()

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.started

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.iterations += 1

    def _on_rollout_start(self) -> None:
        if self.num_timesteps // self.every > self.last_saved // self.every:
            self.save()

    def save(self) -> None:
        model, steps = self.model, int(self.model.num_timesteps)
        folder = self.out / CHECKPOINTS
        ev = self.eval_callback
        state = {
            "format": CHECKPOINT_FORMAT,
            "timesteps": steps,
            "n_updates": int(getattr(model, "_n_updates", 0)),
            "episode_num": int(model._episode_num),
            "iterations": self.iterations,
            "wall_time_s": self.wall(),
            "resumes": self.resumes,
            "ep_info_buffer": [
                {k: float(v) for k, v in e.items()} for e in (model.ep_info_buffer or [])
            ],
            "ep_success_buffer": [bool(x) for x in (model.ep_success_buffer or [])],
            "logger": model.logger.pending() if isinstance(model.logger, _RunLogger) else {},
            "evaluations": {
                "timesteps": [int(t) for t in ev.evaluations_timesteps],
                "results": [[float(r) for r in rs] for rs in ev.evaluations_results],
                "ep_lengths": [[int(n) for n in ns] for ns in ev.evaluations_length],
                "successes": [[bool(x) for x in xs] for xs in ev.evaluations_successes],
            },
            "best_mean_reward": (
                float(ev.best_mean_reward) if np.isfinite(ev.best_mean_reward) else None
            ),
            "last_mean_reward": (
                float(ev.last_mean_reward) if np.isfinite(ev.last_mean_reward) else None
            ),
            "numpy_random": _numpy_state(),
            "python_random": _python_state(),
        }
        name = f"ckpt-{steps:012d}"
        with atomic_dir(folder / name, replace=True) as tmp:
            torch.save(
                {"parameters": model.get_parameters(), "torch_rng": torch.get_rng_state()},
                tmp / "parameters.pt",
            )
            if self.vec_normalize is not None:
                (tmp / "vecnormalize.json").write_text(
                    to_json(_vecnormalize_state(self.vec_normalize))
                )
            if getattr(model, "replay_buffer", None) is not None:
                _save_replay_buffer(model.replay_buffer, tmp / "replay_buffer.npz")
            if (self.out / "best").is_dir():
                shutil.copytree(self.out / "best", tmp / "best")
            (tmp / "checkpoint.json").write_text(to_json(state) + "\n")
        atomic_write_json(folder / "latest.json", {"timesteps": steps, "checkpoint": name})
        for old in checkpoint_dirs(self.out)[:-1]:
            discard_dir(old)
        self.last_saved = steps
        if self.on_checkpoint is not None:
            self.on_checkpoint(self.out)


def _numpy_state() -> list:
    kind, keys, pos, has_gauss, gauss = np.random.get_state()
    return [kind, keys.tolist(), int(pos), int(has_gauss), float(gauss)]


def _python_state() -> list:
    version, internal, gauss = random.getstate()
    return [version, list(internal), gauss]


def _restore_random(state: dict, parameters: dict) -> None:
    if "torch_rng" in parameters:
        torch.set_rng_state(parameters["torch_rng"])
    if state.get("numpy_random"):
        kind, keys, pos, has_gauss, gauss = state["numpy_random"]
        np.random.set_state((kind, np.asarray(keys, np.uint32), pos, has_gauss, gauss))
    if state.get("python_random"):
        version, internal, gauss = state["python_random"]
        random.setstate((version, tuple(internal), gauss))


class _Evaluation(EvalCallback):
    """SB3's EvalCallback, due by the run's step count (not by this session's calls, which
    restart on a resume), each evaluation on the same seeded episodes, `evaluations.npz`
    rewritten atomically after each one."""

    def __init__(self, *args, eval_seed: int, **kwargs):
        super().__init__(*args, **kwargs)
        self.eval_seed = eval_seed

    def _on_step(self) -> bool:
        self.n_calls = self.num_timesteps // self.model.n_envs
        due = self.eval_freq > 0 and self.n_calls % self.eval_freq == 0
        if due:
            self.eval_env.seed(self.eval_seed)
        result = super()._on_step()
        if due:
            self.write()
        return result

    def write(self) -> None:
        if self.log_path is None:
            return
        extra = {"successes": self.evaluations_successes} if self.evaluations_successes else {}
        buffer = _npz(
            timesteps=self.evaluations_timesteps,
            results=self.evaluations_results,
            ep_lengths=self.evaluations_length,
            **extra,
        )
        atomic_write_bytes(self.log_path + ".npz", buffer)

    def restore(self, evaluations: dict, best, last) -> None:
        self.evaluations_timesteps = list(evaluations.get("timesteps", []))
        self.evaluations_results = [list(r) for r in evaluations.get("results", [])]
        self.evaluations_length = [list(n) for n in evaluations.get("ep_lengths", [])]
        self.evaluations_successes = [list(s) for s in evaluations.get("successes", [])]
        self.best_mean_reward = -np.inf if best is None else float(best)
        self.last_mean_reward = -np.inf if last is None else float(last)


def _npz(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


# -- the run ------------------------------------------------------------------------------


def _read_config(out: Path) -> tuple[TrainConfig, str]:
    path = out / "config.json"
    try:
        raw = json.loads(path.read_text())
        command = raw.pop("command", "")
        return TrainConfig(**raw), command
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, TypeError, AttributeError) as e:
        raise ValueError(f"corrupt run configuration {str(path)!r}: {e}") from None


def check_train_config(config: TrainConfig) -> None:
    """Every setting of a run, checked before anything is written or started."""
    check_int(config.timesteps, 1, 10**10, "timesteps")
    check_int(config.n_envs, 1, 64, "n_envs")
    check_seed(config.seed, "seed")
    check_hyperparams(config.algo, config.env_id, config.hyperparams)


LEGACY_CHECKPOINT = Path(CHECKPOINTS) / "latest.zip"  # before this format: SB3 zip + pickles


def _started(out: Path) -> bool:
    return (
        bool(checkpoint_dirs(out))
        or (out / "final").is_dir()
        or (out / LEGACY_CHECKPOINT).is_file()
    )


def _clear_unstarted(out: Path) -> None:
    """What a run that never reached a checkpoint left: it is started over."""
    for name in ("best", "final", "eval"):
        discard_dir(out / name)
    for events in (out / "logs").glob("events.out.tfevents.*"):
        events.unlink()
    (out / "summary.json").unlink(missing_ok=True)


def train(
    config: TrainConfig,
    out: Path,
    *,
    resume: bool = False,
    progress_bar: bool = True,
    command: str = "",
    trust_pickle: bool = False,
    on_checkpoint=None,
) -> dict:
    """Trains (or resumes) a run in `out`; returns the summary. Everything is checked before
    anything is written: a run that fails to start leaves no `config.json` (the directory can
    be given again). A run with `config.json` but no checkpoint yet (it failed or was killed
    early) resumes from the start, or is started over by a new `train` into it.
    `trust_pickle` lets `init_from` name a policy directory of the older pickle format.
    `on_checkpoint(out)` is called after each checkpoint is complete (a sweep cell sends the
    run directory to the driver's disk then)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"the run directory {str(out)!r} is a file; give a directory")
    check_train_config(config)
    hp = config.hyperparams
    env_kwargs = dict(hp.get("env_kwargs", {}))
    if resume and not (out / "config.json").is_file():
        raise FileNotFoundError(f"nothing to resume in {str(out)!r}: it has no config.json")
    with run_lock(out), contextlib.ExitStack() as stack:
        for folder in (out, out / CHECKPOINTS, out / "logs", out / "eval"):
            remove_orphans(folder)  # what a killed session was writing
        for name in ("best", "final"):
            recover_dir(out / name)
        checkpoint, first_command = None, command
        if resume:
            saved, first_command = _read_config(out)
            differences = config_differences(saved.comparable(), config.comparable())
            if differences:
                raise ValueError(
                    f"refusing to resume {str(out)!r} with different settings: "
                    + "; ".join(differences)
                )
            checkpoint = latest_checkpoint(out)
            if checkpoint is None and (out / LEGACY_CHECKPOINT).is_file():
                raise ValueError(
                    f"{str(out)!r} was checkpointed by an earlier drake-tooluse, in a format "
                    "with pickles that this version does not load; start a new run (convert its "
                    "policies with `drake-tooluse convert-policy`)"
                )
        elif (out / "config.json").exists() and _started(out):
            raise FileExistsError(
                f"{str(out)!r} already holds a run; resume it (resume=True) or give a new directory"
            )
        init = None
        if config.init_from and checkpoint is None:
            init = load_policy(config.init_from, trust_pickle=trust_pickle)
            check_policy_spaces(
                init,
                *env_spaces(config.env_id, env_kwargs),
                f"init_from (--init-from) {config.init_from!r}",
            )

        venv = make_vec_env(config.env_id, config.n_envs, config.seed, env_kwargs)
        stack.callback(venv.close)
        eval_env = make_vec_env(config.env_id, 1, config.seed + 10_000, env_kwargs)
        stack.callback(eval_env.close)
        normalize = bool(hp.get("normalize", True))
        if normalize:
            venv = VecNormalize(
                venv, norm_obs=True, norm_reward=True, gamma=float(hp.get("gamma", 0.99))
            )
            eval_env = VecNormalize(eval_env, norm_obs=True, norm_reward=False, training=False)
        model = _build_model(config, venv)
        state = {}
        if checkpoint is not None:
            state = _restore(model, venv if normalize else None, *checkpoint)
            venv.seed(_resume_seed(config.seed, state["timesteps"]))
        else:
            _clear_unstarted(out)
            if init is not None:
                _set_initial_policy(model, init, config)
                if normalize and init.obs_rms is not None:
                    venv.obs_rms = init.obs_rms
        saved_config = {**asdict(config), "command": first_command}
        atomic_write_json(out / "config.json", saved_config)
        steps = int(state.get("timesteps", 0))

        logs = out / "logs"
        logs.mkdir(parents=True, exist_ok=True)
        resumed = checkpoint is not None
        csv_out = _CSV(logs / "progress.csv", keep_until=steps if resumed else None)
        logger = _RunLogger(
            str(logs),
            [csv_out, _TensorBoard(str(logs), purge_step=steps + 1 if resumed else None)],
            offsets={
                "time/iterations": int(state.get("iterations", 0)),
                "time/time_elapsed": int(state.get("wall_time_s", 0.0)),
            },
        )
        logger.restore_pending(state.get("logger", {}))
        model.set_logger(logger)
        stack.callback(logger.close)

        meta = PolicyMeta(
            config.env_id,
            config.algo,
            env_kwargs,
            list(venv.observation_space.shape),
            list(venv.action_space.shape),
            normalize,
            command=first_command,
            policy=hp.get("policy", "MlpPolicy"),
            policy_kwargs=dict(hp.get("policy_kwargs", {})),
        )
        vec_normalize = venv if normalize else None

        class SaveBest(BaseCallback):
            def _on_step(self) -> bool:
                parent = self.parent
                best = dataclasses.replace(
                    meta,
                    trained_timesteps=int(self.model.num_timesteps),
                    evaluation={
                        "timesteps": int(self.model.num_timesteps),
                        "mean_reward": float(parent.best_mean_reward),
                        "episodes": int(parent.n_eval_episodes),
                    },
                )
                save_policy(self.model, vec_normalize, best, out / "best")
                return True

        evaluation = _Evaluation(
            eval_env,
            callback_on_new_best=SaveBest(),
            n_eval_episodes=int(hp.get("eval_episodes", 20)),
            eval_freq=max(int(hp.get("eval_freq", 50_000)) // config.n_envs, 1),
            log_path=str(out / "eval"),
            deterministic=True,
            verbose=0,
            eval_seed=config.seed + 10_000,
        )
        if resumed:
            evaluation.restore(
                state.get("evaluations", {}),
                state.get("best_mean_reward"),
                state.get("last_mean_reward"),
            )
            (out / "eval").mkdir(exist_ok=True)
            evaluation.write()
            discard_dir(out / "best")
            if (checkpoint[0] / "best").is_dir():
                with atomic_dir(out / "best") as tmp:
                    shutil.copytree(checkpoint[0] / "best", tmp, dirs_exist_ok=True)
            discarded = csv_out.dropped_until
            state.setdefault("resumes", []).append(
                {
                    "from_timesteps": steps,
                    "redone_timesteps": max(discarded - steps, 0) if discarded else None,
                    "command": command,
                }
            )
        every = int(hp.get("checkpoint_freq", 50_000))
        run = _Run(out, every, vec_normalize, evaluation, state, on_checkpoint)
        remaining = config.timesteps - steps
        if remaining > 0:
            model.learn(
                total_timesteps=remaining,
                callback=CallbackList([run, evaluation]),
                reset_num_timesteps=not resumed,
                progress_bar=progress_bar,
            )
        run.init_callback(model)  # (learn did, unless nothing was left to do)
        run.save()
        meta.trained_timesteps = int(model.num_timesteps)
        save_policy(model, vec_normalize, meta, out / "final")
        if not (out / "best").exists():
            save_policy(model, vec_normalize, meta, out / "best")
        wall = run.wall()
        summary = {
            "timesteps": int(model.num_timesteps),
            "wall_time_s": wall,
            "steps_per_s": model.num_timesteps / wall if wall > 0 else None,
            "sessions": len(run.resumes) + 1,
            "resumes": run.resumes,
            "command": first_command,
            "out": str(out),
        }
        atomic_write_json(out / "summary.json", summary)
    return summary


def _build_model(config: TrainConfig, venv):
    hp = config.hyperparams
    try:
        return algorithm_class(config.algo)(
            hp.get("policy", "MlpPolicy"),
            venv,
            seed=config.seed,
            device="cpu",
            verbose=0,
            **_algo_kwargs(config, venv.action_space.shape[0]),
        )
    except (TypeError, ValueError, AssertionError, KeyError) as e:
        # A hyperparameter value the algorithm does not take (SB3 asserts some of them).
        raise ValueError(f"bad hyperparameters for {config.algo}: {e}") from None


def _set_initial_policy(model, init, config: TrainConfig) -> None:
    """Fine-tuning starts from `init`'s policy weights (the optimiser starts afresh)."""
    ours, theirs = model.policy.state_dict(), init.model.policy.state_dict()
    wrong = [
        f"{k}: {list(theirs[k].shape) if k in theirs else 'missing'} vs {list(v.shape)}"
        for k, v in ours.items()
        if k not in theirs or theirs[k].shape != v.shape
    ]
    if wrong or set(theirs) - set(ours):
        raise ValueError(
            f"init_from (--init-from) {config.init_from!r} is a {init.meta.algo} policy whose "
            f"network does not fit this run's {config.algo} policy ({'; '.join(wrong[:3])}); "
            "give the same policy_kwargs"
        )
    model.policy.load_state_dict(theirs)


def _restore(model, vec_normalize, folder: Path, state: dict) -> dict:
    """Puts the checkpoint in `folder` into a freshly built `model` (and its VecNormalize)."""
    path = folder / "parameters.pt"
    try:
        saved = torch.load(path, map_location="cpu", weights_only=True)
        model.set_parameters(saved["parameters"], exact_match=True, device="cpu")
    except (OSError, RuntimeError, KeyError, ValueError) as e:
        raise ValueError(f"cannot restore the checkpoint {str(path)!r}: {e}") from None
    model.num_timesteps = int(state["timesteps"])
    model._n_updates = int(state.get("n_updates", 0))
    model._episode_num = int(state.get("episode_num", 0))
    window = model._stats_window_size
    model.ep_info_buffer = deque(state.get("ep_info_buffer", []), maxlen=window)
    model.ep_success_buffer = deque(state.get("ep_success_buffer", []), maxlen=window)
    if vec_normalize is not None:
        norm = folder / "vecnormalize.json"
        try:
            _restore_vecnormalize(vec_normalize, json.loads(norm.read_text()), norm)
        except (OSError, ValueError, KeyError) as e:
            raise ValueError(f"cannot restore the normalisation {str(norm)!r}: {e}") from None
    buffer = folder / "replay_buffer.npz"
    if getattr(model, "replay_buffer", None) is not None and buffer.is_file():
        _restore_replay_buffer(model.replay_buffer, buffer)
    _restore_random(state, saved)
    return state


__all__ = ["OFF_POLICY", "TrainConfig", "latest_checkpoint", "make_vec_env", "train"]
