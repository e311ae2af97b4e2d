"""A push policy on the paper's observation, of the position or the paper's 7-d action,
distilled by DAgger (Ross et al., 2011) from a push policy of the position action.

The student observes the paper's 30 values (`gripper_joints`); the teacher, of the position
action, observes the same or the task in tool-tip space (`tip`, which it computes from the
student's observation: `ToolPushObservation.tip_from_paper`). A teacher on the paper's
observation starts the student as its own network (its action head widened for the 7-d
action, the new outputs zero); a `tip` teacher's student starts as a fresh network of its
policy_kwargs, with the observation normalization of round 0's observations.

The paper's 7-d action moves the tip and adds a change to its orientation quaternion; a
policy of it must also keep the tip's orientation, which a position policy is given (its target
holds the initial one). The expert's action is then

    expert(s) = [teacher(s), clip((q_0 - q(s)) / MAX_QUATERNION_STEP, -1, 1)]

q_0 the episode's initial tip quaternion, q(s) the tip's, of the robot model at the observed
joint angles, in q_0's hemisphere: the change that turns the tip back to its initial
orientation in one step, as far as one step's change reaches. That holds because the env keeps
the quaternion in q_0's hemisphere (with Drake's sign, which jumps at the home orientation, the
same change would turn the tip either way) and moves the target from the observed state
(`builders.control.add_tip_control`): from the state one plant step later, the change back
would turn the tip on by what it turned in that step (at git tag figures-v0, whose envs did so,
the expert reached the goal of the paper's task in 69 % of 100 episodes, where the teacher with
the position action reached about 90 %; benchmarks/distill_gap.py shows an expert beside its
student).

Round 0 runs the expert (every other episode with Gaussian noise on its actions, so the data
hold recoveries), each later round the student; after each round the student's actor (its
network and action head, not the value network) is fitted to all the data so far (mean squared
error of the action means). The result is a policy directory like a trained one, to evaluate,
or to fine-tune with `train --init-from`.
"""

from __future__ import annotations

import dataclasses as dc
import io
import math
import time
import types
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.running_mean_std import RunningMeanStd

from drake_tooluse.files import read_json, to_json
from drake_tooluse.learning.policy_dir import LoadedPolicy, build_model, load_policy, save_policy
from drake_tooluse.limits import MAX_BATCH_SIZE, MAX_EPISODES, MAX_EPOCHS, MAX_ROUNDS, SEED_MAX
from drake_tooluse.systems.tip_target import ACTION_MODES, MAX_QUATERNION_STEP
from drake_tooluse.tasks.push.observation import OBSERVATION_SIZES

STUDENT_MODES = ("position", "position_quaternion")
TEACHER_OBSERVATIONS = ("gripper_joints", "tip")
QUATERNION_LOG_STD = -2.3  # the quaternion outputs' exploration noise for fine-tuning: std 0.1
JOINTS = slice(16, 23)  # the joint angles in the paper's observation (tasks.push.observation)
# An unfinished distillation's state, beside the student so far in its directory: gone when
# it finishes.
PROGRESS = "distill_progress.json"
PROGRESS_TENSORS = "distill_progress.pt"
PROGRESS_DATA = "distill_data.npz"
PROGRESS_FORMAT = 1


@dc.dataclass(frozen=True)
class DistillConfig:
    action_mode: str = "position_quaternion"  # the student's
    env_kwargs: dict = dc.field(default_factory=dict)  # the student's env, over the teacher's
    rounds: int = 16
    episodes: int = 60  # per round, 100 steps each
    seed: int = 7000  # of the first episode (then +1 each) and of the noise and the fitting
    epochs: int = 20  # passes over the data after each round
    learning_rate: float = 3e-4
    batch_size: int = 256
    noise: float = 0.3  # std of the expert's action noise in round 0's odd episodes
    # A student of an earlier distillation to go on from (its network and normalization): more
    # rounds, the data collected afresh.
    init_from: str | Path | None = None


