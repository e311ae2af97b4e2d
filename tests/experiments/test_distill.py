"""`experiments.distill`: the student starts as its teacher, with the paper's 7-d action; one
DAgger round writes a policy directory that loads and acts; a teacher it cannot widen is a
one-line usage error; a stopped distillation goes on to the student it would have made."""

import dataclasses as dc
import re

import gymnasium as gym
import numpy as np
import pytest
import torch

from drake_tooluse.cli import main
from drake_tooluse.experiments.distill import (
    PROGRESS,
    DistillConfig,
    Expert,
    action_mean,
    check_teacher,
    distill,
    resume_distill,
    student_of,
)
from drake_tooluse.learning.policy_dir import LoadedPolicy, load_policy
from drake_tooluse.paths import POLICIES_DIR
from drake_tooluse.tasks.push.env import ToolPushEnv
from tests.cli.test_errors import assert_one_line_error

TEACHER = POLICIES_DIR / "ppo_toolpush"


@pytest.fixture(scope="module")
def teacher():
    return load_policy(TEACHER)


def test_the_widened_student_acts_as_its_teacher_and_turns_nothing(teacher):
    model, meta = student_of(teacher, DistillConfig(), "test")
    assert meta.action_shape == [7]
    assert meta.env_kwargs["action_mode"] == "position_quaternion"
    assert "continuous_quaternion" not in meta.env_kwargs  # no option: the one behaviour
    observations = np.random.default_rng(0).normal(size=(5, 30)).astype(np.float32)
    for observation in observations:
        ours = action_mean(LoadedPolicy(model, meta, teacher.obs_rms), observation)
        np.testing.assert_allclose(ours[:3], action_mean(teacher, observation), rtol=1e-6)
        np.testing.assert_array_equal(ours[3:], np.zeros(4))


def test_the_expert_turns_the_tip_back_to_its_initial_orientation(teacher):
    env = ToolPushEnv(action_mode="position_quaternion")
    try:
        observation, _ = env.reset(seed=0)
        expert = Expert(teacher, "position_quaternion")
        assert np.abs(expert(env, observation)[3:]).max() < 1e-3  # at home: nothing to turn
        for _ in range(20):  # pushes with the tip turned: the expert turns it back
            observation, *_ = env.step(np.array([0.5, 0.5, -0.3, 0.0, 0.4, 0.0, 0.0]))
        turn = expert(env, observation)[3:]
        assert np.abs(turn).max() == 1.0  # farther than one step's change reaches
        for _ in range(15):
            observation, *_ = env.step(np.concatenate([[0.0, 0.0, 0.0], turn]))
            turn = expert(env, observation)[3:]
        assert np.abs(turn).max() < 0.2  # back within 0.01 of each initial component
    finally:
        env.close()


def test_one_round_writes_a_policy_that_loads_and_acts(teacher, tmp_path):
    logged = []
    out = distill(
        TEACHER,
        tmp_path / "student",
        DistillConfig(rounds=2, episodes=1, epochs=2),
        log=logged.append,
    )
    assert [r["acting"] for r in out["rounds"]] == ["expert", "student"]
    assert logged == out["rounds"] and out["rounds"][-1]["samples"] == 200
    student = load_policy(tmp_path / "student")
    assert student.meta.action_shape == [7]
    env = gym.make(student.meta.env_id, **student.meta.env_kwargs)
    try:
        observation, _ = env.reset(seed=1)
        action = student.act(observation)
        assert action.shape == (7,) and np.all(np.abs(action) <= 1)
    finally:
        env.close()


def test_a_teacher_it_cannot_widen_is_refused(capsys, tmp_path):
    with pytest.raises(ValueError, match="action_mode 'position'; this one is .* 'position_quat"):
        check_teacher(load_policy(POLICIES_DIR / "ppo_toolpush_paper_action"))
    assert_one_line_error(
        capsys,
        ["distill", "--teacher", POLICIES_DIR / "ppo_toolpull", "--out", tmp_path / "s"],
        r"--teacher '.*ppo_toolpull': distill needs a tool-tip position teacher .* the pull task",
    )
    assert_one_line_error(
        capsys,
        ["distill", "--teacher", TEACHER, "--out", tmp_path / "s", "--action-mode", "pose"],
        r"--action-mode",
    )
    assert_one_line_error(
        capsys,
        ["distill", "--teacher", TEACHER, "--out", tmp_path / "s", "--rounds", "0"],
        r"--rounds",
    )
    assert_one_line_error(
        capsys,
        ["distill", "--teacher", TEACHER, "--out", tmp_path / "s", "--learning-rate", "0"],
        r"--learning-rate=0 is outside the allowed range \[1e-07, 1\]",
    )
    assert_one_line_error(
        capsys,
        ["distill", "--teacher", TEACHER, "--out", tmp_path / "s", "--env-kwargs", '{"x": 1}'],
        r"unknown argument\(s\) \['x'\]",
    )


