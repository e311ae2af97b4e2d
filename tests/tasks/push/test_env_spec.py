"""The push env's docstring is its spec (Gymnasium-Robotics' layout) and cannot drift from the
code: its sections, the action and observation tables of every mode against the env's spaces,
the arguments against `EnvConfig`, the rewards against the registered ids, the info keys
against a step's `info`, and the figures it quotes against the constants they come from."""

import ast
import dataclasses as dc
import inspect
import itertools

import gymnasium as gym
import numpy as np
import pytest

import drake_tooluse  # noqa: F401  (registers the ids)
from drake_tooluse.systems.tip_target import (
    ACTION_MODES,
    MAX_QUATERNION_STEP,
    MAX_ROTATION_STEP,
    MAX_TRANSLATION_STEP,
)
from drake_tooluse.tasks.push.env import EnvConfig, ToolPushEnv
from drake_tooluse.tasks.push.observation import OBSERVATION_SIZES
from drake_tooluse.tasks.push.registration import ENV_IDS, MAX_EPISODE_STEPS
from drake_tooluse.world.paper import SUCCESS_DISTANCE
from drake_tooluse.world.scenario import Scenario

SECTIONS = [
    "Description",
    "Action Space",
    "Observation Space",
    "Rewards",
    "Starting State",
    "Episode End",
    "Arguments",
    "Info",
    "Version History",
]


def split(text: str, marker: str) -> dict:
    """{heading: body} of the parts of `text` under lines starting with `marker`."""
    parts, title = {}, None
    for line in text.splitlines():
        if line.startswith(marker):
            title = line[len(marker) :].strip()
            parts[title] = []
        elif title is not None:
            parts[title].append(line)
    return {k: "\n".join(v) for k, v in parts.items()}


def table(text: str) -> list[list[str]]:
    """The rows (cells) of the Markdown table in `text`, header and rule left out."""
    rows = [
        [c.strip() for c in line.strip().strip("|").split("|")]
        for line in text.splitlines()
        if line.strip().startswith("|")
    ]
    return rows[2:]


def indices(cell: str) -> list[int]:
    if ":" in cell:
        a, b = cell.split(":")
        return list(range(int(a), int(b)))
    return [int(cell)]


DOC = inspect.getdoc(ToolPushEnv)
SPEC = split(DOC, "### ")


def test_the_docstring_has_the_sections_in_order():
    assert list(SPEC) == SECTIONS


def modes(section: str, name: str) -> dict:
    parts = split(SPEC[section], "#### ")
    return {k.removeprefix(f"{name} = "): v for k, v in parts.items()}


def test_every_action_mode_has_a_table_of_its_size():
    documented = modes("Action Space", "action_mode")
    assert set(documented) == set(ACTION_MODES)
    for mode, text in documented.items():
        rows = table(text)
        size = ToolPushEnv.spaces({"action_mode": mode})[1][0]
        assert [i for r in rows for i in indices(r[0])] == list(range(size)), mode
        for r in rows:  # the scale each index quotes is the one the target applies
            i = int(r[0])
            scale = (
                MAX_TRANSLATION_STEP
                if i < 3
                else MAX_ROTATION_STEP
                if mode == "pose"
                else MAX_QUATERNION_STEP
            )
            assert r[2] == f"[-1, 1] × {scale:.2f}", (mode, r)


def test_every_observation_mode_has_a_table_of_its_size():
    documented = modes("Observation Space", "observation_mode")
    assert set(documented) == set(OBSERVATION_SIZES)
    for mode, text in documented.items():
        rows = table(text)
        always = [i for r in rows if "(optional)" not in r[1] for i in indices(r[0])]
        every = [i for r in rows for i in indices(r[0])]
        kwargs = {"observation_mode": mode}
        assert always == list(range(ToolPushEnv.spaces(kwargs)[0][0])), mode
        with_length = {**kwargs, "include_tool_length": True}
        assert every == list(range(ToolPushEnv.spaces(with_length)[0][0])), mode