def check_teacher(teacher) -> None:
    """The teacher must be a push policy of the position action, observing the paper's 30
    values or the task in tip space (without the tool length)."""
    kwargs = teacher.meta.env_kwargs
    mode = kwargs.get("action_mode", "position_quaternion")
    if not teacher.meta.env_id.startswith("drake_tooluse/ToolPush") or mode != "position":
        raise ValueError(
            f"the teacher must be a push policy of action_mode 'position'; this one is a "
            f"{teacher.meta.env_id} policy of action_mode {mode!r}"
        )
    observation = kwargs.get("observation_mode", "gripper_joints")
    if observation not in TEACHER_OBSERVATIONS or teacher.meta.observation_shape != [
        OBSERVATION_SIZES[observation]
    ]:
        raise ValueError(
            f"the teacher must observe the paper's 30 values or the 12 of the tip (no tool "
            f"length); it observes {teacher.meta.observation_shape}"
        )


def _observes_paper(policy) -> bool:
    return policy.meta.env_kwargs.get("observation_mode", "gripper_joints") == "gripper_joints"


def student_of(teacher, config: DistillConfig, command: str):
    """The student's model and meta: the teacher's network (action head widened, the new
    outputs zero) where it observes the paper's values, else a fresh one of its kwargs."""
    env_kwargs = {**teacher.meta.env_kwargs, **config.env_kwargs}
    env_kwargs.update(action_mode=config.action_mode, observation_mode="gripper_joints")
    meta = dc.replace(
        teacher.meta,
        env_kwargs=env_kwargs,
        observation_shape=[OBSERVATION_SIZES["gripper_joints"]],
        action_shape=[ACTION_MODES[config.action_mode]],
        command=command,
        evaluation=None,
        trained_timesteps=0,
    )
    model = build_model(meta)
    ours, teachers = model.policy.state_dict(), teacher.model.policy.state_dict()
    n = teacher.meta.action_shape[0]
    theirs = dict(teachers if _observes_paper(teacher) else ours)
    if _observes_paper(teacher):
        for name in ("action_net.weight", "action_net.bias"):
            theirs[name] = torch.zeros_like(ours[name])
            theirs[name][:n] = teachers[name]
    log_std = torch.full((meta.action_shape[0],), QUATERNION_LOG_STD)
    log_std[:n] = teachers["log_std"]
    theirs["log_std"] = log_std
    model.policy.load_state_dict(theirs)
    return model, meta


class Expert:
    """The teacher's action at the student's observation and, for the 7-d action, the
    quaternion change back to the initial tip orientation."""

    def __init__(self, teacher, action_mode: str):
        self._teacher = teacher
        self._tip_teacher = not _observes_paper(teacher)
        self._turns = action_mode == "position_quaternion"

    def __call__(self, env, observation: np.ndarray) -> np.ndarray:
        seen = observation
        if self._tip_teacher:
            seen = env.observation_system.tip_from_paper(observation).astype(np.float32)
        move = action_mean(self._teacher, seen)
        if not self._turns:
            return move
        target = env.target_system  # it signs q in q0's hemisphere
        q0, q = target.initial_quaternion, target.quaternion_at(observation[JOINTS])
        return np.concatenate([move, np.clip((q0 - q) / MAX_QUATERNION_STEP, -1.0, 1.0)])


def action_mean(policy, observation: np.ndarray) -> np.ndarray:
    """The policy's action mean before the clip to [-1, 1] (what its actor outputs)."""
    normalized = torch.as_tensor(policy.normalize(observation[None].astype(np.float32)))
    with torch.no_grad():
        actor = policy.model.policy
        return actor.action_net(actor.mlp_extractor.forward_actor(normalized))[0].numpy()


def unfinished(out) -> bool:
    """Whether `out` holds a stopped distillation's state (`resume_distill` goes on with it)."""
    return (Path(out) / PROGRESS).is_file()


def round_text(entry: dict) -> str:
    """One round of the distillation in words (a progress line)."""
    rmse = ", ".join(f"{r:.3f}" for r in entry["rmse"])
    return (
        f"round {entry['round']} ({entry['acting']} acting): success {entry['success']:.0%}, "
        f"{entry['samples']} samples, RMSE per action [{rmse}]"
    )


def distill(
    teacher_dir, out, config: DistillConfig = DistillConfig(), command: str = "", log=print
) -> dict:
    """Distils `teacher_dir`'s policy into a student on the paper's observation, written to
    `out`; returns per round who acted, its success rate and the fit's RMSE per output, and
    the wall time. Each finished round is saved in `out` (the student so far, with the
    distillation's state: `resume_distill` goes on from it after a kill)."""
    if unfinished(out):
        raise FileExistsError(
            f"{str(out)!r} already holds an unfinished distillation; continue it with "
            "resume_distill, or give a new out"
        )
    teacher = str(Path(teacher_dir).resolve())
    return _distill(teacher, Path(out), config, command or f"distill {teacher_dir}", log, None)


