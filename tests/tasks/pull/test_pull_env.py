"""drake_tooluse/ToolPull-v1: registered on import, a Gymnasium and an SB3 env, its docstring
its spec, a hook drawn per episode (or fixed), a success that needs the cube moved, a reward as
documented, and a scripted pull that succeeds."""

import math
import re

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import drake_tooluse
from drake_tooluse.learning.task_envs import check_env_kwargs, env_spaces, task_env_ids
from drake_tooluse.paths import PULL_SCENARIO
from drake_tooluse.robot.tool import HOOK_ANGLE_RANGE, HOOK_HANDLE_RANGE, HOOK_LENGTH_RANGE
from drake_tooluse.tasks.pull.env import ToolPullEnv
from drake_tooluse.tasks.pull.metrics import MIN_TRAVEL, SUCCESS_RADIUS, is_success
from drake_tooluse.tasks.pull.observation import CORNER, HOOK, OBSERVATION_SIZE
from drake_tooluse.tasks.pull.scripted import ScriptedPull
from drake_tooluse.world.randomization import apply_draw, draw_randomization
from drake_tooluse.world.scenario import load_scenario
from drake_tooluse.world.scene import initial_box_pose

ENV_ID = "drake_tooluse/ToolPull-v1"
FIXED_HOOK = (0.25, 0.05, 90.0)


@pytest.fixture(scope="module")
def env():
    env = gym.make(ENV_ID)
    yield env
    env.close()


def test_the_env_is_registered_on_import_and_follows_the_task_contract():
    assert ENV_ID in drake_tooluse.ENV_IDS and ENV_ID in task_env_ids()
    assert gym.spec(ENV_ID).max_episode_steps == 100
    assert env_spaces(ENV_ID, {}) == ([OBSERVATION_SIZE], [3])
    assert check_env_kwargs(ENV_ID, {"hook": FIXED_HOOK}) == {"hook": FIXED_HOOK}


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"hook": (0.10, 0.05, 90.0)}, r"hook\[0\] \(handle length\)=0.1 m is outside"),
        ({"hook": (0.25, 0.09, 90.0)}, r"hook\[1\] \(hook length\)=0.09 m is outside"),
        ({"hook": (0.25, 0.05, 130.0)}, r"hook\[2\] \(hook angle\)=130"),
        ({"hook": 0.25}, r"hook=0.25 must be \(handle length m, hook length m, angle °\)"),
        ({"tool_length": 0.2}, r"unknown argument\(s\) \['tool_length'\]"),
        ({"randomize": "yes"}, r"randomize"),
    ],
)
def test_bad_arguments_are_refused_naming_the_value(kwargs, message):
    with pytest.raises(ValueError, match=message):
        check_env_kwargs(ENV_ID, kwargs)


def test_gymnasium_and_sb3_env_checkers_pass():
    env = gym.make(ENV_ID)  # hooks drawn per episode: the checkers' resets rebuild the world
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped)
    env.close()


def _section(doc: str, title: str) -> str:
    # Python 3.13 strips a docstring's indentation and 3.11 does not: any indent before `##`.
    match = re.search(rf"## {title}\n(.*?)(?=\n[ \t]*## |\Z)", doc, re.S)
    assert match, f"the docstring has no '## {title}' section"
    return match.group(1)


