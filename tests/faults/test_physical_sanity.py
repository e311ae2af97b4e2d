"""Physical sanity as data: the push env reports, every step, how far the tool and the gripper
are inside the table, the box's speed and the fastest arm joint's, and flags what is past the
task's limits (`tasks.sanity`); evaluation counts the flagged episodes per flag; the joint
targets' bound at Baxter's rated speeds keeps extreme actions from driving the tool into the
table."""

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw

import drake_tooluse  # noqa: F401  (registers the ids)
from drake_tooluse.cli import main
from drake_tooluse.learning.evaluate import evaluate
from drake_tooluse.paths import SHIPPED_POLICY
from drake_tooluse.robot.baxter_model import V_MAX
from drake_tooluse.robot.ik import pose_to_vector
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.systems.tool_tip_ik import ToolTipIKSystem
from drake_tooluse.tasks import sanity
from drake_tooluse.tasks.contract import PhysicalLimit
from drake_tooluse.tasks.push.env import ToolPushEnv

ENV = "drake_tooluse/ToolPush-v1"  # joint targets bounded at Baxter's rated speeds
FIGURES = [lim.info_key for lim in ToolPushEnv.PHYSICAL_LIMITS]
FLAGS = [lim.flag for lim in ToolPushEnv.PHYSICAL_LIMITS]
# Bang-bang actions (±1 in every component) from this generator seed drove an unbounded arm's
# tool into the table within 120 steps (at step 83 when measured, at git tag figures-v0).
EXTREME_SEED, EXTREME_STEPS = 3, 120


def extreme_run(env_id: str, steps: int = EXTREME_STEPS) -> list[dict]:
    env = gym.make(env_id)
    rng = np.random.default_rng(EXTREME_SEED)
    infos = [env.reset(seed=EXTREME_SEED)[1]]
    try:
        for _ in range(steps):
            a = rng.choice([-1.0, 1.0], size=env.action_space.shape[0]).astype(np.float32)
            infos.append(env.step(a)[-1])
    finally:
        env.close()
    return infos


@pytest.fixture(scope="module")
def extreme():
    return extreme_run(ENV)


def test_every_limit_is_a_named_constant_with_a_reason():
    assert [lim.limit for lim in sanity.PHYSICAL_LIMITS] == [
        sanity.TABLE_PENETRATION_LIMIT,
        sanity.TABLE_PENETRATION_LIMIT,
        sanity.OBJECT_SPEED_LIMIT,
        sanity.ARM_JOINT_SPEED_LIMIT,
    ]
    for lim in ToolPushEnv.PHYSICAL_LIMITS:
        assert isinstance(lim, PhysicalLimit) and lim.why and lim.limit > 0


def test_every_step_reports_the_figures_and_their_flags(extreme):
    for info in extreme:
        for key in FIGURES:
            assert np.isfinite(info[key]) and info[key] >= 0.0
        for lim in ToolPushEnv.PHYSICAL_LIMITS:
            assert info[lim.flag] is (info[lim.info_key] > lim.limit)


def limit_at_zero(monkeypatch, flag: str) -> None:
    """The task's limit of `flag` at 0: every step whose figure is above zero is past it."""
    strict = tuple(
        PhysicalLimit(lim.flag, lim.info_key, 0.0, lim.unit, lim.why) if lim.flag == flag else lim
        for lim in sanity.PHYSICAL_LIMITS
    )
    monkeypatch.setattr(sanity, "PHYSICAL_LIMITS", strict)


def test_a_step_past_a_limit_says_so(monkeypatch):
    limit_at_zero(monkeypatch, "arm_too_fast")  # flags every step in which the arm moves
    infos = extreme_run(ENV, steps=3)
    assert not infos[0]["arm_too_fast"]  # at rest after the reset
    assert all(i["arm_too_fast"] and i["arm_joint_speed"] > 0.0 for i in infos[1:])


def test_on_extreme_actions_the_bounded_arm_stays_out_of_the_table(extreme):
    assert not any(i["tool_in_table"] or i["gripper_in_table"] for i in extreme)
    assert max(i["tool_table_penetration"] for i in extreme) < sanity.TABLE_PENETRATION_LIMIT
    # The arm follows its targets at the rated speeds, within the PD's overshoot.
    assert max(i["arm_joint_speed"] for i in extreme) < 1.01 * max(V_MAX)


def test_the_bound_moves_each_joint_target_at_most_its_rated_speed_per_solve(posed_env):
    ik, q0 = posed_env.control.ik, posed_env.control.q0
    X = ik.fk(q0)
    far = RigidTransform(X.rotation(), X.translation() + [0.0, 0.15, -0.05])  # one solve away
    answer = ik.solve(far, q_seed=q0).q
    for bound, expected in ((None, answer), (V_MAX, None)):
        system = ToolTipIKSystem(ik, q0, 0.04, bound)
        context = system.CreateDefaultContext()
        system.GetInputPort("tip_pose_desired").FixValue(context, pose_to_vector(far))
        q = system.EvalUniquePeriodicDiscreteUpdate(context).get_vector(0).value()[:7]
        if bound is None:
            np.testing.assert_allclose(q, expected, atol=1e-9)
        else:
            step = np.abs(q - q0)
            assert np.all(step <= V_MAX * 0.04 + 1e-12) and np.any(step > V_MAX * 0.04 - 1e-12)
            assert np.all(np.sign(q - q0) == np.sign(answer - q0))


