"""A run's checkpoints on disk (`OUT/checkpoints/`): writing one, finding the latest, and
putting one back into a freshly built model.

```
OUT/checkpoints/ckpt-<steps>/       the latest checkpoint (one directory, complete or absent):
    checkpoint.json                 counters, episode statistics, pending log values,
                                    evaluations, numpy's and Python's random states
    parameters.pt                   the model's and optimisers' tensors, torch's random state
    vecnormalize.json               the normalisation statistics (when the run normalises)
    replay_buffer.npz               the replay buffer (off-policy algorithms)
    best/                           a copy of OUT/best/ as it was
OUT/checkpoints/latest.json         which one it is
```

Each checkpoint is written into a new directory that appears complete in one rename; the
previous one is removed after. A kill at any moment leaves the newest complete checkpoint where
`latest_checkpoint` looks. A checkpoint holds no pickle: `parameters.pt` is read with
`torch.load(weights_only=True)`, the rest is JSON and `.npz` read with `allow_pickle=False`.
Old checkpoints must stay loadable: change this format only with `CHECKPOINT_FORMAT`.
"""

from __future__ import annotations

import random
import re
import shutil
import zipfile
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.vec_env import VecNormalize

from drake_tooluse.files import (
    atomic_dir,
    atomic_write_json,
    discard_dir,
    library_write,
    read_json,
    to_json,
)
from drake_tooluse.learning.sb3_state import (
    algorithm_counters,
    episode_statistics,
    evaluation_history,
    mean_rewards,
    pending_log_values,
    restore_algorithm,
)
from drake_tooluse.validation import check_int

CHECKPOINTS = "checkpoints"
CHECKPOINT_FORMAT = 1
LEGACY_CHECKPOINT = Path(CHECKPOINTS) / "latest.zip"  # before this format: SB3 zip + pickles
_CKPT = re.compile(r"^ckpt-(\d{12})$")
# checkpoint.json: counters, random states, every evaluation so far (a long run: a few MB).
MAX_STATE_BYTES = 1 << 26


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
    instead = f"remove {str(dirs[-1])!r} to resume from an older one, if any, or start a new run"
    try:
        state = read_json(path, "checkpoint", max_bytes=MAX_STATE_BYTES)  # names the file
    except (OSError, ValueError) as e:
        raise ValueError(f"{e}; {instead}") from None
    try:
        check_int(state["timesteps"], 0, 10**12, "timesteps")
    except (ValueError, KeyError, TypeError) as e:
        raise ValueError(f"corrupt checkpoint {str(path)!r}: {e}; {instead}") from None
    return dirs[-1], state


def write_checkpoint(
    out: Path,
    model,
    vec_normalize: VecNormalize | None,
    evaluation,
    *,
    iterations: int,
    wall_time_s: float,
    resumes: list,
) -> None:
    """Writes the checkpoint of `model` at its step count into `out`, then removes the older
    one. `evaluation` is the run's EvalCallback; `iterations`, `wall_time_s` and `resumes`
    are the run's counters (in checkpoint.json for the next session to carry on)."""
    steps = int(model.num_timesteps)
    folder = out / CHECKPOINTS
    best, last = mean_rewards(evaluation)
    # In the key order of the checkpoints written so far (two of them diff line by line).
    state = {
        "format": CHECKPOINT_FORMAT,
        "timesteps": steps,
        **algorithm_counters(model),
        "iterations": iterations,
        "wall_time_s": wall_time_s,
        "resumes": resumes,
        **episode_statistics(model),
        "logger": pending_log_values(model.logger),
        "evaluations": evaluation_history(evaluation),
        "best_mean_reward": best,
        "last_mean_reward": last,
        "numpy_random": _numpy_state(),
        "python_random": _python_state(),
    }
    name = f"ckpt-{steps:012d}"
    with atomic_dir(folder / name, replace=True) as tmp:
        # SB3's public API for the tensors; a dict of tensors, so no pickle is needed to read it.
        with library_write(folder / name / "parameters.pt"):  # a full disk: an OSError naming it
            torch.save(
                {"parameters": model.get_parameters(), "torch_rng": torch.get_rng_state()},
                tmp / "parameters.pt",
            )
        if vec_normalize is not None:
            (tmp / "vecnormalize.json").write_text(to_json(_vecnormalize_state(vec_normalize)))
        if getattr(model, "replay_buffer", None) is not None:
            _save_replay_buffer(model.replay_buffer, tmp / "replay_buffer.npz")
        if (out / "best").is_dir():
            shutil.copytree(out / "best", tmp / "best")
        (tmp / "checkpoint.json").write_text(to_json(state) + "\n")
    atomic_write_json(folder / "latest.json", {"timesteps": steps, "checkpoint": name})
    for old in checkpoint_dirs(out)[:-1]:
        discard_dir(old)