def resume_distill(out, log=print) -> dict:
    """Goes on with the distillation whose unfinished state `out` holds (one that was
    stopped), from its last finished round, with its own teacher and settings: the same
    student as had it not been stopped."""
    if not unfinished(out):
        raise FileNotFoundError(
            f"{str(out)!r} holds no unfinished distillation (no {PROGRESS}): it finished, or "
            "is not a distillation's"
        )
    path = Path(out) / PROGRESS
    progress = read_json(path, "distillation state")
    if progress.get("format") != PROGRESS_FORMAT:
        raise ValueError(
            f"{str(path)!r} is of format {progress.get('format')!r}; this version reads "
            f"format {PROGRESS_FORMAT}"
        )
    config = check_progress(progress, path)
    return _distill(progress["teacher"], Path(out), config, progress["command"], log, progress)


# The distillation state's numbers: (field, type, lowest, highest); None: unbounded.
CONFIG_RANGES = (
    ("rounds", int, 1, MAX_ROUNDS),
    ("episodes", int, 1, MAX_EPISODES),
    ("seed", int, 0, SEED_MAX),
    ("epochs", int, 0, MAX_EPOCHS),
    ("learning_rate", float, 1e-7, 1.0),
    ("batch_size", int, 1, MAX_BATCH_SIZE),
    ("noise", float, 0.0, 10.0),
)


def check_progress(progress, path: Path) -> DistillConfig:
    """A stopped distillation's state (`distill_progress.json`), checked whole before any
    work: each field typed, each number finite and in its range, the rounds numbered in order
    with their sample counts growing. Returns its config; a ValueError names the file and the
    field."""

    def bad(field: str, value, why: str) -> ValueError:
        return ValueError(f"{str(path)!r}: {field}={value!r} {why}")

    def number(field: str, value, kind, lo, hi):
        if isinstance(value, bool) or not isinstance(value, (int, float) if kind is float else int):
            raise bad(field, value, f"must be {'a number' if kind is float else 'an integer'}")
        if not (math.isfinite(value) and lo <= value <= hi):
            raise bad(field, value, f"must be in [{lo}, {hi}]")
        return value

    if not isinstance(progress, dict):
        raise ValueError(f"{str(path)!r} must hold a JSON object")
    for field, kind in (("teacher", str), ("command", str), ("config", dict), ("rounds", list)):
        if not isinstance(progress.get(field), kind):
            raise bad(field, progress.get(field), f"must be a {kind.__name__}")
    raw = progress["config"]
    fields = {f.name for f in dc.fields(DistillConfig)}
    unknown = sorted(set(raw) - fields)
    if unknown:
        raise bad("config", unknown, f"holds unknown field(s); allowed: {sorted(fields)}")
    for field, kind, lo, hi in CONFIG_RANGES:
        if field not in raw:
            raise bad(f"config.{field}", None, "is missing")
        number(f"config.{field}", raw[field], kind, lo, hi)
    if raw.get("action_mode") not in STUDENT_MODES:
        raise bad("config.action_mode", raw.get("action_mode"), f"must be one of {STUDENT_MODES}")
    if not isinstance(raw.get("env_kwargs", {}), dict):
        raise bad("config.env_kwargs", raw.get("env_kwargs"), "must be a JSON object")
    samples = 0
    for i, entry in enumerate(progress["rounds"]):
        if not isinstance(entry, dict) or entry.get("round") != i:
            raise bad(f"rounds[{i}]", entry, f"must be round {i}'s record")
        count = number(f"rounds[{i}].samples", entry.get("samples"), int, samples + 1, 10**9)
        samples = count
    if len(progress["rounds"]) >= raw["rounds"]:
        raise bad(
            "rounds", len(progress["rounds"]), f"records; the distillation has {raw['rounds']}"
        )
    number("next_seed", progress.get("next_seed"), int, 0, 2**32 - 1)
    number("wall_time_s", progress.get("wall_time_s"), float, 0.0, 1e9)
    if not isinstance(progress.get("numpy_random"), dict):
        raise bad("numpy_random", progress.get("numpy_random"), "must be a generator's state")
    return DistillConfig(**raw)


