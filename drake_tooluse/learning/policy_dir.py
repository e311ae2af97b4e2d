"""The policy-directory format: a trained policy and what it needs to run, loaded without
running any code from its files.

A policy directory holds:

| file | what |
| --- | --- |
| `policy.json` | `PolicyMeta`: env id and kwargs, algorithm, policy class and kwargs, spaces, normalised or not, the command that trained it |
| `policy.safetensors` | the policy network's weights (safetensors: tensors and a JSON header, nothing executable) |
| `normalization.json` | the observation normalisation (`VecNormalize`'s running mean and variance, clip, epsilon), when normalised |
| `scenario.yaml` | the env's scenario (`env_kwargs.scenario`), when it is not one the package ships |

A policy directory reads nothing but its own files and the package's data: its
`env_kwargs.scenario` is a file name, of a file in the directory or of a scenario the package
ships (`paths.SCENARIOS_DIR`), and that scenario's own files (its bases, its tool model) lie
there too (`resolve_scenario`, the one place its paths are resolved). Before any network is
built, the weights file's header is read and checked against `policy.json`: the spaces and
algorithm it was saved for, and `policy_kwargs.net_arch` against the number of parameters it
holds — a 1 kB file cannot ask for a network of gigabytes.

Loading rebuilds the stable-baselines3 model from the algorithm's class and the spaces in
`policy.json` and loads the weights into it; it checks the files against each other (the
algorithm and spaces the weights were saved with, the normaliser's size, `normalized`) and
against the env they name. Directories in the format before this one (`policy.zip`, an SB3
zip with cloudpickled entries, and `vecnormalize.pkl`, a pickle) can run code when they are
loaded: `load_policy` refuses them unless told `trust_pickle=True` (`--trust-pickle`), and
`convert_policy` rewrites one in this format.
"""

from __future__ import annotations

import copy
import dataclasses as dc
import json
import math
import pickle
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load, save
from stable_baselines3.common.running_mean_std import RunningMeanStd

from drake_tooluse.files import (
    MAX_JSON_BYTES,
    atomic_dir,
    parse_json,
    read_json,
    to_json,
)
from drake_tooluse.learning.config import (
    ALGORITHMS,
    OFF_POLICY,
    POLICIES,
    check_algo,
    check_policy_kwargs,
    net_arch_lists,
)
from drake_tooluse.learning.scenario_files import (  # noqa: F401  (this module's names too)
    SCENARIO,
    resolve_scenario,
    shipped_scenarios,
)
from drake_tooluse.learning.scenario_files import scenario_files as _scenario_files
from drake_tooluse.learning.task_envs import check_env_id, check_env_kwargs, env_spaces
from drake_tooluse.validation import check_one_of, refused_by_library, shown

FORMAT = 2
META = "policy.json"
WEIGHTS = "policy.safetensors"
NORMALIZATION = "normalization.json"
LEGACY_MODEL = "policy.zip"
LEGACY_NORMALIZATION = "vecnormalize.pkl"
# A policy's weights: the shipped ones are 0.1 MB; a network of 4096 x 4096 layers is 0.2 GB.
MAX_WEIGHTS_BYTES = 1 << 28
TRUST_HINT = (
    "convert it once (convert_policy(DIR, NEW, trust_pickle=True); on the command line "
    "`drake-tooluse convert-policy --policy DIR --out NEW --trust-pickle`), or load it with "
    "trust_pickle=True (--trust-pickle) if you trust where it comes from"
)


def algorithm_class(algo: str):
    """The stable-baselines3 (or sb3-contrib) class of `algo`."""
    return ALGORITHMS[check_algo(algo)]


@dc.dataclass
class PolicyMeta:
    env_id: str
    algo: str
    env_kwargs: dict
    observation_shape: list
    action_shape: list
    normalized: bool
    trained_timesteps: int = 0
    command: str = ""
    policy: str = "MlpPolicy"
    policy_kwargs: dict = dc.field(default_factory=dict)
    # For a best policy: the evaluation that chose it ({"timesteps", "mean_reward", "episodes"}).
    evaluation: dict | None = None
    format: int = FORMAT


