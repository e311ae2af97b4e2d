"""`train`'s evaluation and checkpoint options under rl-zoo's names, and where best/ came from."""

import json

import pytest

from drake_tooluse.cli import EXIT_USAGE, main

HP = json.dumps({"n_steps": 64, "batch_size": 64, "n_epochs": 1})


def _train(out, *flags):
    argv = ["train", "--out", str(out), "--timesteps", "128", "--n-envs", "1", "--no-progress"]
    return main([*argv, "--hyperparams", HP, *flags])


def test_eval_freq_save_freq_and_n_eval_episodes_set_the_run(tmp_path, capsys):
    out = tmp_path / "run"
    assert _train(out, "--eval-freq", "64", "--save-freq", "64", "--n-eval-episodes", "2") == 0
    printed = capsys.readouterr().out
    config = json.loads((out / "config.json").read_text())
    hp = config["hyperparams"]
    assert (hp["eval_freq"], hp["checkpoint_freq"], hp["eval_episodes"]) == (64, 64, 2)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["evaluations"] == 2 and summary["best"]["step"] in (64, 128)
    assert "best/ is the best of 2 evaluations" in printed


def test_a_run_too_short_to_evaluate_says_best_is_the_final_policy(tmp_path, capsys):
    assert _train(tmp_path / "run", "--eval-freq", "100000") == 0
    assert "best/ is the final policy: no evaluation ran" in capsys.readouterr().out


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--eval-freq", "0"], "--eval-freq"),
        (["--n-eval-episodes", "-2"], "--n-eval-episodes"),
    ],
)
def test_bad_values_are_one_line(tmp_path, capsys, flags, message):
    assert _train(tmp_path / "run", *flags) == EXIT_USAGE
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_a_flag_and_the_same_key_in_hyperparams_are_refused(tmp_path, capsys):
    argv = ["train", "--out", str(tmp_path / "run"), "--timesteps", "64", "--eval-freq", "64"]
    assert main([*argv, "--hyperparams", '{"eval_freq": 128}']) == EXIT_USAGE
    assert "--eval-freq or eval_freq in --hyperparams, not both" in capsys.readouterr().err
