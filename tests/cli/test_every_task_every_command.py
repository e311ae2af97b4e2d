"""Every command, with a policy of each task (the push task's, the pull task's, and the toy task
of tests/tasks/toy_touch.py): it works, or it exits 2 before any work, saying what the task
lacks (`tasks.contract.COMMAND_NEEDS`, the task's `TaskDeclaration`)."""

import json
import os
from pathlib import Path

import pytest

from drake_tooluse.cli import main
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.learning.train import train
from drake_tooluse.paths import PULL_POLICY, TRANSFER_POLICY
from drake_tooluse.tasks.contract import COMMAND_NEEDS
from tests.tasks import toy_touch


@pytest.fixture(scope="module")
def toy_policy(tmp_path_factory):
    toy_touch.register()
    out = tmp_path_factory.mktemp("toy") / "run"
    overrides = {"env_kwargs": {}, **toy_touch.TINY_PPO}
    config = resolve_config(toy_touch.ENV_ID, "ppo", 256, 1, 0, overrides=overrides)
    train(config, out, progress_bar=False)
    return out / "final"


def _argv(command: str, policy, tmp_path) -> list[str]:
    """The command line of `command` with `policy`, as small as it runs."""
    out = str(tmp_path / "out")
    return {
        "trajectory": ["trajectory", "--policy", policy, "--episodes", "1", "--out", out],
        "transfer": ["transfer", "--policy", policy, "--runs", "1", "--out", out],
        "distill": ["distill", "--teacher", policy, "--out", out, "--rounds", "1"],
        "record-video": ["record-video", "--policy", policy, "--out", out + ".gif"],
        "evaluate --meshcat": ["evaluate", "--policy", policy, "--episodes", "1", "--meshcat"],
    }[command]