def restore_checkpoint(
    model, vec_normalize: VecNormalize | None, folder: Path, state: dict
) -> dict:
    """Puts the checkpoint in `folder` (`state` its checkpoint.json) into a freshly built
    `model` (and its VecNormalize), and the random generators back as they were; returns
    `state`."""
    path = folder / "parameters.pt"
    try:
        saved = torch.load(path, map_location="cpu", weights_only=True)
        model.set_parameters(saved["parameters"], exact_match=True, device="cpu")
    except (OSError, RuntimeError, KeyError, ValueError) as e:
        raise ValueError(f"cannot restore the checkpoint {str(path)!r}: {e}") from None
    restore_algorithm(model, state)
    if vec_normalize is not None:
        norm = folder / "vecnormalize.json"
        try:
            _restore_vecnormalize(vec_normalize, read_json(norm, "normalisation"), norm)
        except (OSError, ValueError, KeyError) as e:
            raise ValueError(f"cannot restore the normalisation {str(norm)!r}: {e}") from None
    if getattr(model, "replay_buffer", None) is not None:  # (every checkpoint of it has one)
        _restore_replay_buffer(model.replay_buffer, folder / "replay_buffer.npz")
    _restore_random(state, saved)
    return state


# -- normalisation statistics -----------------------------------------------------------------

# VecNormalize's public attributes (`VecNormalize.save` would pickle the whole wrapper).
VECNORMALIZE_FIELDS = ("obs_rms", "ret_rms", "clip_obs", "clip_reward", "gamma", "epsilon")


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


# -- the replay buffer ------------------------------------------------------------------------

# ReplayBuffer's arrays (its typed public attributes) and `pos`, `full`, `buffer_size`. Not
# SB3's `save_replay_buffer`/`load_replay_buffer`: they pickle the buffer, and a checkpoint
# holds no pickle; `.npz` of the filled part is also smaller.
REPLAY_BUFFER_ARRAYS = (
    "observations",
    "next_observations",
    "actions",
    "rewards",
    "dones",
    "timeouts",
)


def _save_replay_buffer(buffer, path: Path) -> None:
    size = buffer.buffer_size if buffer.full else buffer.pos
    arrays = {
        name: getattr(buffer, name)[:size]
        for name in REPLAY_BUFFER_ARRAYS
        if getattr(buffer, name, None) is not None  # next_observations with optimize_memory
    }
    np.savez(path, pos=buffer.pos, full=buffer.full, **arrays)


def _restore_replay_buffer(buffer, path: Path) -> None:
    """Fills `buffer` from `path`, refusing a file that is not whole (a truncated or
    damaged one would train on zeros where its transitions were)."""

    def refused(why) -> ValueError:
        return ValueError(f"cannot restore the replay buffer {str(path)!r}: {why}")

    try:
        with open(path, "rb") as f:
            npz = f.read(4) == b"PK\x03\x04"  # (numpy's error for other files speaks of pickles)
        if npz:
            with np.load(path, allow_pickle=False) as data:
                pos, full = int(data["pos"]), bool(data["full"])
                saved = {
                    name: data[name]
                    for name in REPLAY_BUFFER_ARRAYS
                    if getattr(buffer, name, None) is not None
                }
    except OSError as e:
        raise refused(e.strerror or e) from None
    except (EOFError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as e:
        raise refused(e) from None
    if not npz:
        raise refused("not an .npz file")
    size = buffer.buffer_size if full else pos
    for name, values in saved.items():
        target = getattr(buffer, name)
        if values.shape[1:] != target.shape[1:] or len(values) > len(target):
            raise refused(
                f"{name} {list(values.shape)} does not fit the replay buffer "
                f"{list(target.shape)} (was buffer_size changed?)"
            )
        if len(values) != size or not 0 <= pos < len(target):
            raise refused(
                f"{name} holds {len(values)} transitions where pos={pos}, full={full} "
                f"say {size}: the file is damaged"
            )
    for name, values in saved.items():
        getattr(buffer, name)[:size] = values
    buffer.pos, buffer.full = pos, full


# -- random generators ------------------------------------------------------------------------
# torch's state is a tensor (in parameters.pt); numpy's and Python's are lists (in JSON).


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
