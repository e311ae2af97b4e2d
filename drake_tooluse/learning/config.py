"""What a training run is: the algorithm, the env, the budget and the hyperparameters.

Hyperparameters live in YAML beside the code (`learning/hyperparams/<algo>.yaml`, an entry per
env id over a `default` one, as rl-zoo keeps them); `resolve_config` merges them with the
command's overrides into a `TrainConfig`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import yaml

from drake_tooluse.envs.registration import ENV_IDS
from drake_tooluse.paths import HYPERPARAMS_DIR

ALGOS = ("ppo", "a2c", "ddpg", "trpo")
OFF_POLICY = ("ddpg",)
# Keys of a hyperparameter entry that are not the algorithm's own arguments.
RUN_KEYS = (
    "n_envs",
    "normalize",
    "env_kwargs",
    "policy",
    "noise_std",
    "eval_freq",
    "checkpoint_freq",
    "eval_episodes",
)


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


def resolve_config(
    env_id: str,
    algo: str,
    timesteps: int,
    n_envs: int | None,
    seed: int,
    init_from: str | None = None,
    overrides: dict | None = None,
) -> TrainConfig:
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