def _distill(teacher_dir: str, out: Path, config, command: str, log, progress) -> dict:
    start = time.monotonic()
    teacher = load_policy(teacher_dir)
    check_teacher(teacher)
    model, meta = student_of(teacher, config, command)
    fresh = not _observes_paper(teacher)  # normalized as round 0's observations
    student = LoadedPolicy(model, meta, None if fresh else teacher.obs_rms)
    if config.init_from is not None and progress is None:
        earlier = load_policy(config.init_from)
        _check_earlier(earlier, meta, config.init_from)
        model.policy.load_state_dict(earlier.model.policy.state_dict())
        student.obs_rms, fresh = earlier.obs_rms, False
    env = gym.make(meta.env_id, **meta.env_kwargs)
    expert = Expert(teacher, config.action_mode)
    rng = np.random.default_rng(config.seed)
    torch.manual_seed(config.seed)
    actor = model.policy
    parameters = [*actor.mlp_extractor.policy_net.parameters(), *actor.action_net.parameters()]
    optimizer = torch.optim.Adam(parameters, lr=config.learning_rate)
    observations, labels, rounds = [], [], []
    seed, earlier_time = config.seed, 0.0
    if progress is not None:
        observations, labels = _restore(out, progress, student, optimizer, rng)
        rounds, seed = progress["rounds"], progress["next_seed"]
        earlier_time = progress["wall_time_s"]
    try:
        for round_ in range(len(rounds), config.rounds):
            successes = []
            for episode in range(config.episodes):
                observation, _ = env.reset(seed=seed)
                seed += 1
                noise = config.noise if round_ == 0 and episode % 2 == 1 else 0.0
                truncated = False
                while not truncated:
                    best = expert(env.unwrapped, observation)
                    observations.append(observation)
                    labels.append(best)
                    if round_ == 0:
                        action = best + noise * rng.standard_normal(best.size)
                    else:
                        action = student.act(observation)
                    observation, _, _, truncated, info = env.step(np.clip(action, -1, 1))
                successes.append(bool(info["is_success"]))
            if fresh and round_ == 0:
                student.obs_rms = RunningMeanStd(shape=tuple(meta.observation_shape))
                student.obs_rms.update(np.asarray(observations, float))
            rmse = _fit(
                actor, optimizer, student.normalize(np.asarray(observations)), labels, config
            )
            rounds.append(
                {
                    "round": round_,
                    "acting": "expert" if round_ == 0 else "student",
                    "success": float(np.mean(successes)),
                    "samples": len(observations),
                    "rmse": [round(float(r), 4) for r in rmse],
                }
            )
            state = {
                "format": PROGRESS_FORMAT,
                "teacher": teacher_dir,
                "command": command,
                "config": _config_dict(config),
                "rounds": rounds,
                "next_seed": seed,
                "wall_time_s": earlier_time + time.monotonic() - start,
                "numpy_random": rng.bit_generator.state,
            }
            _save_round(model, student, meta, out, state, optimizer, observations, labels)
            log(rounds[-1])
    finally:
        env.close()
    save_policy(model, _normalization(student), meta, out)  # the state files go with the rename
    return {
        "teacher": teacher_dir,
        "out": str(out),
        "rounds": rounds,
        "wall_time_s": earlier_time + time.monotonic() - start,
    }


def _normalization(student: LoadedPolicy):
    """The student's observation normalization as `save_policy` takes it (None: none)."""
    if student.obs_rms is None:
        return None
    return types.SimpleNamespace(
        obs_rms=student.obs_rms, clip_obs=student.clip_obs, epsilon=student.epsilon
    )


def _config_dict(config: DistillConfig) -> dict:
    values = dc.asdict(config)
    if values["init_from"] is not None:
        values["init_from"] = str(Path(values["init_from"]).resolve())
    return values