# -- the scenario: the one place a policy directory's paths are resolved ------------------


def _shape(value, name: str, path: Path) -> list:
    if (
        not isinstance(value, list)
        or len(value) != 1
        or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in value)
    ):
        raise ValueError(
            f"{str(path)!r}: {name}={shown(value)} must be a list of one positive integer"
        )
    return value


def parse_meta(raw, path: Path) -> PolicyMeta:
    """A `PolicyMeta` from policy.json's contents, every field checked; errors name the file."""
    if not isinstance(raw, dict):
        raise ValueError(f"corrupt policy metadata {str(path)!r}: not a JSON object")
    names = [f.name for f in dc.fields(PolicyMeta)]
    unknown = sorted(set(raw) - set(names))
    missing = [f.name for f in dc.fields(PolicyMeta) if f.name not in raw and _required(f)]
    if unknown or missing:
        raise ValueError(
            f"corrupt policy metadata {str(path)!r}: "
            + "; ".join(
                ([f"unknown keys {shown(unknown)}"] if unknown else [])
                + ([f"missing keys {missing}"] if missing else [])
            )
            + f" (keys: {names})"
        )
    raw = dict(raw)
    raw.setdefault("format", 1)  # files without it are the format before this one
    meta = PolicyMeta(**raw)
    where = f"{str(path)!r}: "
    # The scenario's name resolved first: an env's own checks may read its scenario (the
    # pull's and the push's delay range, against its plant step).
    if isinstance(meta.env_kwargs, dict) and meta.env_kwargs.get("scenario") is not None:
        meta.env_kwargs = {
            **meta.env_kwargs,
            "scenario": resolve_scenario(meta.env_kwargs["scenario"], path.parent, where),
        }
    try:
        check_env_id(meta.env_id)
        check_algo(meta.algo)
        meta.env_kwargs = check_env_kwargs(meta.env_id, meta.env_kwargs, "env_kwargs")
        check_one_of(meta.policy, POLICIES, "policy")
        meta.policy_kwargs = check_policy_kwargs(meta.policy_kwargs, "policy_kwargs")
    except ValueError as e:
        raise ValueError(where + str(e)) from None
    _shape(meta.observation_shape, "observation_shape", path)
    _shape(meta.action_shape, "action_shape", path)
    for name in ("normalized",):
        if not isinstance(getattr(meta, name), bool):
            raise ValueError(where + f"{name}={shown(getattr(meta, name))} must be true or false")
    if not isinstance(meta.trained_timesteps, int) or meta.trained_timesteps < 0:
        raise ValueError(where + f"trained_timesteps={shown(meta.trained_timesteps)} must be >= 0")
    if not isinstance(meta.command, str):
        raise ValueError(where + f"command={shown(meta.command)} must be a string")
    if meta.format not in (1, FORMAT):
        raise ValueError(
            where + f"format={shown(meta.format)} is not one this version reads (1, 2)"
        )
    obs, act = env_spaces(meta.env_id, meta.env_kwargs)
    if meta.observation_shape != obs or meta.action_shape != act:
        raise ValueError(
            where + f"observation_shape {meta.observation_shape} and action_shape "
            f"{meta.action_shape} do not fit its env_kwargs {shown(meta.env_kwargs)}, whose env "
            f"observes {obs} and acts {act}"
        )
    return meta


def _required(field: dc.Field) -> bool:
    return field.default is dc.MISSING and field.default_factory is dc.MISSING


# -- the model ------------------------------------------------------------------------------


def spaces_of(meta: PolicyMeta) -> tuple[gym.spaces.Box, gym.spaces.Box]:
    """The observation and action spaces of a policy (as the push envs declare them)."""
    return (
        gym.spaces.Box(-np.inf, np.inf, tuple(meta.observation_shape), np.float32),
        gym.spaces.Box(-1.0, 1.0, tuple(meta.action_shape), np.float32),
    )


