"""The trained policy inside a Drake diagram (PolicySystem), not through the Gym wrapper."""

import dataclasses as dc

import gymnasium as gym
import numpy as np
import pytest

import drake_tooluse  # noqa: F401
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.learning.train import train
from drake_tooluse.systems.policy import PolicySystem
from drake_tooluse.tasks.deploy import build_policy_diagram, run_policy
from drake_tooluse.world.scenario import Scenario


@pytest.fixture(scope="module")
def policy_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("policy") / "run"
    overrides = {
        "n_steps": 256,
        "batch_size": 64,
        "n_epochs": 1,
        "eval_freq": 10_000_000,
        "eval_episodes": 1,
        "checkpoint_freq": 10_000_000,
        "env_kwargs": {"action_mode": "position"},
    }
    train(
        resolve_config("drake_tooluse/ToolPush-v1", "ppo", 512, 1, 0, overrides=overrides),
        out,
        progress_bar=False,
    )
    return out / "final"


def test_policy_system_acts_as_the_policy(policy_dir):
    policy = load_policy(policy_dir)
    system = PolicySystem(policy)
    context = system.CreateDefaultContext()
    obs = np.linspace(-1, 1, 30)
    system.get_input_port().FixValue(context, obs)
    np.testing.assert_allclose(system.get_output_port().Eval(context), policy.act(obs))


def test_policy_diagram_matches_the_env_rollout(policy_dir):
    """The diagram controls the arm as the policy's env did (its joint speed bound too)."""
    env_id, kwargs = "drake_tooluse/ToolPush-v1", {"action_mode": "position"}
    policy = load_policy(policy_dir)
    env_kwargs = {**policy.meta.env_kwargs, **kwargs}
    policy.meta = dc.replace(policy.meta, env_id=env_id, env_kwargs=env_kwargs)
    built = build_policy_diagram(Scenario(), policy)
    run = run_policy(built, max_steps=20)
    env = gym.make(env_id, **kwargs)
    ours, envs = built.control.ik_system.max_joint_speed, env.unwrapped.ik_system.max_joint_speed
    np.testing.assert_allclose(ours, envs)
    obs, _ = env.reset(seed=0)
    tips = [obs[6:9]]
    for _ in range(run.steps):
        obs, *_ = env.step(policy.act(obs))
        tips.append(obs[6:9])
    # The same controller and policy: the same tip path (float32 observations aside).
    np.testing.assert_allclose(run.tool_path, np.array(tips), atol=2e-3)


def test_policy_with_mismatched_action_mode_is_refused(policy_dir, tmp_path):
    import json
    import shutil

    other = tmp_path / "other"
    shutil.copytree(policy_dir, other)
    meta = json.loads((other / "policy.json").read_text())
    meta["env_kwargs"]["action_mode"] = "position_quaternion"
    (other / "policy.json").write_text(json.dumps(meta))
    # Refused where it is loaded: its metadata contradict themselves (3 actions, a 7-d mode).
    with pytest.raises(ValueError, match=r"action_shape \[3\] do not fit its env_kwargs"):
        load_policy(other)


def test_policy_diagram_with_a_tip_observation_policy(tmp_path_factory):
    out = tmp_path_factory.mktemp("tip_policy") / "run"
    overrides = {
        "n_steps": 128,
        "batch_size": 64,
        "n_epochs": 1,
        "eval_freq": 10_000_000,
        "eval_episodes": 1,
        "checkpoint_freq": 10_000_000,
        "env_kwargs": {
            "action_mode": "position",
            "observation_mode": "tip",
        },
    }
    train(
        resolve_config("drake_tooluse/ToolPush-v1", "ppo", 128, 1, 0, overrides=overrides),
        out,
        progress_bar=False,
    )
    built = build_policy_diagram(Scenario(), load_policy(out / "final"))
    assert built.observation.get_output_port().size() == 12
    run = run_policy(built, max_steps=5)
    assert run.steps == 5 and np.all(np.isfinite(run.tool_path))