def test_the_docstring_is_the_spec_and_its_dimensions_match_the_spaces(env):
    doc = ToolPullEnv.__doc__
    for title in (
        "Description",
        "Action Space",
        "Observation Space",
        "Rewards",
        "Starting State",
        "Episode End",
        "Arguments",
        "Info",
    ):
        _section(doc, title)
    action = re.search(
        r"Box\(([-\d.]+), ([-\d.]+), \((\d+),\), float32\)", _section(doc, "Action Space")
    )
    low, high, size = float(action[1]), float(action[2]), int(action[3])
    space = env.action_space
    assert space.shape == (size,) and np.all(space.low == low) and np.all(space.high == high)
    observation = _section(doc, "Observation Space")
    assert int(re.search(r"Box\(-inf, inf, \((\d+),\), float32\)", observation)[1]) == 16
    assert env.observation_space.shape == (16,) and env.observation_space.dtype == np.float32
    # The table's rows cover indices 0 … 15, each once.
    indices = []
    for row in re.findall(r"^\s*\| (\d+)(?:–(\d+))? \|", observation, re.M):
        first = int(row[0])
        indices += list(range(first, int(row[1] or first) + 1))
    assert indices == list(range(env.observation_space.shape[0]))
    info = _section(doc, "Info")
    _, step_info = env.reset(seed=0)
    assert {k for k in step_info} == set(re.findall(r"`(\w+)`", info))


def test_each_episode_draws_a_hook_the_observation_holds_as_the_robot_believes_it(env):
    hooks = []
    for seed in range(4):
        observation, info = env.reset(seed=seed)
        handle, length, angle = info["hook"]
        assert HOOK_HANDLE_RANGE[0] <= handle <= HOOK_HANDLE_RANGE[1]
        assert HOOK_LENGTH_RANGE[0] <= length <= HOOK_LENGTH_RANGE[1]
        assert HOOK_ANGLE_RANGE[0] <= angle <= HOOK_ANGLE_RANGE[1]
        assert np.allclose(observation[HOOK], [handle, length, math.radians(angle)], atol=1e-6)
        hooks.append(info["hook"])
    assert len(set(hooks)) == 4  # a new hook each episode
    again, info = env.reset(seed=2)  # a seed gives its hook and start again
    assert info["hook"] == hooks[2]
    assert np.array_equal(again, env.reset(seed=2)[0])


def test_a_fixed_hook_holds_in_every_episode_and_the_corner_observed_is_the_true_one():
    env = gym.make(ENV_ID, hook=FIXED_HOOK, randomize=False)
    for seed in (0, 1):
        observation, info = env.reset(seed=seed)
        assert info["hook"] == FIXED_HOOK
        world = env.unwrapped.world
        plant_context = world.plant.GetMyContextFromRoot(env.unwrapped.simulator.get_context())
        p_WC = world.plant.GetFrameByName("hook_corner").CalcPoseInWorld(plant_context)
        # Belief = truth here (no grasp randomization): the corner the robot computes is the
        # world's.
        assert np.allclose(observation[CORNER], p_WC.translation(), atol=1e-6)
    env.close()


def test_no_start_meets_the_success_criterion():
    """Over 500 drawn starts: every cube starts farther than SUCCESS_RADIUS from its goal
    and has not moved, so no episode succeeds unless the cube is moved."""
    scenario = load_scenario(PULL_SCENARIO)
    rng = np.random.default_rng(0)
    nearest = np.inf
    for _ in range(500):
        s = apply_draw(scenario, draw_randomization(scenario, rng))
        start = initial_box_pose(s).translation()
        goal = start + np.asarray(s.goal_offset, float)
        nearest = min(nearest, float(np.linalg.norm(start - goal)))
        assert not is_success(float(np.linalg.norm(start - goal)), 0.0)
    assert nearest > SUCCESS_RADIUS + MIN_TRAVEL  # by a margin: 0.20 m
    # The criterion is not vacuous: a cube moved onto its goal meets it.
    assert is_success(0.0, nearest)


@pytest.mark.parametrize("policy", ["zero", "random"])
def test_idle_and_random_actions_never_succeed(env, policy):
    """Full episodes (to the step limit) of zero and of uniform random actions: no step of
    any succeeds, while the scripted pull succeeds on the same seeds (the next test)."""
    rng = np.random.default_rng(7)
    for seed in range(3):
        env.reset(seed=seed)
        truncated, steps = False, 0
        while not truncated:
            action = np.zeros(3) if policy == "zero" else rng.uniform(-1, 1, 3)
            _, reward, terminated, truncated, info = env.step(action)
            assert not terminated and not info["is_success"] and not info["sim_error"]
            assert reward == pytest.approx(-(info["object_to_goal"] + info["corner_to_behind"]))
            steps += 1
        assert steps == 100