def build_model(meta: PolicyMeta):
    """A fresh stable-baselines3 model of `meta`'s algorithm, policy class and kwargs and spaces
    (no env: for acting and for its weights), as SB3's own `load` builds one."""
    cls = algorithm_class(meta.algo)
    extra = {"buffer_size": 1} if meta.algo in OFF_POLICY else {}
    model = cls(
        meta.policy,
        env=None,
        device="cpu",
        policy_kwargs=copy.deepcopy(meta.policy_kwargs) or None,
        _init_setup_model=False,
        **extra,
    )
    model.observation_space, model.action_space = spaces_of(meta)
    model.n_envs = 1
    with refused_by_library(
        f"cannot build a {meta.algo} {meta.policy} with policy_kwargs {shown(meta.policy_kwargs)}"
    ):
        model._setup_model()
    return model


def _normalization_dict(vec_normalize) -> dict:
    rms = vec_normalize.obs_rms
    out = {
        "obs_mean": np.asarray(rms.mean, float).tolist(),
        "obs_var": np.asarray(rms.var, float).tolist(),
        "obs_count": float(rms.count),
        "clip_obs": float(vec_normalize.clip_obs),
        "epsilon": float(vec_normalize.epsilon),
    }
    ret = getattr(vec_normalize, "ret_rms", None)
    if ret is not None:
        out.update(
            ret_mean=float(np.asarray(ret.mean)),
            ret_var=float(np.asarray(ret.var)),
            ret_count=float(ret.count),
        )
    return out


def save_policy(
    model, vec_normalize, meta: PolicyMeta, directory: Path, extra_files: dict | None = None
) -> Path:
    """Writes a policy directory atomically (into a temporary sibling, then renamed or swapped
    in): `policy.json`, `policy.safetensors`, normalised `normalization.json`, with a scenario
    the package does not ship `scenario.yaml` (and its tool model), and the `extra_files`
    ({name: bytes}) beside them. Its `env_kwargs.scenario` is stored by file name."""
    meta = dc.replace(meta, format=FORMAT, normalized=vec_normalize is not None)
    files = dict(extra_files or {})
    if meta.env_kwargs.get("scenario") is not None:
        name, scenario_files = _scenario_files(meta.env_kwargs["scenario"])
        meta = dc.replace(meta, env_kwargs={**meta.env_kwargs, "scenario": name})
        files.update(scenario_files)
    tensors = {
        k: v.detach().cpu().clone().contiguous() for k, v in model.policy.state_dict().items()
    }
    header = {
        "format": "drake_tooluse.policy",
        "version": str(FORMAT),
        "algo": meta.algo,
        "observation_shape": json.dumps(meta.observation_shape),
        "action_shape": json.dumps(meta.action_shape),
    }
    with atomic_dir(directory, replace=True) as tmp:
        try:  # (written by Python: safetensors' own file calls take only UTF-8 paths)
            (tmp / WEIGHTS).write_bytes(save(tensors, metadata=header))
        except OSError as e:  # a full disk: named by the policy's path, not the staging one
            raise OSError(e.errno, e.strerror, str(Path(directory) / WEIGHTS)) from None
        if vec_normalize is not None:
            (tmp / NORMALIZATION).write_text(to_json(_normalization_dict(vec_normalize)) + "\n")
        (tmp / META).write_text(to_json(dc.asdict(meta)) + "\n")
        for name, data in files.items():
            (tmp / name).write_bytes(data)
    return Path(directory)


@dc.dataclass
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
        obs = np.asarray(obs, np.float32)
        if list(obs.shape) != list(self.meta.observation_shape):
            raise ValueError(
                f"the policy observes {self.meta.observation_shape[0]} values; this "
                f"observation has shape {list(obs.shape)}"
            )
        action, _ = self.model.predict(self.normalize(obs), deterministic=True)
        return action


