"""The world: an env that nothing draws builds its world without visual geometry, and moves
the same, bit for bit."""

import gymnasium as gym
import numpy as np
import pytest
from pydrake.geometry import Role

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.robot.model import _baxter_without_visuals

STEPS = 40


def _observations(env_id: str, **kwargs) -> tuple[np.ndarray, int, int]:
    """STEPS observations of `env_id` under seeded random actions, and how many geometries
    the world's SceneGraph holds: all of them, and those with a proximity role."""
    env = gym.make(env_id, **kwargs)
    try:
        observation, _ = env.reset(seed=4)
        env.action_space.seed(4)
        observations = [observation]
        for _ in range(STEPS):
            observation, *_ = env.step(env.action_space.sample())
            observations.append(observation)
        inspector = env.unwrapped.world.scene_graph.model_inspector()
        colliding = inspector.NumGeometriesWithRole(Role.kProximity)
        return np.array(observations), inspector.num_geometries(), colliding
    finally:
        env.close()


@pytest.mark.parametrize("env_id", ["drake_tooluse/ToolPush-v1", "drake_tooluse/ToolPull-v1"])
def test_a_world_without_visuals_moves_the_same_bit_for_bit(env_id):
    drawn, with_visuals, colliding = _observations(env_id, render_mode="rgb_array")
    undrawn, without, colliding_undrawn = _observations(env_id)
    assert with_visuals > colliding + 44  # Baxter's 44 visuals, and the rest of the world's
    assert without == colliding_undrawn == colliding  # every collision geometry, nothing else
    np.testing.assert_array_equal(drawn, undrawn)


def test_the_urdf_without_visuals_keeps_every_link_joint_and_collision():
    urdf = _baxter_without_visuals()
    assert "<visual" not in urdf
    text = open(drake_tooluse.paths.BAXTER_URDF).read()
    for tag in ("<link", "<joint", "<collision", "<inertial"):
        assert urdf.count(tag) == text.count(tag), tag
