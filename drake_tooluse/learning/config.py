"""What a training run is: the algorithm, the env, the budget and the hyperparameters.

Hyperparameters live in YAML beside the code (`learning/hyperparams/<algo>.yaml`, an entry per
env id over a `default` one, as rl-zoo keeps them); `resolve_config` merges them with the
command's overrides into a `TrainConfig` and checks every key and value before anything runs:
an unknown key, one the algorithm does not take or a bad value is an error that names it.
"""

from __future__ import annotations

import inspect
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import stable_baselines3 as sb3
from sb3_contrib import TRPO

from drake_tooluse.files import atomic_write_bytes, atomic_write_json, read_json, read_yaml
from drake_tooluse.learning.algorithms import ALGOS
from drake_tooluse.learning.scenario_files import (
    resolve_scenario,
    scenario_files,
    scenario_identity,
)
from drake_tooluse.learning.task_envs import check_env_id, check_env_kwargs
from drake_tooluse.limits import MAX_N_ENVS, MAX_TIMESTEPS
from drake_tooluse.paths import HYPERPARAMS_DIR
from drake_tooluse.validation import (
    check_bool,
    check_in_range,
    check_int,
    check_mapping,
    check_seed,
    shown,
)

ALGORITHMS = dict(zip(ALGOS, (sb3.PPO, sb3.A2C, sb3.DDPG, TRPO)))
OFF_POLICY = ("ddpg",)
POLICIES = ("MlpPolicy",)
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
# Arguments of the algorithms that the run sets itself (or that JSON cannot give).
_NOT_HYPERPARAMETERS = {
    "self",
    "policy",
    "env",
    "seed",
    "device",
    "verbose",
    "tensorboard_log",
    "_init_setup_model",
    "action_noise",
    "rollout_buffer_class",
    "replay_buffer_class",
}
# A network's layers: at most this many, each at most this wide (4096 x 4096: 17M parameters).
MAX_LAYERS, MAX_WIDTH = 16, 4096
# The policy_kwargs whose values are checked here; SB3 checks the others when it builds.
NET_ARCH_KEYS = ("pi", "vf", "qf")  # the policy's, the value function's, the Q function's


def check_algo(algo: str) -> str:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose one of {list(ALGOS)}")
    return algo


def algorithm_arguments(algo: str) -> list[str]:
    """The hyperparameters `algo`'s class takes (its constructor's arguments the run does not
    set itself)."""
    parameters = inspect.signature(ALGORITHMS[check_algo(algo)].__init__).parameters
    return sorted(set(parameters) - _NOT_HYPERPARAMETERS)


def net_arch_lists(net_arch) -> list[list]:
    """The layer widths of each network a (checked) `net_arch` gives: SB3 takes a list for all
    of them, or a mapping of "pi", "vf" (on-policy) or "qf" (DDPG) to a list each."""
    if net_arch is None:
        return []
    return list(net_arch.values()) if isinstance(net_arch, dict) else [net_arch]


def check_net_arch(value, name: str = "net_arch") -> list | dict:
    """A network's layers, as SB3 takes them: a list of at most `MAX_LAYERS` widths, each an
    integer in [1, `MAX_WIDTH`], or a mapping of "pi", "vf" or "qf" to such a list."""
    allowed = (
        f"a list of at most {MAX_LAYERS} layer widths, integers in [1, {MAX_WIDTH}], or a "
        f"mapping of {list(NET_ARCH_KEYS)} to such lists"
    )
    if isinstance(value, dict):
        unknown = sorted(map(str, set(value) - set(NET_ARCH_KEYS)))
        if unknown:
            raise ValueError(f"{name} has unknown networks {shown(unknown)}; it must be {allowed}")
        for key, layers in value.items():
            check_net_arch(layers, f"{name}.{key}")
        return value
    if not isinstance(value, list) or len(value) > MAX_LAYERS:
        raise ValueError(f"{name}={shown(value)} must be {allowed}")
    for i, width in enumerate(value):
        check_int(width, 1, MAX_WIDTH, f"{name}[{i}]")
    return value


