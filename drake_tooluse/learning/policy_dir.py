"""The policy-directory format: a trained policy and what it needs to run.

A policy directory holds `policy.zip` (the SB3 model), `vecnormalize.pkl` (observation
normalisation, when used) and `policy.json` (`PolicyMeta`: env id, env kwargs, algorithm,
spaces, the command that trained it).
"""

from __future__ import annotations

import json
import pickle
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import stable_baselines3 as sb3
from sb3_contrib import TRPO

from drake_tooluse.files import atomic_dir
from drake_tooluse.learning.config import check_algo

ALGORITHMS = {"ppo": sb3.PPO, "a2c": sb3.A2C, "ddpg": sb3.DDPG, "trpo": TRPO}


def algorithm_class(algo: str):
    """The stable-baselines3 (or sb3-contrib) class of `algo`."""
    return ALGORITHMS[check_algo(algo)]


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


def save_policy(model, vec_normalize, meta: PolicyMeta, directory: Path) -> Path:
    """Writes a policy directory atomically (into a temporary sibling, then renamed)."""
    with atomic_dir(directory, replace=True) as tmp:
        model.save(tmp / "policy.zip")
        if vec_normalize is not None:
            vec_normalize.save(str(tmp / "vecnormalize.pkl"))
        (tmp / "policy.json").write_text(json.dumps(asdict(meta), indent=2) + "\n")
    return Path(directory)


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
        return np.clip(
            (obs - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon),
            -self.clip_obs,
            self.clip_obs,
        ).astype(np.float32)

    def act(self, obs) -> np.ndarray:
        action, _ = self.model.predict(
            self.normalize(np.asarray(obs, np.float32)), deterministic=True
        )
        return action


def load_policy(directory) -> LoadedPolicy:
    """Loads a policy directory; a missing or corrupt file is a clear error."""
    directory = Path(directory)
    meta_path = directory / "policy.json"
    if not directory.is_dir() or not meta_path.is_file():
        raise FileNotFoundError(
            f"{str(directory)!r} is not a policy directory (it needs "
            "policy.json, policy.zip and, if normalised, vecnormalize.pkl)"
        )
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
            f"actions {act} (check action_mode / include_tool_length)"
        )
