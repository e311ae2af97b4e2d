"""A policy of the paper's 7-d action, distilled from a push policy of the 3-d position action.

The paper's action moves the tool tip's position and adds a change to its orientation
quaternion; a policy of it must also learn to keep the tip's orientation, which a position
policy is given (its target holds the initial orientation). This starts from what a
position policy does: the student is the teacher's network, its action head widened from 3 to
7 outputs (the 4 new ones zero), and DAgger (Ross et al., 2011) teaches it the expert's
action at the states it visits itself:

    expert(s) = [teacher(s), clip((q_0 - q(s)) / MAX_QUATERNION_STEP, -1, 1)]

q_0 the episode's initial tip quaternion, q(s) the tip's, of the robot model at the observed
joint angles, in q_0's hemisphere: the quaternion change that turns the tip back to its
initial orientation in one step (as far as one step's change reaches). That needs the env's
`continuous_quaternion` (with Drake's sign, which jumps at the home orientation, the same
change turns the tip either way), which the student's env kwargs set.

Round 0 runs the expert (every other episode with Gaussian noise on its actions, so the data
hold recoveries), each later round the student; after each round the student's actor (its
network and action head, not the value network, which PPO fine-tuning starts from) is fitted
to all the data so far (mean squared error of the action means). The result is a policy
directory like a trained one, to evaluate, or to fine-tune with `train --init-from`.
"""

from __future__ import annotations

import dataclasses as dc
import types
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from pydrake.math import RotationMatrix

from drake_tooluse.learning.policy_dir import build_model, load_policy, save_policy
from drake_tooluse.robot.kinematics import fk_jacobian
from drake_tooluse.systems.tip_target import ACTION_MODES, MAX_QUATERNION_STEP
from drake_tooluse.tasks.push.observation import OBSERVATION_SIZES

STUDENT_MODE = "position_quaternion"
QUATERNION_LOG_STD = -2.3  # the new outputs' exploration noise for fine-tuning: std 0.1
JOINTS = slice(16, 23)  # the joint angles in the paper's observation (tasks.push.observation)


@dc.dataclass(frozen=True)
class DistillConfig:
    rounds: int = 16
    episodes: int = 60  # per round, 100 steps each
    seed: int = 7000  # of the first episode (then +1 each) and of the noise and the fitting
    epochs: int = 20  # passes over the data after each round
    learning_rate: float = 3e-4
    batch_size: int = 256
    noise: float = 0.3  # std of the expert's action noise in round 0's odd episodes


def check_teacher(teacher) -> None:
    """The teacher must be a push policy of the position action on the paper's observation."""
    kwargs = teacher.meta.env_kwargs
    mode = kwargs.get("action_mode", STUDENT_MODE)
    observation = kwargs.get("observation_mode", "gripper_joints")
    if not teacher.meta.env_id.startswith("drake_tooluse/ToolPush") or mode != "position":
        raise ValueError(
            f"the teacher must be a push policy of action_mode 'position'; this one is a "
            f"{teacher.meta.env_id} policy of action_mode {mode!r}"
        )
    size = OBSERVATION_SIZES["gripper_joints"]
    if observation != "gripper_joints" or teacher.meta.observation_shape != [size]:
        raise ValueError(
            f"the teacher must observe the paper's {size} values (observation_mode "
            f"'gripper_joints', no tool length); it observes {teacher.meta.observation_shape}"
        )


def widened_student(teacher, command: str):
    """The teacher's network with a 7-output action head (the quaternion outputs zero), its
    meta for `position_quaternion` with `continuous_quaternion`."""
    env_kwargs = {
        **teacher.meta.env_kwargs,
        "action_mode": STUDENT_MODE,
        "continuous_quaternion": True,
    }
    meta = dc.replace(
        teacher.meta,
        env_kwargs=env_kwargs,
        action_shape=[ACTION_MODES[STUDENT_MODE]],
        command=command,
        evaluation=None,
    )
    model = build_model(meta)
    weights = dict(teacher.model.policy.state_dict())
    n = teacher.meta.action_shape[0]
    for name, fill in (("action_net.weight", 0.0), ("action_net.bias", 0.0)):
        wide = torch.full_like(model.policy.state_dict()[name], fill)
        wide[:n] = weights[name]
        weights[name] = wide
    log_std = torch.full((meta.action_shape[0],), QUATERNION_LOG_STD)
    log_std[:n] = weights["log_std"]
    weights["log_std"] = log_std
    model.policy.load_state_dict(weights)
    return model, meta