def _read_normalization(path: Path, meta: PolicyMeta):
    raw = read_json(path, "normalisation")
    try:
        mean = np.asarray(raw["obs_mean"], float)
        var = np.asarray(raw["obs_var"], float)
        clip_obs, epsilon = float(raw["clip_obs"]), float(raw["epsilon"])
        count = float(raw.get("obs_count", 1.0))
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(
            f"corrupt normalisation {str(path)!r}: {e} (it needs obs_mean, obs_var, clip_obs, "
            "epsilon)"
        ) from None
    if list(mean.shape) != meta.observation_shape or var.shape != mean.shape:
        raise ValueError(
            f"{str(path)!r} normalises {list(mean.shape)} / {list(var.shape)} values but the "
            f"policy observes {meta.observation_shape}"
        )
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(var)) and np.all(var >= 0)):
        raise ValueError(f"{str(path)!r}: obs_mean and obs_var must be finite, obs_var >= 0")
    if not (np.isfinite(clip_obs) and clip_obs > 0 and np.isfinite(epsilon) and epsilon > 0):
        raise ValueError(f"{str(path)!r}: clip_obs and epsilon must be positive")
    rms = RunningMeanStd(shape=tuple(mean.shape))
    rms.mean, rms.var, rms.count = mean, var, count
    return rms, clip_obs, epsilon


_DTYPE_BYTES = {"F64": 8, "F32": 4, "F16": 2, "BF16": 2, "I64": 8, "I32": 4, "BOOL": 1}


def read_weights_header(path: Path) -> tuple[dict, dict]:
    """({tensor name: shape}, {metadata name: value}) from a safetensors file's header (8 bytes
    of length, then JSON), read before any tensor: every entry checked (a shape of
    non-negative integers, a known dtype, byte ranges that fit the file), the file at most
    `MAX_WEIGHTS_BYTES`, and the metadata the policy writes (JSON strings) parsed. Errors name
    the file and the entry."""
    size = path.stat().st_size
    if size > MAX_WEIGHTS_BYTES:
        raise ValueError(
            f"{str(path)!r} is {size / 2**20:.0f} MB; a policy's weights are at most "
            f"{MAX_WEIGHTS_BYTES / 2**20:.0f} MB"
        )
    with open(path, "rb") as f:
        n = int.from_bytes(f.read(8), "little")
        if not 2 <= n <= min(MAX_JSON_BYTES, size - 8):
            raise ValueError(f"cannot load {str(path)!r}: its header length {n} does not fit")
        raw = parse_json(f.read(n).decode("utf-8", "replace"), f"cannot load {str(path)!r}")
    if not isinstance(raw, dict):
        raise ValueError(f"cannot load {str(path)!r}: its header is not a JSON object")
    metadata = raw.pop("__metadata__", None) or {}
    shapes = {}
    for name, entry in raw.items():
        ok = (
            isinstance(entry, dict)
            and entry.get("dtype") in _DTYPE_BYTES
            and isinstance(entry.get("shape"), list)
            and all(
                isinstance(d, int) and not isinstance(d, bool) and d >= 0 for d in entry["shape"]
            )
            and isinstance(entry.get("data_offsets"), list)
            and len(entry["data_offsets"]) == 2
            and all(isinstance(o, int) and o >= 0 for o in entry["data_offsets"])
        )
        if ok:
            start, stop = entry["data_offsets"]
            need = math.prod(entry["shape"]) * _DTYPE_BYTES[entry["dtype"]]
            ok = stop - start == need and stop <= size - 8 - n
        if not ok:
            raise ValueError(
                f"cannot load {str(path)!r}: its header's entry {shown(name)} = {shown(entry)} "
                "is not a tensor stored in the file"
            )
        shapes[name] = entry["shape"]
    if not isinstance(metadata, dict) or not all(isinstance(v, str) for v in metadata.values()):
        raise ValueError(f"cannot load {str(path)!r}: its metadata must map names to strings")
    parsed = {}
    for name in ("observation_shape", "action_shape"):
        if name in metadata:
            parsed[name] = parse_json(metadata[name], f"{str(path)!r}: metadata {name}")
    return shapes, {**metadata, **parsed}


def _net_arch_parameters(meta: PolicyMeta) -> int:
    """The fewest parameters a network of `meta`'s `policy_kwargs.net_arch` has: each of its
    layer stacks (policy, value or Q) takes the observation and multiplies it through its
    layers. (SB3's networks hold more: biases, output layers, target copies.)"""
    least = 0
    for layers in net_arch_lists(meta.policy_kwargs.get("net_arch")):
        widths = [meta.observation_shape[0], *layers]
        least += sum(a * b for a, b in zip(widths, widths[1:]))
    return least