def test_the_scripted_pull_succeeds_with_the_drawn_hooks(env):
    successes = []
    for seed in range(3):
        observation, info = env.reset(seed=seed)
        start = info["object_to_goal"]
        policy = ScriptedPull(env.unwrapped.scenario.table.top_z)
        truncated = False
        while not truncated:
            observation, _, _, truncated, info = env.step(policy(observation))
        successes.append(info["is_success"])
        assert (
            info["tool_touched_object_in_episode"] and not info["gripper_touched_object_in_episode"]
        )
        assert info["object_to_goal"] < start
    assert sum(successes) >= 2, successes


def test_the_diagrams_reward_and_success_ports_agree_with_the_step(env):
    """The step reads the metrics from the plant directly; the task's exported `reward` and
    `success` ports (`PullOutcome`, the contract's) give the same values."""
    observation, _ = env.reset(seed=1)
    policy = ScriptedPull(env.unwrapped.scenario.table.top_z)
    diagram = env.unwrapped.diagram
    successes = 0
    for _ in range(100):
        observation, reward, _, _, info = env.step(policy(observation))
        context = env.unwrapped.simulator.get_context()
        assert diagram.GetOutputPort("reward").Eval(context)[0] == pytest.approx(reward, abs=1e-12)
        success = diagram.GetOutputPort("success").Eval(context)[0]
        assert success == float(info["is_success"])
        successes += info["is_success"]
    assert successes > 0  # the success port was seen at 1.0 too


def test_rgb_array_renders_the_scene():
    env = gym.make(ENV_ID, hook=FIXED_HOOK, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 1.0  # not a blank image
    env.close()


def test_an_actuation_delay_range_draws_each_episodes_delay_after_its_hook():
    """As the push env's: each episode's world is built with a delay drawn from the plant-step
    multiples in the range, after its hook, from the env's seeded generator (the hooks are
    those of the env without the range: the draws before it are the same); a fixed hook is
    rebuilt per episode to take its delay. The arm then answers an action that much later."""
    plain = gym.make("drake_tooluse/ToolPull-v1")
    delayed = gym.make("drake_tooluse/ToolPull-v1", actuation_delay_range=[0, 0.06])
    delays = set()
    for seed in range(6):
        plain.reset(seed=seed)
        delayed.reset(seed=seed)
        assert delayed.unwrapped.hook == plain.unwrapped.hook
        delays.add(delayed.unwrapped.scenario.control.actuation_delay)
    assert delays <= {0.0, 0.02, 0.04, 0.06} and len(delays) > 1
    plain.close()

    def corner_after_one_step(**kwargs):
        env = gym.make("drake_tooluse/ToolPull-v1", hook=(0.25, 0.05, 90), **kwargs)
        obs0, _ = env.reset(seed=0)
        obs, *_ = env.step(np.array([0.0, 1.0, 0.0], np.float32))
        env.close()
        return obs[7:10] - obs0[7:10]  # the hook corner's motion in the step

    prompt = corner_after_one_step()
    late = corner_after_one_step(actuation_delay_range=[0.05, 0.07])  # 0.06 s only
    assert np.linalg.norm(late) < 0.5 * np.linalg.norm(prompt)
    with pytest.raises(ValueError, match=r"actuation_delay_range\[1\]=0.5 s is outside"):
        gym.make("drake_tooluse/ToolPull-v1", actuation_delay_range=[0.0, 0.5])
    with pytest.raises(ValueError, match=r"holds no multiple of the plant's time step"):
        check_env_kwargs("drake_tooluse/ToolPull-v1", {"actuation_delay_range": [0.005, 0.015]})