def _refused_before_work(capsys, argv, tmp_path, command, task):
    code = main([*argv, "--json"] if argv[0] != "record-video" else argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert f"{command} needs {COMMAND_NEEDS[command]}, which the {task} task" in err
    assert not any(tmp_path.iterdir())  # no work: nothing written


@pytest.mark.parametrize("command", ["trajectory", "distill"])
def test_the_toy_task_is_refused_before_any_work(command, toy_policy, tmp_path, capsys):
    argv = _argv(command, str(toy_policy), tmp_path)
    _refused_before_work(capsys, argv, tmp_path, command, "touch")


def test_the_toy_task_transfers_to_other_tools_with_what_its_own_file_gives(
    toy_policy, tmp_path, capsys
):
    """Its one builder and its reader in tests/tasks/toy_touch.py: transfer deploys the toy
    policy closed loop with two straight tools in the nominal world and in reality (the camera
    measuring each), judged by the toy's own figures, to its env's step limit; open loop (a
    box push's trajectory) is refused before any work."""
    out = tmp_path / "out"
    argv = ["transfer", "--policy", str(toy_policy), "--runs", "1", "--tools", "0.2", "0.3"]
    code = main([*argv, "--out", str(out), "--json"])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    result = json.loads((out / "transfer.json").read_text())
    assert result["object_name"] == "tip" and result["failed_runs"] == 0
    for tool, length in zip(result["tools"], (0.2, 0.3)):
        assert abs(tool["measured_length_mean_m"] - length) < 0.005
        for world in ("nominal", "reality"):
            run = tool[world]["per_run"][0]
            assert run["steps"] == 20 or run["success"]  # the toy env's step limit
            assert run["final_object_to_goal_m"] < 0.15  # the tip near its target, not a box
    empty = tmp_path / "open-loop"
    empty.mkdir()
    open_loop = [*argv, "--mode", "open-loop", "--out", str(empty / "out")]
    _refused_before_work(capsys, open_loop, empty, "trajectory", "touch")


def test_the_toy_task_records_a_video_with_what_its_own_file_gives(toy_policy, tmp_path, capsys):
    """A view and a declaration in tests/tasks/toy_touch.py: record-video serves it, and
    prints its own figure (the tip's distance from the target) in words."""
    out = tmp_path / "toy.gif"
    code = main(["record-video", "--policy", str(toy_policy), "--out", str(out), "--every", "5"])
    printed = capsys.readouterr()
    assert code == 0 and out.read_bytes()[:6] == b"GIF89a", printed.err
    assert "final distance" in printed.out and " cm" in printed.out
    code = main(["record-video", "--policy", str(toy_policy), "--out", str(out)] + SIZE)
    assert code == 2 and "render_size" in capsys.readouterr().err  # framing it does not take


SIZE = ["--render-size", "64", "48"]


def test_the_toy_task_is_evaluated_in_meshcat(toy_policy, monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", open("/dev/null"))  # the view closes at once
    code = main(["evaluate", "--policy", str(toy_policy), "--episodes", "1", "--meshcat"])
    out = capsys.readouterr().out
    assert code == 0 and "final distance: mean" in out


@pytest.mark.parametrize("command", ["trajectory", "distill"])
def test_the_pull_task_is_refused_before_any_work(command, tmp_path, capsys):
    argv = _argv(command, str(PULL_POLICY), tmp_path)
    _refused_before_work(capsys, argv, tmp_path, command, "pull")


def test_the_pull_policy_s_open_loop_transfer_and_straight_tools_are_refused_before_any_work(
    tmp_path, capsys
):
    """Open loop replays a tool-tip trajectory, which the pull task does not make; its policy
    uses hooks."""
    argv = _argv("transfer", str(PULL_POLICY), tmp_path)
    _refused_before_work(capsys, [*argv, "--mode", "open-loop"], tmp_path, "trajectory", "pull")
    code = main([*argv, "--tools", "0.2"])
    err = capsys.readouterr().err
    assert code == 2 and "--tools: tool 0.200 m: the policy of drake_tooluse/ToolPull-v1" in err
    assert "hook tools" in err and not any(tmp_path.iterdir())


@pytest.mark.slow  # ~10 s: a hook measured and pulled with, in both worlds; .ci/run runs it
def test_the_pull_policy_transfers_to_a_hook_closed_loop(tmp_path, capsys):
    import json

    argv = _argv("transfer", str(PULL_POLICY), tmp_path)
    code = main([*argv, "--tools", "hook:0.25,0.05,90", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    (tool,) = json.loads(captured.out)["tools"]
    assert tool["tool"] == "hook:0.25,0.05,90" and tool["tool_length_m"] is None
    assert abs(tool["measured_mean"]["angle_deg"] - 90) < 3
    assert tool["grasp_along_error_max_m"] < 0.001  # the camera's grasp along the handle
    assert tool["reality"]["runs"] == 1 and tool["reality"]["failed_runs"] == 0
    assert "cube travel nominal" in captured.err


def test_the_pull_policy_records_a_video_framed_as_asked(tmp_path, capsys):
    out = tmp_path / "pull.gif"
    argv = ["record-video", "--policy", str(PULL_POLICY), "--out", str(out)]
    code = main([*argv, *SIZE, "--every", "10", "--json"])
    assert code == 0 and out.is_file(), capsys.readouterr().err


def test_the_pull_policy_is_evaluated_in_meshcat(monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", open("/dev/null"))  # the view closes at once
    code = main(["evaluate", "--policy", str(PULL_POLICY), "--episodes", "1", "--meshcat"])
    out = capsys.readouterr().out
    assert code == 0 and "final cube to goal: mean" in out


def test_the_push_task_serves_every_command():
    from drake_tooluse.learning.policy_dir import load_policy
    from drake_tooluse.tasks.contract import check_serves

    env_id = load_policy(TRANSFER_POLICY).meta.env_id
    for command in COMMAND_NEEDS:
        assert check_serves(env_id, command).name == "push"


PULL_CELLS = """\
episodes: 2
cells:
  pull:
    env: drake_tooluse/ToolPull-v1
    algo: ppo
    timesteps: 128
    seeds: [0]
    protocol: to-limit
    hyperparams: {n_steps: 64, batch_size: 32, n_epochs: 1, eval_freq: 10000000}
"""


@pytest.mark.slow  # ~40 s: a training and two evaluations, as subprocesses; .ci/run runs it
def test_a_study_cell_of_the_pull_task_runs_and_only_the_papers_page_is_refused(tmp_path, capsys):
    """The study runs any task's cells and records the task's own first figure; the page it
    makes is the paper's, so a pull cell's study makes none and says why, and study-report
    refuses its cells before any work."""
    import json

    cells = tmp_path / "cells.yaml"
    cells.write_text(PULL_CELLS)
    study = tmp_path / "study"
    code = main(["study", "--cells", str(cells), "--out", str(study), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "no report (the paper's page): cell 'pull': study-report needs" in captured.err
    assert "final cube to goal: mean" in captured.err
    (run,) = json.loads(captured.out)["runs"]
    assert run["state"].startswith("done"), run
    entry = json.loads((study / "paper_study.json").read_text())["pull"]["seeds"]["0"]
    assert len(entry["evaluate_best"]["per_episode"]["final_object_to_goal_m"]) == 2
    assert not (study / "TRAINING.md").exists()
    code = main(["study-report", "--cells", str(cells), "--out", str(study)])
    err = capsys.readouterr().err
    assert code == 2 and "study-report needs the paper's figures" in err and "pull task" in err
    code = main(["study", "--cells", str(cells), "--update-docs"])
    assert code == 2 and "--update-docs: cell 'pull'" in capsys.readouterr().err


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_a_reader_that_leaves_the_pipe_ends_no_command_in_a_traceback():
    """`drake-tooluse ... --json | head -1`: the reader closes the pipe before the result."""
    import subprocess
    import sys

    child = subprocess.Popen(
        [sys.executable, "-m", "drake_tooluse.cli", "measure-box", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    child.stdout.close()  # the reader is gone before anything is written
    err = child.stderr.read().decode()
    assert child.wait() == 0 and "Traceback" not in err and "BrokenPipe" not in err


def test_render_without_a_render_mode_warns_and_returns_none():
    import gymnasium as gym

    for env_id in ("drake_tooluse/ToolPush-v1", "drake_tooluse/ToolPull-v1"):
        env = gym.make(env_id)
        env.reset(seed=0)
        with pytest.warns(UserWarning, match="render\\(\\) without a render mode"):
            assert env.unwrapped.render() is None
        env.close()


def test_every_tasks_figures_print_in_words_with_units():
    """One formatter for every task's evaluation, from the figures' names."""
    from drake_tooluse.cli.learning import format_evaluate

    toy = {
        "episodes": 3,
        "seed": 0,
        "final_distance_mean_m": 0.0123,
        "final_distance_median_m": 0.01,
        "final_distance_std_m": 0.002,
        "success_rate": 2 / 3,
        "episode_length_mean": 12.0,
        "tool_touched_rate": 0.5,
        "sim_errors": 1,
        "flagged_episodes": {"arm_too_fast": 1, "tool_in_table": 0},
    }
    assert format_evaluate(toy) == (
        "3 episodes from seed 0: final distance: mean 1.23 cm, median 1.00 cm, std 0.20 cm; "
        "success 67 %; episode length 12.0 steps; tool touched in 50 % of episodes; "
        "1 simulation failure(s); past a physical limit: arm_too_fast in 1"
    )


def test_an_early_end_cell_is_refused_as_the_v0_envs_protocol(tmp_path, capsys):
    cells = tmp_path / "cells.yaml"
    cells.write_text(PULL_CELLS.replace("protocol: to-limit", "protocol: early-end"))
    code = main(["study", "--cells", str(cells), "--out", str(tmp_path / "study")])
    err = capsys.readouterr().err
    assert code == 2 and "protocol early-end was the -v0 envs' (tag figures-v0)" in err
    assert not (tmp_path / "study").exists()


@pytest.fixture
def toy_in_every_process(monkeypatch):
    """The toy task known to the subprocesses the study and the sweep start: its module named
    in DRAKE_TOOLUSE_TASKS, importable from the checkout."""
    root = str(Path(toy_touch.__file__).parents[2])
    monkeypatch.setenv("DRAKE_TOOLUSE_TASKS", toy_touch.__name__)
    monkeypatch.setenv(
        "PYTHONPATH", os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))
    )


TINY_TOY = {
    k: v
    for k, v in toy_touch.TINY_PPO.items()
    if k in ("n_steps", "batch_size", "n_epochs", "eval_freq")
}


@pytest.mark.slow  # ~15 s: a training and two evaluations, as subprocesses; .ci/run runs it
def test_a_study_cell_of_the_toy_task_runs(toy_in_every_process, tmp_path, capsys):
    cells = tmp_path / "cells.yaml"
    cells.write_text(PULL_CELLS.replace("pull", "touch").replace("ToolPull-v1", "ToyTouch-v1"))
    study = tmp_path / "study"
    code = main(["study", "--cells", str(cells), "--out", str(study), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    (run,) = json.loads(captured.out)["runs"]
    assert run["state"].startswith("done"), run
    entry = json.loads((study / "paper_study.json").read_text())["touch"]["seeds"]["0"]
    assert len(entry["evaluate_best"]["per_episode"]["final_distance_m"]) == 2


@pytest.mark.slow  # ~15 s: Ray started, one tiny trial; .ci/run runs it
def test_a_sweep_of_the_toy_task_runs(toy_in_every_process, tmp_path, capsys):
    argv = ["sweep", "--envs", toy_touch.ENV_ID, "--seeds", "0", "--timesteps", "128"]
    hyperparams = json.dumps({**TINY_TOY, "n_envs": 1})
    out = tmp_path / "sweep"
    code = main(
        [
            *argv,
            "--out",
            str(out),
            "--num-cpus",
            "2",
            "--episodes",
            "1",
            "--hyperparams",
            hyperparams,
        ]
    )
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert f"| ppo | {toy_touch.ENV_ID} | 0 | finished | 128 |" in printed.out
    assert "final_distance_mean" in printed.out


def test_the_toy_policy_initializes_a_training(toy_policy, tmp_path, capsys):
    argv = ["train", "--env", toy_touch.ENV_ID, "--init-from", str(toy_policy)]
    hyperparams = json.dumps({**TINY_TOY, "n_envs": 1})
    code = main(
        [*argv, "--timesteps", "64", "--out", str(tmp_path / "run"), "--hyperparams", hyperparams]
    )
    assert code == 0, capsys.readouterr().err
    assert (tmp_path / "run" / "final").is_dir()


@pytest.mark.parametrize(
    "argv, said",
    [
        (["demo", "--out", "{out}", "--policy", "{policy}"], "not of the push task"),
        (["choose-tool", "--task", "touch"], "task='touch' is not allowed"),
    ],
)
def test_the_toy_task_is_refused_by_the_tool_tasks_commands(
    argv, said, toy_policy, tmp_path, capsys
):
    """`demo` and `choose-tool` serve the tasks that declare a tool task (`ToolTask`: a
    policy, its tools, its worlds); the toy declares none, and they refuse it at once."""
    argv = [a.format(out=tmp_path / "out", policy=toy_policy) for a in argv]
    code = main(argv)
    assert code == 2 and said in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    "value, said",
    [
        ("no_such_module_here", "cannot import the task module 'no_such_module_here'"),
        (".toy", "'.toy' is not a module name"),
        ("json.decoder, os..path", "'os..path' is not a module name"),
    ],
)
def test_a_task_module_that_cannot_be_imported_is_one_line(value, said, monkeypatch, capsys):
    monkeypatch.setenv("DRAKE_TOOLUSE_TASKS", value)
    code = main(["evaluate", "--episodes", "1", "--json"])
    printed = capsys.readouterr()
    assert code == 2 and said in printed.err and "Traceback" not in printed.err
    assert json.loads(printed.out)["exit_code"] == 2
