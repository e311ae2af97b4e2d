"""Training and evaluation with stable-baselines3 (TRPO from sb3-contrib).

A run directory holds everything a run needs and makes:

```
OUT/config.json                 what was asked for, resolved (env, algo, seed, hyperparameters)
OUT/checkpoints/latest.*        the latest checkpoint, written atomically every checkpoint interval
OUT/best/                       the best policy by periodic evaluation (a policy directory)
OUT/final/                      the policy at the end (a policy directory)
OUT/logs/                       progress.csv and TensorBoard events
```

A policy directory holds `policy.zip` (the SB3 model), `vecnormalize.pkl` (observation
normalisation, when used) and `policy.json` (env id, env kwargs, algorithm, spaces).
Hyperparameters live in YAML files beside this module (`hyperparams/<algo>.yaml`, per env id,
as rl-zoo keeps them).
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import yaml

from drake_tooluse.io import atomic_write_json
from drake_tooluse.registration import ENV_IDS

HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
ALGOS = ("ppo", "a2c", "ddpg", "trpo")
OFF_POLICY = ("ddpg",)
# Keys of a hyperparameter entry that are not the algorithm's own arguments.
RUN_KEYS = ("n_envs", "normalize", "env_kwargs", "policy", "noise_std", "eval_freq",
            "checkpoint_freq", "eval_episodes")


def algorithm_class(algo: str):
    check_algo(algo)
    if algo == "trpo":
        from sb3_contrib import TRPO

        return TRPO
    import stable_baselines3 as sb3

    return {"ppo": sb3.PPO, "a2c": sb3.A2C, "ddpg": sb3.DDPG}[algo]


def check_algo(algo: str) -> str:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose one of {list(ALGOS)}")
    return algo


def check_env_id(env_id: str) -> str:
    if env_id not in ENV_IDS:
        raise ValueError(f"unknown env {env_id!r}; choose one of {list(ENV_IDS)}")
    return env_id


def load_hyperparams(algo: str, env_id: str) -> dict:
    """The YAML entry for `env_id` (or `default`) of `hyperparams/<algo>.yaml`."""
    check_algo(algo)
    check_env_id(env_id)
    table = yaml.safe_load((HYPERPARAMS_DIR / f"{algo}.yaml").read_text())
    entry = dict(table.get("default", {}))
    entry.update(table.get(env_id, {}))
    return entry


# -- environments ---------------------------------------------------------------------------
def _make_env(env_id: str, env_kwargs: dict):
    def thunk():
        import gymnasium as gym

        # "module:id": a fresh worker process imports the package and its registrations.
        return gym.make(f"drake_tooluse:{env_id}", **env_kwargs)

    return thunk


def make_vec_env(env_id: str, n_envs: int, seed: int, env_kwargs: dict):
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    fns = [_make_env(env_id, env_kwargs) for _ in range(n_envs)]
    vec = SubprocVecEnv(fns) if n_envs > 1 else DummyVecEnv(fns)
    vec.seed(seed)
    return VecMonitor(vec, info_keywords=("is_success", "box_to_goal"))


# -- policy directories -----------------------------------------------------------------------
@dataclass
class PolicyMeta:
    env_id: str
    algo: str
    env_kwargs: dict
    observation_shape: list
    action_shape: list
    normalized: bool
    trained_timesteps: int = 0
    command: str = ""


def _atomic_replace_dir(tmp_dir: Path, target: Path) -> None:
    """Swaps a fully written temporary directory into place."""
    mask = os.umask(0)
    os.umask(mask)
    tmp_dir.chmod(0o777 & ~mask)  # mkdtemp makes 0700; give the usual directory mode
    old = target.with_name(f".{target.name}.old")
    if old.exists():
        shutil.rmtree(old)
    if target.exists():
        target.rename(old)
    tmp_dir.rename(target)
    if old.exists():
        shutil.rmtree(old)


def save_policy(model, vec_normalize, meta: PolicyMeta, directory: Path) -> Path:
    """Writes a policy directory atomically (into a temporary sibling, then renamed)."""
    directory = Path(directory)
    directory.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=directory.parent, prefix=f".{directory.name}."))
    model.save(tmp / "policy.zip")
    if vec_normalize is not None:
        vec_normalize.save(str(tmp / "vecnormalize.pkl"))
    (tmp / "policy.json").write_text(json.dumps(asdict(meta), indent=2) + "\n")
    _atomic_replace_dir(tmp, directory)
    return directory


@dataclass
class LoadedPolicy:
    model: object
    meta: PolicyMeta
    obs_rms: object = None  # RunningMeanStd of the observations, or None
    clip_obs: float = 10.0
    epsilon: float = 1e-8

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        if self.obs_rms is None:
            return obs
        return np.clip((obs - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon),
                       -self.clip_obs, self.clip_obs).astype(np.float32)

    def act(self, obs) -> np.ndarray:
        action, _ = self.model.predict(self.normalize(np.asarray(obs, np.float32)),
                                       deterministic=True)
        return action


def load_policy(directory) -> LoadedPolicy:
    """Loads a policy directory; a missing or corrupt file is a clear error."""
    directory = Path(directory)
    meta_path = directory / "policy.json"
    if not directory.is_dir() or not meta_path.is_file():
        raise FileNotFoundError(f"{str(directory)!r} is not a policy directory (it needs "
                                "policy.json, policy.zip and, if normalised, vecnormalize.pkl)")
    try:
        meta = PolicyMeta(**json.loads(meta_path.read_text()))
    except (json.JSONDecodeError, TypeError) as e:
        raise ValueError(f"corrupt policy metadata {str(meta_path)!r}: {e}") from None
    try:
        model = algorithm_class(meta.algo).load(directory / "policy.zip", device="cpu")
    except Exception as e:  # SB3 raises several kinds on a damaged zip
        raise ValueError(f"cannot load {str(directory / 'policy.zip')!r}: {e}") from None
    loaded = LoadedPolicy(model, meta)
    if meta.normalized:
        try:
            with open(directory / "vecnormalize.pkl", "rb") as f:
                vec_normalize = pickle.load(f)
        except (OSError, pickle.UnpicklingError, EOFError) as e:
            raise ValueError(f"cannot load the normalisation of {str(directory)!r}: {e}") from None
        loaded.obs_rms = vec_normalize.obs_rms
        loaded.clip_obs = vec_normalize.clip_obs
        loaded.epsilon = vec_normalize.epsilon
    return loaded


def check_policy_matches(policy: LoadedPolicy, env) -> None:
    """The policy's spaces must be the env's."""
    obs, act = list(env.observation_space.shape), list(env.action_space.shape)
    if policy.meta.observation_shape != obs or policy.meta.action_shape != act:
        raise ValueError(
            f"the policy was trained for observations {policy.meta.observation_shape} and "
            f"actions {policy.meta.action_shape}, but this env has observations {obs} and "
            f"actions {act} (check action_mode / include_tool_length)")


# -- evaluation -----------------------------------------------------------------------------
@dataclass
class EvalResult:
    episodes: int
    seed: int
    final_box_to_goal_mean_m: float
    final_box_to_goal_median_m: float
    final_box_to_goal_std_m: float
    success_rate: float
    box_travel_mean_m: float
    episode_length_mean: float
    tool_touched_rate: float
    gripper_touched_rate: float
    per_episode: list = field(default_factory=list)


def evaluate(policy_dir, env_id: str | None = None, episodes: int = 100, seed: int = 0,
             env_kwargs: dict | None = None) -> EvalResult:
    """Runs the policy deterministically for `episodes` episodes, seeds seed, seed+1, …"""
    import gymnasium as gym

    import drake_tooluse  # noqa: F401

    policy = load_policy(policy_dir)
    env_id = check_env_id(env_id or policy.meta.env_id)
    if episodes < 1:
        raise ValueError(f"episodes={episodes} must be at least 1")
    kwargs = dict(policy.meta.env_kwargs)
    kwargs.update(env_kwargs or {})
    env = gym.make(env_id, **kwargs)
    check_policy_matches(policy, env)
    rows = []
    for ep in range(episodes):
        obs, info = env.reset(seed=seed + ep)
        for steps in range(1, 10_000):
            obs, _, terminated, truncated, info = env.step(policy.act(obs))
            if terminated or truncated:
                break
        rows.append({"seed": seed + ep, "final_box_to_goal_m": info["box_to_goal"],
                     "success": bool(info["is_success"]), "box_travel_m": info["box_travel"],
                     "length": steps, "tool_touched": info["tool_touched_box_in_episode"],
                     "gripper_touched": info["gripper_touched_box_in_episode"]})
    d = np.array([r["final_box_to_goal_m"] for r in rows])
    return EvalResult(
        episodes=episodes, seed=seed, final_box_to_goal_mean_m=float(d.mean()),
        final_box_to_goal_median_m=float(np.median(d)), final_box_to_goal_std_m=float(d.std()),
        success_rate=float(np.mean([r["success"] for r in rows])),
        box_travel_mean_m=float(np.mean([r["box_travel_m"] for r in rows])),
        episode_length_mean=float(np.mean([r["length"] for r in rows])),
        tool_touched_rate=float(np.mean([r["tool_touched"] for r in rows])),
        gripper_touched_rate=float(np.mean([r["gripper_touched"] for r in rows])),
        per_episode=rows)


# -- training -------------------------------------------------------------------------------
@dataclass
class TrainConfig:
    env_id: str
    algo: str
    timesteps: int
    n_envs: int
    seed: int
    hyperparams: dict
    init_from: str | None = None

    def comparable(self) -> dict:
        """What a resumed run must share with the original (the budget may grow)."""
        d = asdict(self)
        d.pop("timesteps")
        return d


def resolve_config(env_id: str, algo: str, timesteps: int, n_envs: int | None, seed: int,
                   init_from: str | None = None, overrides: dict | None = None) -> TrainConfig:
    check_env_id(env_id)
    check_algo(algo)
    if timesteps < 1:
        raise ValueError(f"timesteps={timesteps} must be at least 1")
    hp = load_hyperparams(algo, env_id)
    hp.update(overrides or {})
    n = int(n_envs if n_envs is not None else hp.get("n_envs", 1))
    if not 1 <= n <= 64:
        raise ValueError(f"n_envs={n} is outside the allowed range [1, 64]")
    hp["n_envs"] = n
    if seed < 0:
        raise ValueError(f"seed={seed} must be a non-negative integer")
    return TrainConfig(env_id, algo, int(timesteps), n, int(seed), hp, init_from)


def _algo_kwargs(config: TrainConfig, action_dim: int) -> dict:
    kwargs = {k: v for k, v in config.hyperparams.items() if k not in RUN_KEYS}
    if config.algo == "ddpg":
        from stable_baselines3.common.noise import NormalActionNoise

        std = float(config.hyperparams.get("noise_std", 0.1))
        kwargs["action_noise"] = NormalActionNoise(np.zeros(action_dim), std * np.ones(action_dim))
    return kwargs


class _Checkpointer:
    """Writes the latest checkpoint (model, normalisation, replay buffer, step count)
    atomically: a run killed at any moment resumes from the last complete one."""

    def __init__(self, out: Path):
        self.dir = out / "checkpoints"

    def save(self, model, vec_normalize) -> None:
        self.dir.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=self.dir.parent, prefix=".checkpoints."))
        model.save(tmp / "latest.zip")
        if vec_normalize is not None:
            vec_normalize.save(str(tmp / "latest_vecnormalize.pkl"))
        if hasattr(model, "replay_buffer") and model.replay_buffer is not None:
            model.save_replay_buffer(tmp / "latest_replay_buffer.pkl")
        (tmp / "latest.json").write_text(json.dumps({"timesteps": int(model.num_timesteps)}))
        _atomic_replace_dir(tmp, self.dir)

    def exists(self) -> bool:
        return (self.dir / "latest.json").is_file()

    def timesteps(self) -> int:
        return int(json.loads((self.dir / "latest.json").read_text())["timesteps"])


def train(config: TrainConfig, out: Path, *, resume: bool = False, progress_bar: bool = True,
          command: str = "") -> dict:
    """Trains (or resumes) a run in `out`; returns the final evaluation figures."""
    import torch
    from stable_baselines3.common.callbacks import (
        BaseCallback,
        CallbackList,
        EvalCallback,
    )
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(1)
    out = Path(out)
    config_path = out / "config.json"
    checkpointer = _Checkpointer(out)
    if resume:
        if not config_path.is_file() or not checkpointer.exists():
            raise FileNotFoundError(f"nothing to resume in {str(out)!r}: it needs config.json "
                                    "and checkpoints/latest.json")
        saved = TrainConfig(**json.loads(config_path.read_text()))
        if saved.comparable() != config.comparable():
            diff = {k: (saved.comparable()[k], config.comparable()[k])
                    for k in config.comparable() if saved.comparable()[k] != config.comparable()[k]}
            raise ValueError(f"refusing to resume {str(out)!r} with different settings "
                             f"(saved, asked): {diff}")
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
            venv = VecNormalize(venv, norm_obs=True, norm_reward=True,
                                gamma=float(hp.get("gamma", 0.99)))
        try:
            model = algo_cls(hp.get("policy", "MlpPolicy"), venv, seed=config.seed,
                             device="cpu", verbose=0,
                             **_algo_kwargs(config, venv.action_space.shape[0]))
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

    meta = PolicyMeta(config.env_id, config.algo, env_kwargs,
                      list(venv.observation_space.shape), list(venv.action_space.shape),
                      normalize, command=command)
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
        eval_env, callback_on_new_best=SaveBest(), n_eval_episodes=int(hp.get("eval_episodes", 20)),
        eval_freq=max(int(hp.get("eval_freq", 50_000)) // config.n_envs, 1),
        log_path=str(out / "eval"), deterministic=True, verbose=0)
    remaining = config.timesteps - (checkpointer.timesteps() if resume else 0)
    start = time.perf_counter()
    if remaining > 0:
        model.learn(total_timesteps=remaining, callback=CallbackList([Periodic(), eval_callback]),
                    reset_num_timesteps=not resume, progress_bar=progress_bar)
    wall = time.perf_counter() - start
    checkpointer.save(model, vec_normalize)
    meta.trained_timesteps = int(model.num_timesteps)
    save_policy(model, vec_normalize, meta, out / "final")
    if not (out / "best").exists():
        save_policy(model, vec_normalize, meta, out / "best")
    venv.close()
    eval_env.close()
    summary = {"timesteps": int(model.num_timesteps), "wall_time_s": wall,
               "steps_per_s": (remaining / wall) if remaining > 0 and wall > 0 else None,
               "out": str(out)}
    atomic_write_json(out / "summary.json", summary)
    return summary
