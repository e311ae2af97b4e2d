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
replay buffer as `.npz`, and a copy of `best/` as it was (`learning.checkpoint`).

**Resume** rebuilds the model from the configuration and the checkpoint, then puts the run's
history back as it was at the checkpoint: the rows of `progress.csv` and the evaluations after
it are dropped (and TensorBoard's events after it purged), the best reward so far and the
`best/` policy are those of the kept evaluations, pending log values, episode statistics,
iteration count and wall time carry on, and the random generators continue. Only the work
after the last checkpoint (at most one interval) is done again. Each evaluation runs the same
seeded episodes, so evaluations are comparable across a run and across a resume.

Here: the training loop and its callbacks. The logs: `learning.run_log`. SB3's state that
a resume restores beyond its public API: `learning.sb3_state`. Policy directories:
`learning.policy_dir`. Hyperparameters: `learning.config`. The `drake-tooluse train` command
(and each sweep cell) runs torch single-threaded: the env processes are the parallelism; a
caller of `train` from Python chooses for its own process.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import io
import shutil
import signal
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor, VecNormalize

from drake_tooluse.files import (
    atomic_dir,
    atomic_write_bytes,
    atomic_write_json,
    discard_dir,
    recover_dir,
    remove_orphans,
    run_lock,
)
from drake_tooluse.learning.checkpoint import (
    CHECKPOINTS,
    LEGACY_CHECKPOINT,
    checkpoint_dirs,
    latest_checkpoint,
    restore_checkpoint,
    write_checkpoint,
)
from drake_tooluse.learning.config import (
    OFF_POLICY,
    RUN_CONFIG,
    RUN_KEYS,
    TrainConfig,
    check_hyperparams,
    config_differences,
    read_run_config,
    write_run_config,
)
from drake_tooluse.learning.policy_dir import (
    PolicyMeta,
    algorithm_class,
    check_policy_spaces,
    load_policy,
    save_policy,
)
from drake_tooluse.learning.run_log import open_run_logger
from drake_tooluse.learning.sb3_state import (
    evaluation_lists,
    mean_rewards,
    restore_evaluation_history,
    restore_pending_log_values,
    set_call_count,
)
from drake_tooluse.learning.task_envs import check_env_id, env_spaces, episode_metrics
from drake_tooluse.limits import MAX_N_ENVS, MAX_TIMESTEPS
from drake_tooluse.provenance import code_version
from drake_tooluse.validation import check_int, check_seed


def _make_env(env_id: str, env_kwargs: dict, worker: bool = False):
    def thunk():
        if worker:  # (the thunk runs in a SubprocVecEnv's env process)
            # Ctrl-C reaches the whole process group: the training process stops the run and
            # then closes its env processes, which must still be there to answer it.
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        # A fresh worker process knows the package's ids (this module imported it) and, once
        # asked for the ids, the task modules of DRAKE_TOOLUSE_TASKS.
        return gym.make(check_env_id(env_id), **env_kwargs)

    return thunk


def close_envs(venv, timeout_s: float = 10.0) -> None:
    """Closes a vectorized env, its env processes joined, in bounded time whatever interrupted
    it. SubprocVecEnv's own close first reads every pending step result: after a Ctrl-C that
    landed between two of step_wait's reads, the first env process has nothing more to send
    and that read waits forever. Here each env process is told to close (one mid-step sends
    its result first, into the pipe, and then reads the close), and those still running after
    `timeout_s` are terminated."""
    vec = venv.unwrapped
    if isinstance(vec, SubprocVecEnv) and not vec.closed:
        for remote in vec.remotes:
            try:
                remote.send(("close", None))
            except (BrokenPipeError, ConnectionResetError, EOFError, OSError):
                pass  # (that process is gone already: killed, crashed)
        deadline = time.monotonic() + timeout_s
        for process in vec.processes:
            process.join(timeout=max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.terminate()
                process.join(timeout=5)
        for remote in vec.remotes:
            remote.close()
        vec.closed = True
    venv.close()  # (the wrappers' own: VecMonitor's file; the processes' part is done)


def make_vec_env(env_id: str, n_envs: int, seed: int, env_kwargs: dict):
    fns = [_make_env(env_id, env_kwargs, worker=n_envs > 1) for _ in range(n_envs)]
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


# -- callbacks --------------------------------------------------------------------------------


class _Run(BaseCallback):
    """Writes the run's checkpoints at rollout boundaries, and counts rollouts and wall time.

    Not SB3's CheckpointCallback: that one saves every n calls, mid-rollout, with `model.save`
    (a zip with pickles) and without the logs' and evaluations' state a resume needs.
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
        write_checkpoint(
            self.out,
            self.model,
            self.vec_normalize,
            self.eval_callback,
            iterations=self.iterations,
            wall_time_s=self.wall(),
            resumes=self.resumes,
        )
        self.last_saved = int(self.model.num_timesteps)
        if self.on_checkpoint is not None:
            self.on_checkpoint(self.out)


class _Evaluation(EvalCallback):
    """SB3's EvalCallback, due by the run's step count (not by this session's calls, which
    restart on a resume), each evaluation on the same seeded episodes, `evaluations.npz`
    rewritten atomically after each one."""

    def __init__(self, *args, eval_seed: int, **kwargs):
        super().__init__(*args, **kwargs)
        self.eval_seed = eval_seed

    def _on_step(self) -> bool:
        set_call_count(self, self.num_timesteps // self.model.n_envs)
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
        lists = evaluation_lists(self)
        extra = {"successes": lists["successes"]} if lists["successes"] else {}
        buffer = _npz(
            timesteps=lists["timesteps"],
            results=lists["results"],
            ep_lengths=lists["ep_lengths"],
            **extra,
        )
        atomic_write_bytes(self.log_path + ".npz", buffer)

    def restore(self, evaluations: dict, best, last) -> None:
        restore_evaluation_history(self, evaluations, best, last)


class _SaveBest(BaseCallback):
    """Saves the policy as `folder` (a policy directory) at each new best evaluation (the
    evaluation callback is its parent)."""

    def __init__(self, meta: PolicyMeta, vec_normalize, folder: Path):
        super().__init__()
        self.meta, self.vec_normalize, self.folder = meta, vec_normalize, folder

    def _on_step(self) -> bool:
        best_mean_reward, _ = mean_rewards(self.parent)
        best = dataclasses.replace(
            self.meta,
            trained_timesteps=int(self.model.num_timesteps),
            evaluation={
                "timesteps": int(self.model.num_timesteps),
                "mean_reward": best_mean_reward,
                "episodes": int(self.parent.n_eval_episodes),
            },
        )
        save_policy(self.model, self.vec_normalize, best, self.folder)
        return True


def _npz(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


# -- the run ------------------------------------------------------------------------------


def check_train_config(config: TrainConfig) -> None:
    """Every setting of a run, checked before anything is written or started."""
    check_int(config.timesteps, 1, MAX_TIMESTEPS, "timesteps")
    check_int(config.n_envs, 1, MAX_N_ENVS, "n_envs")
    check_seed(config.seed, "seed")
    check_hyperparams(config.algo, config.env_id, config.hyperparams)


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


def _open_run(out: Path, config: TrainConfig, resume: bool, command: str):
    """(the checkpoint to resume from or None, the run's first command), once what a killed
    session was writing is cleaned away; refuses a resume with other settings, and a new run
    into a directory that holds one."""
    for folder in (out, out / CHECKPOINTS, out / "logs", out / "eval"):
        remove_orphans(folder)  # what a killed session was writing
    for name in ("best", "final"):
        recover_dir(out / name)
    if not resume:
        if (out / RUN_CONFIG).exists() and _started(out):
            raise FileExistsError(
                f"{str(out)!r} already holds a run; resume it (resume=True) or give a new directory"
            )
        return None, command
    saved, first_command = read_run_config(out / RUN_CONFIG)
    differences = config_differences(saved.comparable(), config.comparable())
    if differences:
        raise ValueError(
            f"refusing to resume {str(out)!r} with different settings: " + "; ".join(differences)
        )
    checkpoint = latest_checkpoint(out)
    if checkpoint is None and (out / LEGACY_CHECKPOINT).is_file():
        raise ValueError(
            f"{str(out)!r} was checkpointed by an earlier drake-tooluse, in a format "
            "with pickles that this version does not load; start a new run (convert its "
            "policies with `drake-tooluse convert-policy`)"
        )
    return checkpoint, first_command


def _make_envs(config: TrainConfig, env_kwargs: dict, normalize: bool, stack):
    """The training and the evaluation envs (closed by `stack`)."""
    venv = make_vec_env(config.env_id, config.n_envs, config.seed, env_kwargs)
    stack.callback(close_envs, venv)
    eval_env = make_vec_env(config.env_id, 1, config.seed + 10_000, env_kwargs)
    stack.callback(close_envs, eval_env)
    if normalize:
        gamma = float(config.hyperparams.get("gamma", 0.99))
        venv = VecNormalize(venv, norm_obs=True, norm_reward=True, gamma=gamma)
        eval_env = VecNormalize(eval_env, norm_obs=True, norm_reward=False, training=False)
    return venv, eval_env


def _resume_history(out: Path, evaluation, checkpoint, state: dict, csv_out, command) -> None:
    """Puts the evaluations and `best/` back as they were at the checkpoint, and records this
    session in `state["resumes"]`."""
    folder, steps = checkpoint[0], int(state["timesteps"])
    evaluation.restore(
        state.get("evaluations", {}), state.get("best_mean_reward"), state.get("last_mean_reward")
    )
    (out / "eval").mkdir(exist_ok=True)
    evaluation.write()
    discard_dir(out / "best")
    if (folder / "best").is_dir():
        with atomic_dir(out / "best") as tmp:
            shutil.copytree(folder / "best", tmp, dirs_exist_ok=True)
    discarded = csv_out.dropped_until
    state.setdefault("resumes", []).append(
        {
            "from_timesteps": steps,
            "redone_timesteps": max(discarded - steps, 0) if discarded else None,
            "command": command,
        }
    )


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
    if resume and not (out / RUN_CONFIG).is_file():
        raise FileNotFoundError(f"nothing to resume in {str(out)!r}: it has no config.json")
    with run_lock(out), contextlib.ExitStack() as stack:
        checkpoint, first_command = _open_run(out, config, resume, command)
        init = None
        if config.init_from and checkpoint is None:
            init = load_policy(config.init_from, trust_pickle=trust_pickle)
            check_policy_spaces(
                init,
                *env_spaces(config.env_id, env_kwargs),
                f"init_from (--init-from) {config.init_from!r}",
            )

        normalize = bool(hp.get("normalize", True))
        venv, eval_env = _make_envs(config, env_kwargs, normalize, stack)
        vec_normalize = venv if normalize else None
        model = _build_model(config, venv)
        state = {}
        if checkpoint is not None:
            state = restore_checkpoint(model, vec_normalize, *checkpoint)
            venv.seed(_resume_seed(config.seed, state["timesteps"]))
        else:
            _clear_unstarted(out)
            if init is not None:
                _set_initial_policy(model, init, config)
                if normalize and init.obs_rms is not None:
                    venv.obs_rms = init.obs_rms
        write_run_config(out, config, first_command)
        steps = int(state.get("timesteps", 0))
        resumed = checkpoint is not None

        logger, csv_out = open_run_logger(
            out / "logs",
            resume_from=steps if resumed else None,
            iterations=int(state.get("iterations", 0)),
            wall_time_s=float(state.get("wall_time_s", 0.0)),
        )
        restore_pending_log_values(logger, state.get("logger", {}))
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
        evaluation = _Evaluation(
            eval_env,
            callback_on_new_best=_SaveBest(meta, vec_normalize, out / "best"),
            n_eval_episodes=int(hp.get("eval_episodes", 20)),
            eval_freq=max(int(hp.get("eval_freq", 50_000)) // config.n_envs, 1),
            log_path=str(out / "eval"),
            deterministic=True,
            verbose=0,
            eval_seed=config.seed + 10_000,
        )
        if resumed:
            _resume_history(out, evaluation, checkpoint, state, csv_out, command)
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
            # the code of the session that finished it (a resumed run's sessions may differ)
            "code": code_version(),
            **_best_source(evaluation),
        }
        atomic_write_json(out / "summary.json", summary)
    return summary


def _best_source(evaluation: EvalCallback) -> dict:
    """Where `best/` came from: the run's evaluations (how many, and the best's mean reward and
    step), or, where none ran, the final policy."""
    steps = list(evaluation.evaluations_timesteps)
    if not steps:
        return {"evaluations": 0, "best": None}
    means = [float(np.mean(r)) for r in evaluation.evaluations_results]
    i = int(np.argmax(means))
    return {"evaluations": len(steps), "best": {"mean_reward": means[i], "step": int(steps[i])}}


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


__all__ = [
    "OFF_POLICY",
    "TrainConfig",
    "check_train_config",
    "checkpoint_dirs",
    "latest_checkpoint",
    "make_vec_env",
    "train",
]