def check_policy_kwargs(kwargs, name: str = "policy_kwargs") -> dict:
    """The policy's keyword arguments: a mapping; `net_arch` (`check_net_arch`), `log_std_init`
    (the log of the initial action noise, in [-20, 2]) and `n_critics` (in [1, 10]) checked
    here, the others by SB3 when it builds the policy."""
    kwargs = check_mapping(kwargs, name)
    if "net_arch" in kwargs:
        check_net_arch(kwargs["net_arch"], f"{name}.net_arch")
    if "log_std_init" in kwargs:
        check_in_range(kwargs["log_std_init"], -20.0, 2.0, f"{name}.log_std_init")
    if "n_critics" in kwargs:
        check_int(kwargs["n_critics"], 1, 10, f"{name}.n_critics")
    return kwargs


def check_hyperparams(algo: str, env_id: str, hp, name: str = "hyperparameters") -> dict:
    """A hyperparameter entry for `algo` on `env_id`, every key known and every run key's value checked;
    algorithm arguments are passed on as given (their class checks their values)."""
    hp = dict(check_mapping(hp, name))
    allowed = algorithm_arguments(algo)
    unknown = sorted(k for k in hp if k not in RUN_KEYS and k not in allowed)
    if unknown:
        raise ValueError(
            f"unknown hyperparameter(s) {unknown} for {algo} in {name}; allowed: the run's "
            f"{list(RUN_KEYS)} and {algo}'s {allowed}"
        )
    for key in ("eval_freq", "checkpoint_freq", "eval_episodes"):
        if key in hp:
            check_int(hp[key], 1, MAX_TIMESTEPS, f"{name}: {key}")
    if "n_envs" in hp:
        check_int(hp["n_envs"], 1, MAX_N_ENVS, f"{name}: n_envs")
    if "normalize" in hp:
        check_bool(hp["normalize"], f"{name}: normalize")
    if "policy" in hp and hp["policy"] not in POLICIES:
        raise ValueError(
            f"{name}: policy={hp['policy']!r} is not allowed; choose one of {POLICIES}"
        )
    if "noise_std" in hp:
        x = hp["noise_std"]
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0 < x <= 10:
            raise ValueError(f"{name}: noise_std={x!r} is outside the allowed range (0, 10]")
    if "env_kwargs" in hp:
        hp["env_kwargs"] = check_env_kwargs(env_id, hp["env_kwargs"], f"{name}: env_kwargs")
    if "policy_kwargs" in hp:
        check_policy_kwargs(hp["policy_kwargs"], f"{name}: policy_kwargs")
    for key, value in hp.items():  # (named here, before JSON's message that names none)
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"{name}: {key}={value} must be finite")
    try:
        json.dumps(hp, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(
            f"{name} must be plain JSON values (numbers, strings, lists): {e}"
        ) from None
    return hp


def load_hyperparams(algo: str, env_id: str) -> dict:
    """The YAML entry for `env_id` (or `default`) of `hyperparams/<algo>.yaml`."""
    check_algo(algo)
    check_env_id(env_id)
    path = HYPERPARAMS_DIR / f"{algo}.yaml"
    table = read_yaml(path, "hyperparameter file") or {}
    entry = dict(table.get("default", {}))
    entry.update(table.get(env_id, {}))
    return check_hyperparams(algo, env_id, entry, str(path))


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
        """What a resumed run must share with the original (the budget may grow). The env's
        scenario is compared as what it is (`scenario_identity`: a shipped scenario's name,
        else its contents), not where its file lies: a run resumes after it or the checkout
        moved."""
        d = asdict(self)
        d.pop("timesteps")
        scenario = self.hyperparams.get("env_kwargs", {}).get("scenario")
        if scenario is not None:
            d["hyperparams"]["env_kwargs"]["scenario"] = scenario_identity(scenario)
        return d


RUN_CONFIG = "config.json"


def write_run_config(out, config: TrainConfig, command: str) -> Path:
    """Writes a run's config.json in the run directory `out` (atomically), with the command
    that started it. The env's scenario is stored by name (`scenario_files`: a shipped
    scenario's file name, else `scenario.yaml`, written whole into `out`), so the file names
    no path of the machine that wrote it."""
    out = Path(out)
    data = {**asdict(config), "command": command}
    env_kwargs = config.hyperparams.get("env_kwargs", {})
    if env_kwargs.get("scenario") is not None:
        name, files = scenario_files(env_kwargs["scenario"])
        for file_name, content in files.items():
            atomic_write_bytes(out / file_name, content)
        data["hyperparams"]["env_kwargs"]["scenario"] = name
    return atomic_write_json(out / RUN_CONFIG, data)


def read_run_config(path) -> tuple[TrainConfig, str]:
    """(a run's configuration, the command that started it) from its config.json; the env's
    scenario resolved on this machine (`resolve_scenario`: a file of the run directory or a
    scenario the package ships; an absolute path, as runs wrote before, is kept). Errors name
    the file."""
    path = Path(path)
    raw = read_json(path, "run configuration")
    if not isinstance(raw, dict):
        raise ValueError(f"corrupt run configuration {str(path)!r}: not a JSON object")
    command = raw.pop("command", "")
    try:
        config = TrainConfig(**raw)
    except TypeError as e:
        raise ValueError(f"corrupt run configuration {str(path)!r}: {e}") from None
    env_kwargs = (
        config.hyperparams.get("env_kwargs") if isinstance(config.hyperparams, dict) else None
    )
    scenario = env_kwargs.get("scenario") if isinstance(env_kwargs, dict) else None
    if isinstance(scenario, str) and not Path(scenario).is_absolute():
        env_kwargs["scenario"] = resolve_scenario(
            scenario, path.parent, f"{str(path)!r}: ", what="run"
        )
    return config, command


def config_differences(saved: dict, asked: dict, prefix: str = "") -> list[str]:
    """The keys (dotted) whose values differ between two configurations, each with both."""
    out = []
    for key in sorted(set(saved) | set(asked), key=str):
        a, b = saved.get(key, "<unset>"), asked.get(key, "<unset>")
        name = f"{prefix}{key}"
        if isinstance(a, dict) and isinstance(b, dict):
            out += config_differences(a, b, name + ".")
        elif a != b:
            out.append(f"{name}: saved {a!r}, asked {b!r}")
    return out


def resolve_config(
    env_id: str,
    algo: str,
    timesteps: int,
    n_envs: int | None,
    seed: int,
    init_from: str | None = None,
    overrides: dict | None = None,
    env_kwargs: dict | None = None,
) -> TrainConfig:
    """The run's configuration: `algo`'s YAML entry for `env_id`, updated with `overrides`
    (hyperparameters; an `env_kwargs` there replaces the YAML's), then the env's keyword
    arguments updated with `env_kwargs` (merged into the YAML's), every key and value checked."""
    check_env_id(env_id)
    check_algo(algo)
    check_int(timesteps, 1, MAX_TIMESTEPS, "timesteps")
    check_seed(seed, "seed")
    hp = load_hyperparams(algo, env_id)
    hp.update(check_hyperparams(algo, env_id, overrides, "hyperparameter overrides"))
    if env_kwargs:
        merged = {**hp.get("env_kwargs", {}), **check_mapping(env_kwargs, "env kwargs")}
        hp["env_kwargs"] = check_env_kwargs(env_id, merged, "env kwargs")
    n = check_int(n_envs if n_envs is not None else hp.get("n_envs", 1), 1, MAX_N_ENVS, "n_envs")
    hp["n_envs"] = n
    return TrainConfig(env_id, algo, int(timesteps), n, int(seed), hp, init_from)
