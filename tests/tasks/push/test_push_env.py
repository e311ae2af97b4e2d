"""The push envs: ecosystem checks, determinism, rewards, success, bad input, vector envs."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from stable_baselines3.common.vec_env import SubprocVecEnv

import drake_tooluse  # noqa: F401  (registers the ids)
from drake_tooluse.tasks.push.registration import ENV_IDS
from drake_tooluse.tasks.push.scripted import ScriptedPush


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_registered_ids_pass_gymnasium_and_sb3_checkers(env_id):
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == 100
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped)
    assert env.observation_space.shape == (30,) and env.observation_space.dtype == np.float32
    assert env.action_space.shape == (7,)


def test_full_ik_env_passes_the_checker():
    check_env(gym.make("drake_tooluse/ToolPush-v1").unwrapped, skip_render_check=True)


@pytest.mark.parametrize("mode, size", [("position_quaternion", 7), ("pose", 6), ("position", 3)])
def test_action_modes(mode, size):
    env = gym.make("drake_tooluse/ToolPush-v1", action_mode=mode, include_tool_length=True)
    assert env.action_space.shape == (size,)
    obs, _ = env.reset(seed=1)
    assert obs.shape == (31,) and obs[30] == pytest.approx(0.175)
    obs, *_ = env.step(np.ones(size) * 0.5)
    assert np.all(np.isfinite(obs))


def _rollout(env, seed, actions):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for a in actions:
        obs, *_ = env.step(a)
        out.append(obs)
    return np.array(out)


def test_same_seed_same_actions_give_bit_identical_observations():
    actions = np.random.default_rng(0).uniform(-1, 1, (15, 7))
    kwargs = {"randomize": True}
    a = _rollout(gym.make("drake_tooluse/ToolPush-v1", **kwargs), 3, actions)
    b = _rollout(gym.make("drake_tooluse/ToolPush-v1", **kwargs), 3, actions)
    np.testing.assert_array_equal(a, b)
    c = _rollout(gym.make("drake_tooluse/ToolPush-v1", **kwargs), 4, actions)
    assert not np.array_equal(a[0], c[0])  # randomized start differs with the seed


def test_rewards_of_env1_env2_env3():
    action = np.zeros(7)
    for env_id in ENV_IDS:
        env = gym.make(env_id)
        obs, info = env.reset(seed=0)
        goal, box = obs[0:3], obs[3:6]
        _, reward, *_, info = env.step(action)
        if "BoxReward" in env_id:
            assert reward == pytest.approx(-info["object_to_goal"])
        else:
            assert reward == pytest.approx(-(info["object_to_goal"] + info["tip_to_object"]))
        far = "Far" in env_id
        assert goal[1] - box[1] == pytest.approx(0.30 if far else 0.20)
        assert goal[0] == pytest.approx(box[0]) and goal[2] == pytest.approx(box[2])


def _scripted_episode(env):
    """The scripted push from seed 0 until its first success or the episode's end:
    (terminated, truncated, info)."""
    policy = ScriptedPush(env.unwrapped.scenario.table.top_z)
    obs, _ = env.reset(seed=0)
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        if terminated or truncated or info["is_success"]:
            break
    return terminated, truncated, info


def test_episodes_run_to_the_step_limit_reporting_success_every_step():
    """The paper's protocol: no early end; `is_success` says, each step, whether the box is
    at the goal now (the scripted push arrives, drifts off and comes back)."""
    env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position")
    policy = ScriptedPush(env.unwrapped.scenario.table.top_z)
    obs, _ = env.reset(seed=0)
    successes, terminated, truncated = [], False, False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(policy(obs))
        successes.append(info["is_success"])
    assert len(successes) == 100 and truncated and not terminated
    first = successes.index(True)
    assert not all(successes[first:]) and successes[-1]
    assert info["object_to_goal"] + info["tip_to_object"] <= 0.05
    assert info["object_travel"] > 0.15
    assert info["tool_touched_object_in_episode"] and not info["gripper_touched_object_in_episode"]
    env.close()


@pytest.mark.parametrize("tool_length", [0.125, 0.40, 0.55])
def test_scripted_push_works_with_short_and_long_tools(tool_length):
    """Any tool the arm can hold down to the box: a long rod used to be pushed into the box
    and out through its top face by the contact query (one long thin collision cylinder),
    pinning the box to the table."""
    env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position", tool_length=tool_length)
    _, _, info = _scripted_episode(env)
    assert info["is_success"] and info["object_travel"] > 0.15


def test_nan_action_is_an_error_naming_it():
    env = gym.make("drake_tooluse/ToolPush-v1")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="NaN or infinite"):
        env.step(np.array([0, np.nan, 0, 0, 0, 0, 0]))
    with pytest.raises(ValueError, match="needs 7"):
        env.step(np.zeros(3))


def test_out_of_bounds_actions_are_clipped():
    a = gym.make("drake_tooluse/ToolPush-v1", action_mode="position")
    b = gym.make("drake_tooluse/ToolPush-v1", action_mode="position")
    a.reset(seed=0)
    b.reset(seed=0)
    np.testing.assert_array_equal(
        a.step(np.array([5.0, -7.0, 0.3]))[0], b.step(np.array([1.0, -1.0, 0.3]))[0]
    )


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"colour": "red"}, r"unknown argument\(s\) \['colour'\].*allowed: \['render_mode'"),
        (
            {"action_mode": "joint"},
            r"action_mode='joint' is not allowed; choose one of \['position_quaternion', 'pose', 'position'\]",
        ),
        ({"tool_length": 0.9}, r"tool_length=0.9 m is outside the allowed range \(0, 0.6\]"),
    ],
)
def test_bad_kwargs_list_what_is_allowed(kwargs, message):
    with pytest.raises((TypeError, ValueError), match=message):
        gym.make("drake_tooluse/ToolPush-v1", **kwargs)


def test_reset_options_are_refused():
    env = gym.make("drake_tooluse/ToolPush-v1")
    with pytest.raises(ValueError, match="not supported"):
        env.reset(options={"goal": 1})


def test_rgb_array_render_from_the_camera():
    env = gym.make("drake_tooluse/ToolPush-v1", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8  # 640 x 480 by default
    assert frame.std() > 10  # a scene, not a blank image


def test_episode_recorded_to_meshcat_html(tmp_path):
    from drake_tooluse.builders.visualization import start_meshcat

    env = gym.make("drake_tooluse/ToolPush-v1", meshcat=start_meshcat())
    env.reset(seed=0)
    env.unwrapped.start_recording()
    for _ in range(5):
        env.step(env.action_space.sample())
    path = env.unwrapped.save_recording(tmp_path / "episode.html")
    assert path.stat().st_size > 100_000


def _make(rank):
    def thunk():
        # Workers start fresh (forkserver): "module:id" makes Gymnasium import the package.
        return gym.make("drake_tooluse:drake_tooluse/ToolPush-v1")

    return thunk


@pytest.mark.slow  # ~9 s: two worker processes; .ci/run runs it
def test_subproc_vec_env_with_two_workers():
    vec = SubprocVecEnv([_make(0), _make(1)])
    try:
        vec.seed(5)
        obs = vec.reset()
        assert obs.shape == (2, 30)
        for _ in range(3):
            obs, rewards, dones, infos = vec.step(np.zeros((2, 7), np.float32))
        assert rewards.shape == (2,) and all("is_success" in i for i in infos)
    finally:
        vec.close()


def test_tip_observation_is_the_same_for_any_tool():
    """`observation_mode="tip"`: goal, box, tip position and velocity — nothing that changes
    with the tool for the same tip motion (unlike the paper's joint angles)."""
    from drake_tooluse.tasks.push.observation import OBSERVATION_SIZES

    observations = {}
    for length in (0.125, 0.175):
        env = gym.make(
            "drake_tooluse/ToolPush-v1",
            observation_mode="tip",
            action_mode="position",
            tool_length=length,
        )
        obs, _ = env.reset(seed=0)
        assert obs.shape == (OBSERVATION_SIZES["tip"],) == env.observation_space.shape
        X_WT, _ = env.unwrapped.believed_poses()
        np.testing.assert_allclose(obs[6:9], X_WT.translation(), atol=1e-6)
        np.testing.assert_allclose(obs[9:12], 0.0, atol=1e-6)  # at rest
        obs, *_ = env.step(np.array([0.0, 1.0, 0.0], np.float32))
        assert obs[10] > 0.01  # moving along +y
        observations[length] = obs
    # Same tip target, same task state: the observations agree to tracking differences.
    np.testing.assert_allclose(observations[0.125][:9], observations[0.175][:9], atol=5e-3)


def test_unknown_observation_mode_is_refused():
    with pytest.raises(ValueError, match="observation_mode='joint'.*gripper_joints.*tip"):
        gym.make("drake_tooluse/ToolPush-v1", observation_mode="joint")


def test_the_recorded_goal_marker_is_this_episodes_goal():
    """With randomized starts the goal moves with the box: the Meshcat marker follows it."""
    from drake_tooluse.builders.visualization import GOAL_PATH, start_meshcat
    from drake_tooluse.experiments.screenshots import scene_commands

    meshcat = start_meshcat()
    env = gym.make("drake_tooluse/ToolPush-v1", meshcat=meshcat, randomize=True)
    for seed in (3, 4):
        env.reset(seed=seed)
        moves = [
            c
            for c in scene_commands(meshcat.StaticHtml())
            if c.get("type") == "set_transform" and c.get("path") == GOAL_PATH
        ]
        goal = env.unwrapped._episode["goal"]
        np.testing.assert_allclose(moves[-1]["matrix"][12:14], goal[:2], atol=1e-12)


def test_a_tool_length_range_draws_each_episodes_tool_from_the_seed():
    """One env, a distribution of tools: each episode's world and belief hold a tool drawn
    from the range with the env's seeded generator; the observation carries its length."""
    env = gym.make(
        "drake_tooluse/ToolPush-v1",
        action_mode="position",
        observation_mode="tip",
        include_tool_length=True,
        tool_length_range=[0.125, 0.25],
    )
    lengths = []
    for seed in (0, 1, 0):
        obs, _ = env.reset(seed=seed)
        length = env.unwrapped.scenario.tool.length
        assert 0.125 <= length <= 0.25 and obs[-1] == np.float32(length)
        assert env.unwrapped.control.ik.tool_length == length  # the robot believes it
        env.step(np.zeros(3))
        lengths.append(length)
    assert lengths[0] == lengths[2] != lengths[1]
    env.close()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"tool_length_range": [0.2, 0.1]}, r"must have lo < hi"),
        ({"tool_length_range": [0.1, 0.9]}, r"tool_length_range\[1\]=0.9 m is outside"),
        ({"tool_length_range": 0.2}, r"must be \[lo, hi\]"),
        ({"tool_length_range": [0.1, 0.2], "tool_length": 0.15}, "not both"),
    ],
)
def test_bad_tool_length_ranges_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make("drake_tooluse/ToolPush-v1", **kwargs)