def _check_header(meta: PolicyMeta, directory: Path, shapes: dict, metadata: dict) -> None:
    """The weights file's header against policy.json, before any network is built."""
    path, meta_path = directory / WEIGHTS, directory / META
    saved_algo = metadata.get("algo")
    if saved_algo is not None and saved_algo != meta.algo:
        raise ValueError(
            f"{str(meta_path)!r} says algo {meta.algo!r} but {str(path)!r} holds a "
            f"{shown(saved_algo)} policy"
        )
    for name in ("observation_shape", "action_shape"):
        if name in metadata and metadata[name] != getattr(meta, name):
            raise ValueError(
                f"{str(meta_path)!r} says {name} {getattr(meta, name)} but "
                f"{str(path)!r} was saved for {shown(metadata[name])}"
            )
    held = sum(math.prod(shape) for shape in shapes.values())
    least = _net_arch_parameters(meta)
    if least > held:
        raise ValueError(
            f"{str(meta_path)!r}: policy_kwargs.net_arch="
            f"{shown(meta.policy_kwargs.get('net_arch'))} makes a network of at least "
            f"{least:,} parameters, but {str(path)!r} holds {held:,}"
        )


def _load_weights(directory: Path, meta: PolicyMeta):
    path = directory / WEIGHTS
    try:
        shapes, metadata = read_weights_header(path)
    except OSError as e:
        raise ValueError(f"cannot load {str(path)!r}: {e}") from None
    _check_header(meta, directory, shapes, metadata)
    try:
        tensors = load(path.read_bytes())  # (any path: see save_policy)
    except (SafetensorError, OSError, ValueError) as e:
        raise ValueError(f"cannot load {str(path)!r}: {e}") from None
    for name, tensor in tensors.items():
        if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all()):
            raise ValueError(
                f"{str(path)!r}: the weights {name!r} hold NaN or infinite values; a policy's "
                "weights must be finite"
            )
    model = build_model(meta)
    _set_weights(model, tensors, path, meta)
    return model


def _set_weights(model, tensors: dict, path, meta: PolicyMeta) -> None:
    expected = model.policy.state_dict()
    missing = sorted(set(expected) - set(tensors))
    unexpected = sorted(set(tensors) - set(expected))
    wrong = [
        f"{k}: file {list(tensors[k].shape)}, the policy {list(expected[k].shape)}"
        for k in expected
        if k in tensors and tensors[k].shape != expected[k].shape
    ]
    if missing or unexpected or wrong:
        detail = "; ".join(
            ([f"missing {missing[:4]}"] if missing else [])
            + ([f"unexpected {unexpected[:4]}"] if unexpected else [])
            + wrong[:4]
        )
        raise ValueError(
            f"the weights in {str(path)!r} do not fit a {meta.algo} {meta.policy} "
            f"(policy_kwargs {shown(meta.policy_kwargs)}) for observations {meta.observation_shape} "
            f"and actions {meta.action_shape}: {detail}"
        )
    model.policy.load_state_dict(tensors, strict=True)
    model.policy.set_training_mode(False)


def _legacy_algo(zip_path: Path) -> str | None:
    """The algorithm an SB3 zip was saved by, from the names in its `data` (plain JSON; the
    cloudpickled values in it are not read)."""
    try:
        with zipfile.ZipFile(zip_path) as z:
            keys = set(json.loads(z.read("data")))
    except (zipfile.BadZipFile, KeyError, OSError, ValueError):
        return None
    if "cg_max_steps" in keys:
        return "trpo"
    if "clip_range" in keys:
        return "ppo"
    if "tau" in keys:
        return "ddpg"
    if "n_steps" in keys:
        return "a2c"
    return None


