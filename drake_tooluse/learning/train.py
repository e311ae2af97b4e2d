"""Training with stable-baselines3 (TRPO from sb3-contrib) through the Gymnasium envs.

A run directory holds everything a run needs and makes:

```
OUT/config.json                 what was asked for, resolved (env, algo, seed, hyperparameters)
OUT/checkpoints/latest.*        the latest checkpoint, written atomically every checkpoint interval
OUT/best/                       the best policy by periodic evaluation (a policy directory)
OUT/final/                      the policy at the end (a policy directory)
OUT/logs/                       progress.csv and TensorBoard events
OUT/summary.json                steps, wall time
```

Policy directories: `learning.policy_dir`. Hyperparameters: `learning.config`. The
`drake-tooluse train` command (and each sweep cell) runs torch single-threaded: the env
processes are the parallelism; a caller of `train` from Python chooses for its own process.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
from stable_baselines3.common.logger import configure
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor, VecNormalize

from drake_tooluse.files import atomic_dir, atomic_write_json
from drake_tooluse.learning.config import OFF_POLICY, RUN_KEYS, TrainConfig
from drake_tooluse.learning.policy_dir import PolicyMeta, algorithm_class, load_policy, save_policy


def _make_env(env_id: str, env_kwargs: dict):
    def thunk():
        # "module:id": a fresh worker process imports the package and its registrations.
        return gym.make(f"drake_tooluse:{env_id}", **env_kwargs)

    return thunk


def make_vec_env(env_id: str, n_envs: int, seed: int, env_kwargs: dict):
    fns = [_make_env(env_id, env_kwargs) for _ in range(n_envs)]
    vec = SubprocVecEnv(fns) if n_envs > 1 else DummyVecEnv(fns)
    vec.seed(seed)
    return VecMonitor(vec, info_keywords=("is_success", "box_to_goal"))


def _algo_kwargs(config: TrainConfig, action_dim: int) -> dict:
    kwargs = {k: v for k, v in config.hyperparams.items() if k not in RUN_KEYS}
    if config.algo == "ddpg":
        std = float(config.hyperparams.get("noise_std", 0.1))
        kwargs["action_noise"] = NormalActionNoise(np.zeros(action_dim), std * np.ones(action_dim))
    return kwargs


class _Checkpointer:
    """Writes the latest checkpoint (model, normalisation, replay buffer, step count)
    atomically: a run killed at any moment resumes from the last complete one."""

    def __init__(self, out: Path):
        self.dir = out / "checkpoints"

    def save(self, model, vec_normalize) -> None:
        with atomic_dir(self.dir, replace=True) as tmp:
            model.save(tmp / "latest.zip")
            if vec_normalize is not None:
                vec_normalize.save(str(tmp / "latest_vecnormalize.pkl"))
            if hasattr(model, "replay_buffer") and model.replay_buffer is not None:
                model.save_replay_buffer(tmp / "latest_replay_buffer.pkl")
            (tmp / "latest.json").write_text(json.dumps({"timesteps": int(model.num_timesteps)}))

    def exists(self) -> bool:
        return (self.dir / "latest.json").is_file()

    def timesteps(self) -> int:
        return int(json.loads((self.dir / "latest.json").read_text())["timesteps"])


def train(
    config: TrainConfig,
    out: Path,
    *,
    resume: bool = False,
    progress_bar: bool = True,
    command: str = "",
) -> dict:
    """Trains (or resumes) a run in `out`; returns the final evaluation figures."""
    out = Path(out)
    config_path = out / "config.json"
    checkpointer = _Checkpointer(out)
    if resume:
        if not config_path.is_file() or not checkpointer.exists():
            raise FileNotFoundError(
                f"nothing to resume in {str(out)!r}: it needs config.json "
                "and checkpoints/latest.json"
            )
        saved = TrainConfig(**json.loads(config_path.read_text()))
        if saved.comparable() != config.comparable():
            diff = {
                k: (saved.comparable()[k], config.comparable()[k])
                for k in config.comparable()
                if saved.comparable()[k] != config.comparable()[k]
            }
            raise ValueError(
                f"refusing to resume {str(out)!r} with different settings (saved, asked): {diff}"
            )
    elif config_path.exists():
        raise FileExistsError(f"{str(out)!r} already holds a run; use --resume or a new --out")
    atomic_write_json(config_path, asdict(config))

    hp = config.hyperparams
    env_kwargs = dict(hp.get("env_kwargs", {}))
    venv = make_vec_env(config.env_id, config.n_envs, config.seed, env_kwargs)
    eval_env = make_vec_env(config.env_id, 1, config.seed + 10_000, env_kwargs)
    normalize = bool(hp.get("normalize", True))
    algo_cls = algorithm_class(config.algo)
    if resume:
        if normalize:
            venv = VecNormalize.load(str(checkpointer.dir / "latest_vecnormalize.pkl"), venv)
        model = algo_cls.load(checkpointer.dir / "latest.zip", env=venv, device="cpu")
        buffer = checkpointer.dir / "latest_replay_buffer.pkl"
        if config.algo in OFF_POLICY and buffer.is_file():
            model.load_replay_buffer(buffer)
    else:
        if normalize:
            venv = VecNormalize(
                venv, norm_obs=True, norm_reward=True, gamma=float(hp.get("gamma", 0.99))
            )
        try:
            model = algo_cls(
                hp.get("policy", "MlpPolicy"),
                venv,
                seed=config.seed,
                device="cpu",
                verbose=0,
                **_algo_kwargs(config, venv.action_space.shape[0]),
            )
        except TypeError as e:  # a hyperparameter this algorithm does not take
            venv.close()
            eval_env.close()
            raise ValueError(f"bad hyperparameters for {config.algo}: {e}") from None
        if config.init_from:
            init = load_policy(config.init_from)
            model.set_parameters(init.model.get_parameters())
            if normalize and init.obs_rms is not None:
                venv.obs_rms = init.obs_rms
    if normalize:
        eval_env = VecNormalize(eval_env, norm_obs=True, norm_reward=False, training=False)
    model.set_logger(configure(str(out / "logs"), ["csv", "tensorboard"]))

    meta = PolicyMeta(
        config.env_id,
        config.algo,
        env_kwargs,
        list(venv.observation_space.shape),
        list(venv.action_space.shape),
        normalize,
        command=command,
    )
    vec_normalize = venv if normalize else None
    every = max(int(hp.get("checkpoint_freq", 50_000)) // config.n_envs, 1)

    class Periodic(BaseCallback):
        def _on_step(self) -> bool:
            if self.n_calls % every == 0:
                checkpointer.save(self.model, vec_normalize)
            return True

    class SaveBest(BaseCallback):
        def _on_step(self) -> bool:
            meta.trained_timesteps = int(self.model.num_timesteps)
            save_policy(self.model, vec_normalize, meta, out / "best")
            return True

    eval_callback = EvalCallback(
        eval_env,
        callback_on_new_best=SaveBest(),
        n_eval_episodes=int(hp.get("eval_episodes", 20)),
        eval_freq=max(int(hp.get("eval_freq", 50_000)) // config.n_envs, 1),
        log_path=str(out / "eval"),
        deterministic=True,
        verbose=0,
    )
    remaining = config.timesteps - (checkpointer.timesteps() if resume else 0)
    start = time.perf_counter()
    if remaining > 0:
        model.learn(
            total_timesteps=remaining,
            callback=CallbackList([Periodic(), eval_callback]),
            reset_num_timesteps=not resume,
            progress_bar=progress_bar,
        )
    wall = time.perf_counter() - start
    checkpointer.save(model, vec_normalize)
    meta.trained_timesteps = int(model.num_timesteps)
    save_policy(model, vec_normalize, meta, out / "final")
    if not (out / "best").exists():
        save_policy(model, vec_normalize, meta, out / "best")
    venv.close()
    eval_env.close()
    summary = {
        "timesteps": int(model.num_timesteps),
        "wall_time_s": wall,
        "steps_per_s": (remaining / wall) if remaining > 0 and wall > 0 else None,
        "out": str(out),
    }
    atomic_write_json(out / "summary.json", summary)
    return summary