def test_an_actuation_delay_range_draws_each_episodes_delay_from_the_seed():
    """Domain randomization of the command latency: each episode's world is built with a
    delay drawn from the plant-step multiples in the range, from the env's seeded generator,
    and the arm then answers an action that much later."""
    env = gym.make(
        "drake_tooluse/ToolPush-v1", action_mode="position", actuation_delay_range=[0, 0.06]
    )
    delays = {}
    for seed in range(8):
        env.reset(seed=seed)
        delays[seed] = env.unwrapped.scenario.control.actuation_delay
    assert set(delays.values()) <= {0.0, 0.02, 0.04, 0.06} and len(set(delays.values())) > 1
    env.reset(seed=3)
    assert env.unwrapped.scenario.control.actuation_delay == delays[3]
    env.close()

    def tip_after_one_step(**kwargs):
        env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position", **kwargs)
        obs0, _ = env.reset(seed=0)
        obs, *_ = env.step(np.array([0.0, 1.0, 0.0]))
        env.close()
        return obs[6:9] - obs0[6:9]  # the tip's motion in the step

    prompt = tip_after_one_step()
    late = tip_after_one_step(actuation_delay_range=[0.05, 0.07])  # 0.06 s only
    assert np.linalg.norm(late) < 0.5 * np.linalg.norm(prompt)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"actuation_delay_range": [0.04, 0.0]}, r"must have lo < hi"),
        ({"actuation_delay_range": [0.0, 0.5]}, r"actuation_delay_range\[1\]=0.5 s is outside"),
        ({"actuation_delay_range": 0.04}, r"must be \[lo, hi\] \(s\)"),
        ({"actuation_delay_range": [0.005, 0.015]}, r"holds no multiple of the plant's time step"),
    ],
)
def test_bad_actuation_delay_ranges_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make("drake_tooluse/ToolPush-v1", **kwargs)