def _load_legacy(directory: Path, meta: PolicyMeta) -> LoadedPolicy:
    """The format before this one: an SB3 zip and a pickled VecNormalize (trusted)."""
    zip_path = directory / LEGACY_MODEL
    if not zip_path.is_file():
        raise FileNotFoundError(
            f"{str(directory)!r} has no {WEIGHTS} (nor the older {LEGACY_MODEL})"
        )
    saved_algo = _legacy_algo(zip_path)
    if saved_algo is not None and saved_algo != meta.algo:
        raise ValueError(
            f"{str(directory / META)!r} says algo {meta.algo!r} but {str(zip_path)!r} was "
            f"saved by {saved_algo!r}"
        )
    try:
        model = algorithm_class(meta.algo).load(zip_path, device="cpu")
    except Exception as e:  # SB3 raises several kinds on a damaged zip
        raise ValueError(f"cannot load {str(zip_path)!r}: {e}") from None
    for name, space in (("observation", model.observation_space), ("action", model.action_space)):
        shape = list(getattr(space, "shape", None) or [])
        if shape != getattr(meta, f"{name}_shape"):
            raise ValueError(
                f"{str(directory / META)!r} says {name}_shape {getattr(meta, f'{name}_shape')} "
                f"but {str(zip_path)!r} holds a model for {name}s {shape}"
            )
    loaded = LoadedPolicy(model, meta)
    pkl = directory / LEGACY_NORMALIZATION
    if meta.normalized != pkl.is_file():
        raise ValueError(_normalized_mismatch(directory, meta, pkl))
    if meta.normalized:
        try:
            with open(pkl, "rb") as f:
                vec_normalize = pickle.load(f)
            rms = vec_normalize.obs_rms
        except Exception as e:  # a pickle can fail in any way
            raise ValueError(f"cannot load the normalisation {str(pkl)!r}: {e}") from None
        if list(np.shape(rms.mean)) != meta.observation_shape:
            raise ValueError(
                f"{str(pkl)!r} normalises {list(np.shape(rms.mean))} values but the policy "
                f"observes {meta.observation_shape}"
            )
        loaded.obs_rms = rms
        loaded.clip_obs = vec_normalize.clip_obs
        loaded.epsilon = vec_normalize.epsilon
    return loaded


def _normalized_mismatch(directory: Path, meta: PolicyMeta, path: Path) -> str:
    if meta.normalized:
        return (
            f"{str(directory / META)!r} says normalized: true but {path.name} is missing: the "
            "policy would see raw observations"
        )
    return (
        f"{str(directory / META)!r} says normalized: false but {str(path)!r} is there: the "
        "policy was trained on normalised observations (fix policy.json or remove the file)"
    )


def pickle_files(directory) -> list[str]:
    """The files of a policy directory that are (or hold) pickles."""
    directory = Path(directory)
    return [n for n in (LEGACY_MODEL, LEGACY_NORMALIZATION) if (directory / n).exists()]


def _check_inside_policy(directory: Path, path: Path) -> None:
    """Refuses, before it is opened, a policy file that is a symbolic link leading out of
    its directory (`policy.json` -> /etc/passwd would be parsed, and quoted in an error), as
    a scenario in a policy directory may read nothing outside it."""
    if path.is_symlink() and not path.resolve().is_relative_to(directory.resolve()):
        raise ValueError(
            f"{str(path)!r} is a symbolic link to {str(path.resolve())!r}, outside the policy "
            f"directory {str(directory)!r}; a policy's files must lie in its directory"
        )


def load_policy(directory, trust_pickle: bool = False) -> LoadedPolicy:
    """Loads a policy directory. No code in its files runs: the weights are safetensors, the
    rest JSON. A directory in the older pickle format is refused unless `trust_pickle`. A
    missing, corrupt or inconsistent file is a clear error naming it."""
    directory = Path(directory)
    meta_path = directory / META
    if not directory.is_dir() or not meta_path.is_file():
        raise FileNotFoundError(
            f"{str(directory)!r} is not a policy directory (it needs {META}, {WEIGHTS} and, if "
            f"normalised, {NORMALIZATION})"
        )
    for name in (META, WEIGHTS, NORMALIZATION, LEGACY_NORMALIZATION):
        _check_inside_policy(directory, directory / name)
    meta = parse_meta(read_json(meta_path, "policy metadata"), meta_path)
    if not (directory / WEIGHTS).is_file():
        legacy = pickle_files(directory)
        if not legacy:
            raise FileNotFoundError(f"{str(directory)!r} has no {WEIGHTS}: not a policy directory")
        if not trust_pickle:
            raise ValueError(
                f"{str(directory)!r} is in the older pickle format ({', '.join(legacy)}), whose "
                f"files can run code when loaded; {TRUST_HINT}"
            )
        return _load_legacy(directory, meta)
    norm = directory / NORMALIZATION
    if meta.normalized and not norm.is_file():
        raise ValueError(_normalized_mismatch(directory, meta, norm))
    for path in (norm, directory / LEGACY_NORMALIZATION):
        if not meta.normalized and path.is_file():
            raise ValueError(_normalized_mismatch(directory, meta, path))
    loaded = LoadedPolicy(_load_weights(directory, meta), meta)
    if meta.normalized:
        loaded.obs_rms, loaded.clip_obs, loaded.epsilon = _read_normalization(norm, meta)
    return loaded