@pytest.mark.parametrize(
    "action_mode, observation_mode, include_tool_length",
    [
        ("position_quaternion", "gripper_joints", False),
        ("pose", "tip", True),
        ("position", "tip", False),
    ],
)
def test_a_built_env_has_the_spaces_its_class_gives(
    action_mode, observation_mode, include_tool_length
):
    kwargs = {
        "action_mode": action_mode,
        "observation_mode": observation_mode,
        "include_tool_length": include_tool_length,
    }
    env = gym.make("drake_tooluse/ToolPush-v1", **kwargs)
    try:
        obs, act = ToolPushEnv.spaces(kwargs)
        assert env.observation_space.shape == tuple(obs)
        assert env.action_space.shape == tuple(act)
    finally:
        env.close()


def test_every_combination_of_modes_has_the_documented_sizes():
    for a, o, n in itertools.product(ACTION_MODES, OBSERVATION_SIZES, (False, True)):
        obs, act = ToolPushEnv.spaces(
            {"action_mode": a, "observation_mode": o, "include_tool_length": n}
        )
        assert act == [ACTION_MODES[a]] and obs == [OBSERVATION_SIZES[o] + n]


def test_the_arguments_are_envconfigs_fields_with_their_defaults():
    rows = table(SPEC["Arguments"])
    fields = dc.fields(EnvConfig)
    assert [r[0] for r in rows] == [f.name for f in fields]
    for row, f in zip(rows, fields):
        assert ast.literal_eval(row[1]) == f.default, f.name


def test_the_rewards_name_every_registered_id_with_its_reward_type():
    rows = table(SPEC["Rewards"])
    assert {r[0].strip("`"): r[2] for r in rows} == {
        env_id: kwargs["reward_type"] for env_id, kwargs in ENV_IDS.items()
    }
    assert f"≤ {SUCCESS_DISTANCE:g} m" in SPEC["Rewards"]
    far = ENV_IDS["drake_tooluse/ToolPushFar-v1"]["goal_extra"]
    assert f"the goal {far:.2f} m further" in SPEC["Rewards"]


def test_the_episode_end_and_the_starting_state_quote_the_code():
    assert f"{MAX_EPISODE_STEPS} steps" in SPEC["Episode End"]
    s = Scenario()
    r = s.randomization
    start = " ".join(SPEC["Starting State"].split()).replace("−", "-")
    for figure in (
        f"±{r.box_xy:g} m",
        f"yaw ±{r.box_yaw:g} rad",
        f"mass × {r.box_mass_scale}",
        f"friction × {r.box_friction_scale}",
        f"±{r.grasp_along:g} m along",
        f"±{r.grasp_across:g} m across",
        f"({s.robot.home_tip_xy[0]:.2f}, {s.robot.home_tip_xy[1]:.2f}) m, "
        f"{s.robot.home_tip_height:.2f} m above",
        f"({s.box.position[0]:.2f}, {s.box.position[1]:.2f}) m on the table",
        f"the goal is {s.goal_offset[1]:.2f} m along +y",
    ):
        assert figure.replace("'", "") in start, figure


def test_the_info_keys_are_a_steps_info_keys_and_the_flags_quote_their_limits():
    rows = table(SPEC["Info"])
    env = gym.make("drake_tooluse/ToolPush-v1", action_mode="position")
    try:
        _, reset_info = env.reset(seed=0)
        info = env.step(np.zeros(3, np.float32))[-1]
    finally:
        env.close()
    assert [r[0] for r in rows] == list(info) == list(reset_info)
    meaning = {r[0]: r[1] for r in rows}
    for lim in ToolPushEnv.PHYSICAL_LIMITS:
        assert meaning[lim.flag] == f"{lim.info_key} past {lim.limit:g} {lim.unit}"