def test_the_tip_observation_made_of_the_papers_is_the_tip_envs():
    paper = ToolPushEnv(action_mode="position")
    tip = ToolPushEnv(action_mode="position", observation_mode="tip")
    try:
        observation, _ = paper.reset(seed=4)
        tip_observation, _ = tip.reset(seed=4)
        actions = np.random.default_rng(0).uniform(-1, 1, (30, 3))
        worst = 0.0
        for action in actions:
            observation, *_ = paper.step(action)
            tip_observation, *_ = tip.step(action)
            made = paper.observation_system.tip_from_paper(observation)
            worst = max(worst, np.abs(made - tip_observation).max())
        assert np.abs(tip_observation[9:]).max() > 0.05  # the tip moves
        assert worst < 1e-6  # float32 observations
    finally:
        paper.close()
        tip.close()


def test_a_tip_teachers_student_is_a_fresh_network_normalized_as_its_data(tmp_path):
    distill(
        POLICIES_DIR / "ppo_toolpush_tip",
        tmp_path / "student",
        DistillConfig(action_mode="position", rounds=1, episodes=2, epochs=1),
        log=lambda r: None,
    )
    student = load_policy(tmp_path / "student")
    assert student.meta.observation_shape == [30] and student.meta.action_shape == [3]
    assert student.meta.env_kwargs["observation_mode"] == "gripper_joints"
    assert round(student.obs_rms.count) == 200  # round 0: 2 episodes of 100 steps


def test_an_earlier_student_goes_on_and_one_that_does_not_fit_is_refused(tmp_path):
    quiet = {"log": lambda r: None}
    first = DistillConfig(action_mode="position", rounds=1, episodes=1, epochs=1)
    distill(TEACHER, tmp_path / "a", first, **quiet)
    more = dc.replace(first, init_from=tmp_path / "a", epochs=0)  # no fitting: the same weights
    distill(TEACHER, tmp_path / "b", more, **quiet)
    a, b = load_policy(tmp_path / "a"), load_policy(tmp_path / "b")
    for name, value in a.model.policy.state_dict().items():
        assert (value == b.model.policy.state_dict()[name]).all(), name
    np.testing.assert_array_equal(a.obs_rms.mean, b.obs_rms.mean)
    with pytest.raises(ValueError, match="is not a student of this distillation"):
        distill(
            TEACHER, tmp_path / "c", dc.replace(more, action_mode="position_quaternion"), **quiet
        )


def _stop_after(round_: int):
    def log(r):
        if r["round"] == round_:
            raise KeyboardInterrupt

    return log


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_a_stopped_distillation_goes_on_to_the_same_student(tmp_path):
    """Stopped after its second round (as by Ctrl-C: the round is saved before it is
    logged), then resumed: the student, its normalization and the rounds' records are the
    uninterrupted run's, bit for bit, and the state files are gone."""
    config = DistillConfig(rounds=3, episodes=1, epochs=2)
    whole = distill(TEACHER, tmp_path / "whole", config, log=lambda r: None)
    with pytest.raises(KeyboardInterrupt):
        distill(TEACHER, tmp_path / "stopped", config, log=_stop_after(1))
    assert (tmp_path / "stopped" / PROGRESS).is_file()
    assert load_policy(tmp_path / "stopped").meta.action_shape == [7]  # the student so far
    with pytest.raises(FileExistsError, match="already holds an unfinished distillation"):
        distill(TEACHER, tmp_path / "stopped", config, log=lambda r: None)
    logged = []
    resumed = resume_distill(tmp_path / "stopped", log=logged.append)
    assert [r["round"] for r in logged] == [2]
    assert resumed["rounds"] == whole["rounds"]
    a, b = load_policy(tmp_path / "whole"), load_policy(tmp_path / "stopped")
    for name, value in a.model.policy.state_dict().items():
        assert torch.equal(value, b.model.policy.state_dict()[name]), name
    np.testing.assert_array_equal(a.obs_rms.mean, b.obs_rms.mean)
    np.testing.assert_array_equal(a.obs_rms.var, b.obs_rms.var)
    assert sorted(p.name for p in (tmp_path / "stopped").iterdir()) == sorted(
        p.name for p in (tmp_path / "whole").iterdir()
    )
    with pytest.raises(FileNotFoundError, match="holds no unfinished distillation"):
        resume_distill(tmp_path / "stopped")