@pytest.mark.parametrize("bound", [[1.0] * 6, [1.0] * 6 + [0.0], [np.inf] * 7])
def test_a_bad_joint_speed_bound_is_refused(posed_env, bound):
    ik, q0 = posed_env.control.ik, posed_env.control.q0
    with pytest.raises(ValueError, match=r"max_joint_speed=.* must be 7 finite values > 0 rad/s"):
        ToolTipIKSystem(ik, q0, 0.04, bound)


@pytest.fixture(scope="module", params=[False, True], ids=["nominal", "randomized"])
def posed_env(request):
    """An env after a reset; randomized: the true grasp is off the believed one (by up to
    1 cm along the tool), so the tool's pose in the hand is the episode's, not the model's."""
    env = ToolPushEnv(randomize=request.param)
    env.reset(seed=3)
    yield env
    env.close()


def put_tip_at(env, p_WT) -> None:
    """The arm where the (true = believed) tool's tip is at p_WT, pointing straight down."""
    X = RigidTransform(RollPitchYaw(*TOOL_DOWN_RPY), p_WT)
    result = env.control.ik.solve(X, q_seed=env.control.q0)
    assert result.success
    plant = env.world.plant
    context = plant.GetMyMutableContextFromRoot(env.simulator.get_mutable_context())
    for joint, q in zip(env.world.arm_joints(), result.q):
        joint.set_angle(context, q)


@pytest.mark.parametrize("depth", [0.0, 0.01, 0.03, 0.08])
def test_the_tools_depth_in_the_table_is_the_true_tips_depth_below_its_top(posed_env, depth):
    env = posed_env
    top = env.scenario.table.top_z
    put_tip_at(env, [0.70, -0.20, top - depth])
    context = env.world.plant.GetMyContextFromRoot(env.simulator.get_context())
    x = env.world.plant.GetPositionsAndVelocities(context)
    figures = env._sanity_reader.read(context, x)
    # The tool points straight down: its lowest point is the true tip.
    true_tip_z = env.world.tip_frame.CalcPoseInWorld(context).translation()[2]
    assert figures["tool_table_penetration"] == pytest.approx(max(0.0, top - true_tip_z), abs=1e-9)
    assert abs(true_tip_z - (top - depth)) < 0.011
    assert figures["gripper_table_penetration"] == 0.0  # the gripper is 0.175 m higher


def test_off_the_tables_footprint_nothing_is_in_the_table(posed_env):
    env = posed_env
    s = env.scenario.table
    put_tip_at(env, [s.center_xy[0] - s.size_xy[0] / 2 - 0.05, -0.30, s.top_z - 0.03])
    context = env.world.plant.GetMyContextFromRoot(env.simulator.get_context())
    x = env.world.plant.GetPositionsAndVelocities(context)
    assert env._sanity_reader.read(context, x)["tool_table_penetration"] == 0.0


def test_the_speeds_are_the_plants():
    env = ToolPushEnv()
    rng = np.random.default_rng(1)
    env.reset(seed=1)
    try:
        for _ in range(5):
            info = env.step(rng.choice([-1.0, 1.0], size=7))[-1]
        plant = env.world.plant
        context = plant.GetMyContextFromRoot(env.simulator.get_context())
        v_box = env.world.box.EvalSpatialVelocityInWorld(context).translational()
        v_arm = [j.get_angular_rate(context) for j in env.world.arm_joints()]
        assert info["object_speed"] == pytest.approx(np.linalg.norm(v_box), rel=1e-12, abs=1e-15)
        assert info["arm_joint_speed"] == pytest.approx(np.max(np.abs(v_arm)), rel=1e-12)
    finally:
        env.close()


def test_evaluation_counts_the_flagged_episodes_per_flag(monkeypatch):
    limit_at_zero(monkeypatch, "object_too_fast")  # flags every episode in which the box moves
    result = evaluate(SHIPPED_POLICY, episodes=2, seed=1000).as_dict()
    assert result["flagged_episodes"] == {
        "tool_in_table": 0,
        "gripper_in_table": 0,
        "object_too_fast": 2,
        "arm_too_fast": 0,
    }
    for row in result["per_episode"]:
        assert row["object_too_fast"] is True and row["peak_object_speed"] > 0.0
        assert row["peak_tool_table_penetration"] < sanity.TABLE_PENETRATION_LIMIT


def test_evaluate_json_shows_the_counts(capsys):
    code = main(
        ["evaluate", "--policy", str(SHIPPED_POLICY), "--episodes", "1", "--json", "--no-progress"]
    )
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["flagged_episodes"] == dict.fromkeys(FLAGS, 0)


def test_a_shipped_policys_episodes_stay_inside_the_limits():
    meta = json.loads((Path(SHIPPED_POLICY) / "policy.json").read_text())
    assert meta["env_id"] == ENV
    result = evaluate(SHIPPED_POLICY, episodes=3, seed=0)
    assert result.flagged_episodes == dict.fromkeys(FLAGS, 0)