def convert_policy(source, target, trust_pickle: bool = False) -> Path:
    """Rewrites a policy directory of the older pickle format (`policy.zip`,
    `vecnormalize.pkl`) in this one, into `target` (a new directory, or `source` itself; its
    other files, such as metrics.json, go along). Loading the old files runs their pickles:
    `trust_pickle` must be given."""
    source, target = Path(source), Path(target)
    if not trust_pickle:
        raise ValueError(
            f"converting {str(source)!r} loads its pickles, which can run code: pass "
            "trust_pickle=True (--trust-pickle) if you trust where it comes from"
        )
    in_place = target.exists() and source.resolve() == target.resolve()
    if not in_place and target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise FileExistsError(f"{str(target)!r} exists and is not empty; give a new directory")
    old = load_policy(source, trust_pickle=True)
    meta = dc.replace(old.meta, policy_kwargs=dict(old.model.policy_kwargs or {}))
    try:
        json.dumps(meta.policy_kwargs)
    except TypeError:
        raise ValueError(
            f"{str(source)!r}: policy_kwargs {meta.policy_kwargs} hold a Python object "
            "(a class?), which this format cannot store"
        ) from None
    skip = (META, WEIGHTS, NORMALIZATION, LEGACY_MODEL, LEGACY_NORMALIZATION)
    extra = {p.name: p.read_bytes() for p in source.iterdir() if p.is_file() and p.name not in skip}
    normalizer = None
    if old.obs_rms is not None:
        normalizer = _Normalizer(old.obs_rms, old.clip_obs, old.epsilon)
    return save_policy(old.model, normalizer, meta, target, extra_files=extra)


@dc.dataclass
class _Normalizer:
    """What `save_policy` reads of a VecNormalize."""

    obs_rms: object
    clip_obs: float
    epsilon: float
    ret_rms: object = None


def check_policy_spaces(policy: LoadedPolicy, observation_shape, action_shape, name: str) -> None:
    """`policy`'s observation and action shapes must be the env's (given as lists); else a
    ValueError naming the policy (`name`) and both sets of shapes."""
    obs, act = list(observation_shape), list(action_shape)
    if policy.meta.observation_shape != obs or policy.meta.action_shape != act:
        raise ValueError(
            f"{name} was trained for observations {policy.meta.observation_shape} and "
            f"actions {policy.meta.action_shape}, but this env has observations {obs} and "
            f"actions {act} (check action_mode / observation_mode / include_tool_length)"
        )


def check_policy_env(policy: LoadedPolicy, env_id: str | None = None, env_kwargs=None):
    """The env a policy acts in, checked the same way by every command: `env_id` (default the
    policy's) must be a registered id, the policy's env kwargs updated with `env_kwargs` must be
    valid, and that env's spaces must be the policy's. Returns (env_id, env_kwargs)."""
    env_id = check_env_id(env_id or policy.meta.env_id)
    kwargs = dict(policy.meta.env_kwargs)
    kwargs.update(check_env_kwargs(env_id, env_kwargs, "env kwargs"))
    kwargs = check_env_kwargs(env_id, kwargs, "env kwargs")
    check_policy_spaces(policy, *env_spaces(env_id, kwargs), "the policy")
    return env_id, kwargs


def check_policy_matches(policy: LoadedPolicy, env) -> None:
    """The policy's spaces must be the (built) env's."""
    check_policy_spaces(policy, env.observation_space.shape, env.action_space.shape, "the policy")
