"""docs/ARCHITECTURE.md's "Add a tool" as a test: a toy L-shaped tool defined in the tests (an
SDFormat file, tests/tasks/data/toy_l_tool.sdf) goes into the world by a scenario line, the
robot believes it, the IK solves for any of its named frames, and the toy task trains with it —
with no edit outside the test's own files."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import DiagramBuilder

from drake_tooluse.builders.control import add_world_at_home, nominal_belief
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.learning.train import train
from drake_tooluse.paths import DEFAULT_SCENARIO
from drake_tooluse.robot.ik import ToolTipIK
from drake_tooluse.robot.model import load_tool_model
from drake_tooluse.robot.tool import Tool
from drake_tooluse.world.scenario import load_scenario
from tests.tasks import toy_touch

TOY_TOOL = toy_touch.__file__.replace("toy_touch.py", "data/toy_l_tool.sdf")


@pytest.fixture
def scenario_file(tmp_path):
    """A scenario on top of the push task's, with the toy tool in the hand (one line)."""
    path = tmp_path / "toy_tool.yaml"
    path.write_text(f"base: {DEFAULT_SCENARIO}\ntool: {{model: {TOY_TOOL}}}\n")
    return path


def test_the_toy_tool_is_a_geometry_with_named_frames():
    tool = load_tool_model(TOY_TOOL)
    assert isinstance(tool, Tool) and {"tool_tip", "corner"} <= set(tool.frame_names())
    assert np.allclose(tool.X_HF("tool_tip").translation, [0.05, 0.0, 0.15])
    assert np.isclose(tool.reach(), np.hypot(0.05, 0.15))


def test_the_world_holds_it_and_the_ik_solves_for_any_of_its_frames(scenario_file):
    scenario = load_scenario(scenario_file)
    belief = nominal_belief(scenario)
    builder = DiagramBuilder()
    world, ik, q0 = add_world_at_home(builder, scenario, belief)
    assert world.plant.HasFrameNamed("corner") and world.tool is not None
    X_WT = RigidTransform(RollPitchYaw(np.pi, 0, np.pi / 2), [0.65, -0.25, -0.10])
    for frame in ("tool_tip", "corner"):
        frame_ik = ToolTipIK(belief.tool, frame=frame)
        result = frame_ik.solve(X_WT, q_seed=q0)
        assert result.success and result.position_error < 1e-5, frame
    # The tip and the corner are different points: the same q puts them 5 cm apart.
    q = ToolTipIK(belief.tool).solve(X_WT, q_seed=q0).q
    p_tip = ToolTipIK(belief.tool).fk(q).translation()
    p_corner = ToolTipIK(belief.tool, frame="corner").fk(q).translation()
    assert np.linalg.norm(p_tip - p_corner) == pytest.approx(0.05, abs=1e-9)


@pytest.mark.slow  # ~1.2-2.4 s: with the slow tests CI runs
def test_the_toy_task_trains_with_the_toy_tool(scenario_file, tmp_path):
    toy_touch.register()
    env = gym.make(toy_touch.ENV_ID, scenario=str(scenario_file))
    check_env(env.unwrapped, skip_render_check=True)
    env.close()
    overrides = {"env_kwargs": {"scenario": str(scenario_file)}, **toy_touch.TINY_PPO}
    config = resolve_config(toy_touch.ENV_ID, "ppo", 256, 1, 0, overrides=overrides)
    summary = train(config, tmp_path / "run", progress_bar=False)
    assert summary["timesteps"] >= 256 and (tmp_path / "run" / "final").is_dir()