class OrientationExpert:
    """The teacher's action and the quaternion change back to the initial tip orientation."""

    def __init__(self, teacher):
        self._teacher = teacher
        self._R, self._p, self._J = np.empty((3, 3)), np.empty(3), np.empty((6, 7))

    def __call__(self, env, observation: np.ndarray) -> np.ndarray:
        target = env.target_system
        q0 = target._held_quaternion  # the initial target's orientation
        fk_jacobian(
            target._chain.fixed,
            target._chain.axes,
            observation[JOINTS].astype(float),
            self._R,
            self._p,
            self._J,
        )
        q = RotationMatrix.MakeUnchecked(self._R).ToQuaternion().wxyz()
        if q.dot(q0) < 0.0:
            q = -q  # as the env's continuous_quaternion signs it
        turn = np.clip((q0 - q) / MAX_QUATERNION_STEP, -1.0, 1.0)
        return np.concatenate([action_mean(self._teacher, observation), turn])


def action_mean(policy, observation: np.ndarray) -> np.ndarray:
    """The policy's action mean before the clip to [-1, 1] (what its actor outputs)."""
    normalized = torch.as_tensor(policy.normalize(observation[None].astype(np.float32)))
    with torch.no_grad():
        actor = policy.model.policy
        return actor.action_net(actor.mlp_extractor.forward_actor(normalized))[0].numpy()


def distill(
    teacher_dir, out, config: DistillConfig = DistillConfig(), command: str = "", log=print
) -> dict:
    """Distils `teacher_dir`'s position policy into a `position_quaternion` policy written to
    `out`; returns per round who acted, its success rate and the fit's RMSE per output."""
    teacher = load_policy(teacher_dir)
    check_teacher(teacher)
    model, meta = widened_student(teacher, command or f"distill {teacher_dir}")
    student = dc.replace(teacher, model=model, meta=meta)
    env = gym.make(meta.env_id, **meta.env_kwargs)
    expert = OrientationExpert(teacher)
    rng = np.random.default_rng(config.seed)
    torch.manual_seed(config.seed)
    actor = model.policy
    parameters = [*actor.mlp_extractor.policy_net.parameters(), *actor.action_net.parameters()]
    optimizer = torch.optim.Adam(parameters, lr=config.learning_rate)
    inputs, labels, rounds = [], [], []
    seed = config.seed
    try:
        for round_ in range(config.rounds):
            successes = []
            for episode in range(config.episodes):
                observation, _ = env.reset(seed=seed)
                seed += 1
                noisy = round_ == 0 and episode % 2 == 1
                truncated = False
                while not truncated:
                    best = expert(env.unwrapped, observation)
                    inputs.append(student.normalize(observation[None].astype(np.float32))[0])
                    labels.append(best)
                    if round_ == 0:
                        action = best + (config.noise * rng.standard_normal(7) if noisy else 0)
                    else:
                        action = student.act(observation)
                    observation, _, _, truncated, info = env.step(np.clip(action, -1, 1))
                successes.append(bool(info["is_success"]))
            rmse = _fit(actor, optimizer, inputs, labels, config)
            rounds.append(
                {
                    "round": round_,
                    "acting": "expert" if round_ == 0 else "student",
                    "success": float(np.mean(successes)),
                    "samples": len(inputs),
                    "rmse": [round(float(r), 4) for r in rmse],
                }
            )
            log(rounds[-1])
    finally:
        env.close()
    holder = types.SimpleNamespace(
        obs_rms=teacher.obs_rms, clip_obs=teacher.clip_obs, epsilon=teacher.epsilon
    )
    save_policy(model, holder if teacher.obs_rms is not None else None, meta, Path(out))
    return {"teacher": str(teacher_dir), "out": str(out), "rounds": rounds}


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