def test_the_command_line_says_how_to_go_on_and_resumes(capsys, tmp_path, monkeypatch):
    out = tmp_path / "s"
    import drake_tooluse.experiments.distill as module

    real = module.distill

    def stopped(teacher, out_, config, command, log):
        return real(teacher, out_, config, command, _stop_after(0))

    monkeypatch.setattr(module, "distill", stopped)
    flags = ["--rounds", "2", "--episodes", "1", "--epochs", "1"]
    code = main(["distill", "--teacher", str(TEACHER), "--out", str(out), *flags])
    err = capsys.readouterr().err
    assert code == 130 and f"drake-tooluse distill --resume {out}" in err, err
    monkeypatch.setattr(module, "distill", real)
    assert_one_line_error(
        capsys, ["distill", "--teacher", TEACHER, "--out", out], r"continue it with --resume"
    )
    assert_one_line_error(
        capsys, ["distill", "--resume", out, "--rounds", "3"], r"leave out --rounds"
    )
    assert main(["distill", "--resume", str(out)]) == 0
    assert "2 rounds" in capsys.readouterr().out
    assert_one_line_error(capsys, ["distill", "--resume", out], r"holds no unfinished")


def test_the_help_names_the_defaults_that_apply(capsys):
    with pytest.raises(SystemExit):
        main(["distill", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    defaults = DistillConfig()
    for flag, value in [
        ("--rounds", defaults.rounds),
        ("--episodes", defaults.episodes),
        ("--epochs", defaults.epochs),
        ("--learning-rate", defaults.learning_rate),
        ("--seed", defaults.seed),
    ]:
        shown = re.search(rf"{flag} \S+ [^-]*\(default: ([^)]+)\)", text)
        assert shown and float(shown[1]) == value, flag
    assert f"{defaults.action_mode} (the paper's 7-d action, the default)" in text


@pytest.fixture(scope="module")
def stopped(tmp_path_factory):
    """A distillation stopped after its first of three rounds."""
    from drake_tooluse.experiments.distill import distill

    out = tmp_path_factory.mktemp("stopped") / "student"

    def stop(_round):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        distill(TEACHER, out, DistillConfig(rounds=3, episodes=1, epochs=1), log=stop)
    return out


def _tampered(stopped, tmp_path, edit):
    import shutil

    out = tmp_path / "student"
    shutil.copytree(stopped, out)
    edit(out)
    return out


def _edit_progress(change):
    import json

    def edit(out):
        path = out / "distill_progress.json"
        state = json.loads(path.read_text())
        change(state)
        path.write_text(json.dumps(state))

    return edit


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda s: s["config"].update(colour=1), r"config=\['colour'\] holds unknown field"),
        (lambda s: s["config"].pop("rounds"), r"config\.rounds=None is missing"),
        (lambda s: s["config"].update(rounds="six"), r"config\.rounds='six' must be an integer"),
        (lambda s: s["config"].update(learning_rate=float("nan")), r"config\.learning_rate=nan"),
        (lambda s: s["rounds"][0].update(samples=1400), r"observations has shape \[100, 30\]"),
        (lambda s: s.update(numpy_random="x"), r"numpy_random='x' must be a generator's state"),
    ],
)
def test_a_tampered_distillation_state_is_refused_naming_the_file_and_field(
    stopped, tmp_path, change, message
):
    from drake_tooluse.experiments.distill import resume_distill

    out = _tampered(stopped, tmp_path, _edit_progress(change))
    with pytest.raises(ValueError, match=message) as refused:
        resume_distill(out, log=lambda r: None)
    assert str(out) in str(refused.value)
    assert not (out / "policy.json").stat().st_mtime > (stopped / "policy.json").stat().st_mtime


def _write_data(observations, labels):
    def edit(out):
        np.savez(out / "distill_data.npz", observations=observations, labels=labels)

    return edit


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            _write_data(np.full((100, 30), np.nan), np.zeros((100, 7))),
            "observations holds NaN or infinite values",
        ),
        (_write_data(np.zeros((100, 30)), np.zeros((90, 7))), r"labels has shape \[90, 7\]"),
        (lambda out: (out / "distill_data.npz").write_bytes(b"PK\x03\x04trunc"), "distill_data"),
        (lambda out: (out / "distill_progress.pt").write_bytes(b"garbage"), "distill_progress.pt"),
    ],
)
def test_tampered_distillation_data_is_refused_before_any_round(stopped, tmp_path, edit, message):
    from drake_tooluse.experiments.distill import resume_distill

    out = _tampered(stopped, tmp_path, edit)
    rounds = []
    with pytest.raises(ValueError, match=message):
        resume_distill(out, log=rounds.append)
    assert rounds == []  # nothing trained on it
