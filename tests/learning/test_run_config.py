"""A run's config.json is portable: the env's scenario is stored by name (a shipped scenario's
file name, or `scenario.yaml` written into the run directory), never as a path of the machine
that wrote it, and a run resumes after its directory or the checkout moved. One reader of
config.json serves train and sweep."""

import json
import shutil
from dataclasses import replace

import pytest

from drake_tooluse.learning import train as train_module
from drake_tooluse.learning.config import read_run_config, resolve_config, write_run_config
from drake_tooluse.learning.train import train
from drake_tooluse.paths import SCENARIOS_DIR

ENV = "drake_tooluse/ToolPush-v1"
TINY = {"n_steps": 64, "batch_size": 64, "n_epochs": 1, "checkpoint_freq": 64}
TINY |= {"eval_freq": 10_000_000, "eval_episodes": 1}


def own_scenario(folder, length=0.15):
    """A scenario outside the package, on top of the shipped push.yaml."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "mine.yaml"
    path.write_text(f"base: {SCENARIOS_DIR.resolve() / 'push.yaml'}\ntool:\n  length: {length}\n")
    return path


def config_for(scenario, timesteps=64):
    return resolve_config(
        ENV, "ppo", timesteps, 1, 0, overrides=TINY, env_kwargs={"scenario": str(scenario)}
    )


def test_a_shipped_scenario_is_stored_by_name_and_read_back_as_this_machines_file(tmp_path):
    config = config_for(SCENARIOS_DIR.resolve() / "push_tool_125.yaml")
    write_run_config(tmp_path, config, "cmd")
    text = (tmp_path / "config.json").read_text()
    stored = json.loads(text)["hyperparams"]["env_kwargs"]["scenario"]
    assert stored == "push_tool_125.yaml" and str(SCENARIOS_DIR.resolve()) not in text
    read, command = read_run_config(tmp_path / "config.json")
    assert command == "cmd"
    assert read.hyperparams["env_kwargs"]["scenario"] == str(
        (SCENARIOS_DIR / "push_tool_125.yaml").resolve()
    )
    assert read.comparable() == config.comparable()


def test_another_scenario_is_written_into_the_run_directory(tmp_path):
    config = config_for(own_scenario(tmp_path / "elsewhere"))
    run = tmp_path / "run"
    run.mkdir()
    write_run_config(run, config, "")
    text = (run / "config.json").read_text()
    assert json.loads(text)["hyperparams"]["env_kwargs"]["scenario"] == "scenario.yaml"
    assert str(tmp_path) not in text and (run / "scenario.yaml").is_file()


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_a_run_resumes_after_its_directory_and_its_scenario_file_moved(tmp_path):
    first = tmp_path / "first"
    train(config_for(own_scenario(first / "src")), first / "run", progress_bar=False)
    moved = tmp_path / "moved"
    shutil.move(first, moved)  # the run directory and the scenario's original folder move
    saved, _ = read_run_config(moved / "run" / "config.json")
    assert saved.hyperparams["env_kwargs"]["scenario"] == str(
        (moved / "run" / "scenario.yaml").resolve()
    )
    summary = train(replace(saved, timesteps=128), moved / "run", resume=True, progress_bar=False)
    assert summary["timesteps"] >= 128
    # The same scenario asked for from its new place resumes too; an edited one is refused.
    again = config_for(moved / "src" / "mine.yaml", timesteps=192)
    assert train(again, moved / "run", resume=True, progress_bar=False)["timesteps"] >= 192
    edited = config_for(own_scenario(tmp_path / "edited", length=0.16), timesteps=256)
    with pytest.raises(ValueError, match=r"env_kwargs\.scenario: saved 'scenario\.yaml \(sha256"):
        train(edited, moved / "run", resume=True, progress_bar=False)


def test_a_config_json_with_an_absolute_path_as_earlier_runs_wrote_it_still_reads(tmp_path):
    path = str((SCENARIOS_DIR / "push.yaml").resolve())
    config = config_for(path)
    raw = {**json.loads(json.dumps(config.__dict__)), "command": ""}
    (tmp_path / "config.json").write_text(json.dumps(raw))
    read, _ = read_run_config(tmp_path / "config.json")
    assert read.hyperparams["env_kwargs"]["scenario"] == path


def test_a_stored_scenario_name_that_is_neither_in_the_run_nor_shipped_is_an_error(tmp_path):
    config = config_for(SCENARIOS_DIR.resolve() / "push.yaml")
    write_run_config(tmp_path, config, "")
    raw = json.loads((tmp_path / "config.json").read_text())
    raw["hyperparams"]["env_kwargs"]["scenario"] = "gone.yaml"
    (tmp_path / "config.json").write_text(json.dumps(raw))
    with pytest.raises(ValueError, match=r"env_kwargs.scenario='gone.yaml' is not the name"):
        read_run_config(tmp_path / "config.json")


def test_train_has_no_reader_of_its_own():
    assert not hasattr(train_module, "_read_config")
    assert train_module.read_run_config is read_run_config
