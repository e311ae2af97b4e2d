"""`render_mode="rgb_array"`: frames that show the task (the whole robot, tool, box and the goal
drawn), a camera and image size of one's choosing, checked; and rendering changes no physics."""

import gymnasium as gym
import numpy as np
import pytest
from pydrake.geometry import Meshcat
from pydrake.gym import DrakeGymEnv

import drake_tooluse  # noqa: F401  (registers the ids)
from drake_tooluse.systems.camera import GOAL_RGB

ENV = "drake_tooluse/ToolPush-v1"


@pytest.fixture(scope="module")
def rendered():
    """An rgb_array env after reset(seed=0), its frame, and the frame without the goal."""
    env = gym.make(ENV, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    raw = np.asarray(DrakeGymEnv.render(env.unwrapped))[:, :, :3]
    yield env.unwrapped, frame, raw
    env.close()


def _pixel(env, p_W):
    (uv,), front = env._scene_view.project([p_W])
    assert front.all()
    return np.rint(uv).astype(int)


def _borders_are_sky(image) -> bool:
    """The top, left and right borders of `image` are all the background's one colour."""
    sky = image[0, 0].astype(int)
    return all(
        np.abs(border.astype(int) - sky).max() <= 3
        for border in (image[:2], image[:, :2], image[:, -2:])
    )


def test_the_border_check_sees_a_cut_robot():
    """The camera the env had before (in front, below the head, nearer) cuts the robot's head
    and arms: the check above tells."""
    env = gym.make(
        ENV,
        render_mode="rgb_array",
        render_camera_position=(1.35, -0.85, 0.35),
        render_camera_target=(0.55, -0.15, -0.12),
    )
    env.reset(seed=0)
    e = env.unwrapped
    assert not _borders_are_sky(np.asarray(DrakeGymEnv.render(e))[:, :, :3])
    env.close()


def test_the_default_frame_holds_the_whole_robot_and_the_task(rendered):
    env, frame, raw = rendered
    h, w = frame.shape[:2]
    assert (w, h) == (640, 480)
    # Nothing is cut at the top or the sides: those borders are all background (the sky's one
    # colour), so the robot, head and arms included, lies inside the image.
    assert _borders_are_sky(raw)
    # The tool's tip, the box and the goal project well inside the image.
    plant_context = env.world.plant.GetMyContextFromRoot(env._context)
    points = {
        "tool tip": env.world.tip_frame.CalcPoseInWorld(plant_context).translation(),
        "box": env.world.box.EvalPoseInWorld(plant_context).translation(),
        "goal": env._episode["goal"],
    }
    for name, p in points.items():
        u, v = _pixel(env, p)
        assert 20 <= u < w - 20 and 20 <= v < h - 20, (name, u, v)


def test_the_goal_is_drawn_at_the_episode_goal_and_nowhere_else(rendered):
    env, frame, raw = rendered
    goal = env._episode["goal"]
    u, v = _pixel(env, [goal[0], goal[1], env.scenario.table.top_z])
    changed = np.abs(frame.astype(int) - raw.astype(int)).sum(axis=2) > 30
    assert changed[v - 2 : v + 3, u - 2 : u + 3].all()
    assert np.allclose(frame[v, u], GOAL_RGB, atol=40)  # the cross at x*, green
    rows, cols = np.nonzero(changed)  # the disc and the word "goal" beside it
    assert np.abs(rows - v).max() < 40 and cols.min() > u - 40 and cols.max() < u + 120


def test_what_stands_in_front_of_the_goal_stays_in_front():
    from drake_tooluse.systems.camera import draw_goal

    env = gym.make(ENV, render_mode="rgb_array", render_size=(320, 240))
    env.reset(seed=0)
    e = env.unwrapped
    raw = np.asarray(DrakeGymEnv.render(e))[:, :, :3]
    depth = e._scene_depth.Eval(e._scene_depth.get_system().GetMyContextFromRoot(e._context)).data
    box = e.world.box.EvalPoseInWorld(e.world.plant.GetMyContextFromRoot(e._context))
    p_box = box.translation()
    z = e.scenario.table.top_z
    u, v = _pixel(e, p_box)
    # A goal drawn under the box: the box's pixels stay as rendered with the depth image,
    # and are painted over without it.
    with_depth = draw_goal(raw, e._scene_view, [p_box[0], p_box[1], z], 0.05, depth)
    without = draw_goal(raw, e._scene_view, [p_box[0], p_box[1], z], 0.05)
    assert np.array_equal(
        with_depth[v - 1 : v + 2, u - 1 : u + 2], raw[v - 1 : v + 2, u - 1 : u + 2]
    )
    assert not np.array_equal(
        without[v - 1 : v + 2, u - 1 : u + 2], raw[v - 1 : v + 2, u - 1 : u + 2]
    )
    env.close()


def test_render_size_and_camera_are_the_caller_s():
    kwargs = dict(render_mode="rgb_array", render_size=[160, 96])
    env = gym.make(ENV, **kwargs)
    env.reset(seed=0)
    near = env.render()
    assert near.shape == (96, 160, 3) and near.dtype == np.uint8
    env.close()
    env = gym.make(
        ENV, **kwargs, render_camera_position=[0.7, -0.9, 0.3], render_camera_target=[0.7, 0, -0.2]
    )
    env.reset(seed=0)
    side = env.render()
    assert side.shape == near.shape and np.abs(side.astype(int) - near.astype(int)).mean() > 10
    env.close()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"render_size": (16, 480)},
            r"render_size=\(16, 480\) px: each side must be in \[32, 2048\]",
        ),
        ({"render_size": (640.0, 480)}, r"render_size=\(640.0, 480\) must be \(width, height\)"),
        ({"render_size": 640}, "must be \\(width, height\\), two integers"),
        (
            {"render_camera_position": [1, 2]},
            r"render_camera_position=\[1, 2\] must be 3 finite numbers",
        ),
        (
            {"render_camera_target": [0, float("nan"), 0]},
            "render_camera_target=.* must be 3 finite numbers",
        ),
        ({"render_camera_position": [50, 0, 0]}, r"is outside \[-10, 10\] m per coordinate"),
        (
            {"render_camera_position": [0.4, -0.1, 0.1]},
            "are 0 m apart; they must be at least 0.05 m apart",
        ),
        ({"render_camera_position": [0.4, -0.1, 2.0]}, "looks straight up or down"),
    ],
)
def test_bad_render_settings_are_one_line_errors(kwargs, message):
    with pytest.raises(ValueError, match=message) as e:
        gym.make(ENV, render_mode="rgb_array", **kwargs)
    assert "\n" not in str(e.value)


def test_rendering_changes_nothing_of_the_physics():
    """The same actions from the same seed: an env that renders every step (the goal drawn
    on its images) and one that does not give bit-identical observations and rewards."""
    plain = gym.make(ENV)
    shown = gym.make(ENV, render_mode="rgb_array", render_size=(64, 48))
    actions = np.random.default_rng(3).uniform(-1, 1, (6, 7)).astype(np.float32)
    a, _ = plain.reset(seed=5)
    b, _ = shown.reset(seed=5)
    assert np.array_equal(a, b)
    for action in actions:
        shown.render()
        a, ra, *_ = plain.step(action)
        b, rb, *_ = shown.step(action)
        assert np.array_equal(a, b) and ra == rb
    plain.close()
    shown.close()


def test_an_env_made_with_a_meshcat_resets_and_steps():
    """The guide's example (docs/guide/simulation.md): an env drawing its episodes in a Meshcat of one's own."""
    meshcat = Meshcat()
    env = gym.make(ENV, meshcat=meshcat)
    observation, info = env.reset(seed=0)
    for _ in range(3):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert np.isfinite(observation).all() and not info["sim_error"]
    assert meshcat.HasPath("/drake/visualizer")  # the robot drawn there
    env.close()