def _save_round(model, student, meta, out: Path, state, optimizer, observations, labels):
    """The student after a round, as a policy directory, with what `resume_distill` needs to
    go on: the state (JSON), the optimizer's and torch's random state (tensors, read back
    with `weights_only`) and the data so far (`.npz`, read back without pickles). One
    directory, swapped in whole."""
    tensors, data = io.BytesIO(), io.BytesIO()
    torch.save({"optimizer": optimizer.state_dict(), "torch_rng": torch.get_rng_state()}, tensors)
    np.savez(data, observations=np.asarray(observations), labels=np.asarray(labels))
    files = {
        PROGRESS: (to_json(state) + "\n").encode(),
        PROGRESS_TENSORS: tensors.getvalue(),
        PROGRESS_DATA: data.getvalue(),
    }
    save_policy(model, _normalization(student), meta, out, extra_files=files)


def _restore(out: Path, progress: dict, student, optimizer, rng) -> tuple[list, list]:
    """Puts the saved round back: the student's network and normalization, the optimizer,
    the random generators; returns the observations and labels so far."""
    saved = load_policy(out)
    student.model.policy.load_state_dict(saved.model.policy.state_dict())
    student.obs_rms = saved.obs_rms
    tensors_path, data_path = out / PROGRESS_TENSORS, out / PROGRESS_DATA
    try:
        tensors = torch.load(tensors_path, map_location="cpu", weights_only=True)
        optimizer.load_state_dict(tensors["optimizer"])
        torch.set_rng_state(tensors["torch_rng"])
    except Exception as e:  # torch's unpickler raises many kinds; all mean an unreadable file
        raise ValueError(
            f"cannot restore the distillation from {str(tensors_path)!r}: {e}"
        ) from None
    try:
        with np.load(data_path, allow_pickle=False) as data:
            observations, labels = np.asarray(data["observations"]), np.asarray(data["labels"])
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as e:
        raise ValueError(f"cannot restore the distillation from {str(data_path)!r}: {e}") from None
    _check_data(observations, labels, progress, student.meta, data_path)
    try:
        rng.bit_generator.state = progress["numpy_random"]
    except (TypeError, ValueError, KeyError) as e:
        raise ValueError(f"{str(out / PROGRESS)!r}: numpy_random: {e}") from None
    return list(observations), list(labels)


def _check_data(observations, labels, progress, meta, path) -> None:
    """The data so far fits the state: one observation and one label per sample, of the
    student's sizes, every value finite, as many samples as the last round recorded."""
    n = progress["rounds"][-1]["samples"] if progress["rounds"] else 0
    shapes = {
        "observations": (observations, meta.observation_shape[0]),
        "labels": (labels, meta.action_shape[0]),
    }
    for name, (array, width) in shapes.items():
        if array.dtype.kind not in "fiu" or array.shape != (n, width):
            raise ValueError(
                f"{str(path)!r}: {name} has shape {list(array.shape)} ({array.dtype}); the "
                f"state's {n} samples need [{n}, {width}] numbers"
            )
        if not np.isfinite(array).all():
            raise ValueError(f"{str(path)!r}: {name} holds NaN or infinite values")


def _check_earlier(earlier, meta, path) -> None:
    """An earlier student fits: the same observation, action and network."""
    ours = (meta.env_kwargs.get("action_mode"), meta.observation_shape, meta.action_shape)
    theirs = (
        earlier.meta.env_kwargs.get("action_mode"),
        earlier.meta.observation_shape,
        earlier.meta.action_shape,
    )
    if theirs != ours or earlier.meta.policy_kwargs != meta.policy_kwargs:
        raise ValueError(
            f"init_from {str(path)!r} is not a student of this distillation: its action mode, "
            f"observation and action {theirs}, this one's {ours} (and the same policy_kwargs)"
        )


def _fit(actor, optimizer, inputs, labels, config: DistillConfig) -> np.ndarray:
    x = torch.as_tensor(np.asarray(inputs, np.float32))
    y = torch.as_tensor(np.asarray(labels, np.float32))
    for _ in range(config.epochs):
        order = torch.randperm(len(x))
        for start in range(0, len(x), config.batch_size):
            batch = order[start : start + config.batch_size]
            mean = actor.action_net(actor.mlp_extractor.forward_actor(x[batch]))
            loss = ((mean - y[batch]) ** 2).mean()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
    with torch.no_grad():
        mean = actor.action_net(actor.mlp_extractor.forward_actor(x))
        return ((mean - y) ** 2).mean(0).sqrt().numpy()
