"""Training killed or failing at the named moments: a complete
checkpoint is always where resume looks, nothing of the killed process is left behind, and
the resumed run's logs, evaluations, best policy and summary are one run's."""

import dataclasses
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

import drake_tooluse.files as files
import drake_tooluse.learning.train as train_module
from drake_tooluse.learning.checkpoint import REPLAY_BUFFER_ARRAYS, restore_checkpoint
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.learning.train import checkpoint_dirs, train
from tests.faults.common import (
    KILLED,
    csv_column,
    csv_steps,
    die,
    evaluations,
    orphans,
    read_json,
    run_killed,
    tiny_config,
)

# -- a kill at any moment of the checkpoint write leaves a resumable run -------------


def _die_on_second_checkpoint(moment: str):
    """Plants a kill at `moment` of the run's second checkpoint (256 steps)."""
    rename, replace, rmtree = os.rename, os.replace, shutil.rmtree

    def second(path) -> bool:
        return "ckpt-000000000256" in str(path)

    if moment == "before the new checkpoint appears":

        def patched(src, dst, *a, **k):
            if second(dst) and not str(dst).endswith(".tmp"):
                die()
            return rename(src, dst, *a, **k)

        os.rename = patched
    elif moment == "after it appears, before latest.json":

        def patched(src, dst, *a, **k):
            if str(dst).endswith("latest.json") and "ckpt-000000000256" in Path(src).read_text():
                die()
            return replace(src, dst, *a, **k)

        os.replace = patched
    elif moment == "while the old one is deleted":

        def patched(path, *a, **k):
            if "ckpt-000000000128" in str(path):
                die()
            return rmtree(path, *a, **k)

        files.shutil.rmtree = patched


@pytest.mark.parametrize(
    "moment",
    [
        # ~1.5-2 s each: with the slow tests CI runs.
        pytest.param("before the new checkpoint appears", marks=pytest.mark.slow),
        pytest.param("after it appears, before latest.json", marks=pytest.mark.slow),
        pytest.param("while the old one is deleted", marks=pytest.mark.slow),
    ],
)
def test_a_kill_while_checkpointing_leaves_a_complete_checkpoint(tmp_path, moment):
    out, config = tmp_path / "run", tiny_config(384, eval_freq=10**7)

    def killed_run():
        _die_on_second_checkpoint(moment)
        # A write of the logs in flight, as a kill would leave it.
        (out / "logs").mkdir(parents=True)
        open(out / "logs" / f".progress.csv.tmp-{os.getpid()}@{files._HOST}.abcdefgh", "w")
        train(config, out, progress_bar=False)

    assert run_killed(killed_run) == KILLED
    assert checkpoint_dirs(out), "no complete checkpoint where resume looks"
    summary = train(config, out, resume=True, progress_bar=False)
    assert summary["timesteps"] == 384
    assert summary["resumes"][0]["from_timesteps"] in (128, 256)
    # The killed process's temporary files and directories are gone.
    assert orphans(out, out / "checkpoints", out / "logs", out / "eval") == []
    assert [p.name for p in checkpoint_dirs(out)] == ["ckpt-000000000384"]
    assert read_json(out / "checkpoints" / "latest.json")["checkpoint"] == "ckpt-000000000384"
    load_policy(out / "final")


def test_a_kill_between_the_two_renames_of_a_swap_keeps_the_old_directory(tmp_path, monkeypatch):
    """Where the file system has no atomic exchange, a replace is two renames; a kill between
    them leaves the target missing and the complete old one beside it: the next write (or
    `recover_dir`) puts it back."""
    target = tmp_path / "best"
    with files.atomic_dir(target) as tmp:
        (tmp / "policy.json").write_text("old")

    def killed_swap():
        files._RENAMEAT2 = None  # no RENAME_EXCHANGE here
        rename = os.rename

        def patched(src, dst):
            rename(src, dst)
            if Path(dst).name == ".best.old":
                die()

        os.rename = patched
        with files.atomic_dir(target, replace=True) as tmp:
            (tmp / "policy.json").write_text("new")

    assert run_killed(killed_swap) == KILLED
    assert not target.exists() and (tmp_path / ".best.old" / "policy.json").read_text() == "old"
    assert files.recover_dir(target)
    assert (target / "policy.json").read_text() == "old"
    assert orphans(tmp_path)  # the killed writer's complete new copy ...
    files.remove_orphans(tmp_path)
    assert orphans(tmp_path) == []  # ... is its process's, and goes with it
    monkeypatch.setattr(files, "_RENAMEAT2", None)
    with files.atomic_dir(target, replace=True) as tmp:
        (tmp / "policy.json").write_text("new")
    assert (target / "policy.json").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["best"]


def test_training_leaves_no_temporary_files_of_a_killed_process(tmp_path):
    """A directory write killed half-way leaves its temporary sibling; the next run in the
    same directory deletes it (it belongs to a process that is gone), and keeps live ones."""

    def killed_write():
        with files.atomic_dir(tmp_path / "demo") as tmp:
            (tmp / "half.txt").write_text("half")
            die()

    assert run_killed(killed_write) == KILLED
    assert len(orphans(tmp_path)) == 1
    live = tmp_path / f".other.tmp-{os.getpid()}@{files._HOST}.abcdefgh"
    live.mkdir()
    with files.atomic_dir(tmp_path / "demo") as tmp:
        (tmp / "whole.txt").write_text("whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == [live.name, "demo"]


# -- kill + resume keeps one run's history -------------------------------------------

FAULTY = {"eval_freq": 192, "checkpoint_freq": 128}  # evaluations at 192, 384, 576, 768
STEPS, KILL_AT, CHECKPOINT = 768, 620, 512  # killed after the evaluation at 576


# The column each algorithm writes at every row (DDPG has two losses, no `train/loss`).
LOSS = {"ppo": "train/loss", "ddpg": "train/critic_loss"}


def _config(algo: str):
    return tiny_config(STEPS, seed=1, algo=algo, **FAULTY)


def _replay_buffer(checkpoint: Path) -> dict:
    with np.load(checkpoint / "replay_buffer.npz") as saved:
        return {name: saved[name] for name in saved.files}


@pytest.fixture(scope="module", params=list(LOSS))
def uninterrupted(request, tmp_path_factory):
    """(the algorithm, its run of STEPS steps that nothing stopped)."""
    out = tmp_path_factory.mktemp(f"uninterrupted-{request.param}") / "run"
    train(_config(request.param), out, progress_bar=False, command="first")
    return request.param, out


# Measured on 2 cores shared with a training run: PPO 4-14 s, DDPG 13-17 s, each with its
# uninterrupted twin; .ci/run runs them.
@pytest.mark.slow
def test_kill_and_resume_keep_the_history_of_one_run(uninterrupted, tmp_path, monkeypatch):
    algo, uninterrupted = uninterrupted
    out, config = tmp_path / "run", _config(algo)

    def killed_run():
        on_step = train_module._Run._on_step

        def patched(self):
            if self.model.num_timesteps >= KILL_AT:
                die()
            return on_step(self)

        train_module._Run._on_step = patched
        train(config, out, progress_bar=False, command="first")

    assert run_killed(killed_run) == KILLED
    assert read_json(out / "checkpoints" / "latest.json")["timesteps"] == CHECKPOINT
    killed_best = read_json(out / "best" / "policy.json")["evaluation"]["timesteps"]
    if algo == "ddpg":
        saved = _replay_buffer(out / "checkpoints" / f"ckpt-{CHECKPOINT:012d}")
    restored = []  # each session's replay buffer as its checkpoint restored it

    def restoring(model, *args):
        state = restore_checkpoint(model, *args)
        if getattr(model, "replay_buffer", None) is not None:
            buffer = model.replay_buffer
            arrays = {n: getattr(buffer, n)[: buffer.pos].copy() for n in REPLAY_BUFFER_ARRAYS}
            restored.append({"pos": buffer.pos, "full": buffer.full, **arrays})
        return state

    monkeypatch.setattr(train_module, "restore_checkpoint", restoring)
    summary = train(config, out, resume=True, progress_bar=False, command="second")

    # Logs: the rows of one run, none repeated or missing; those before the checkpoint kept.
    a, b = uninterrupted / "logs" / "progress.csv", out / "logs" / "progress.csv"
    assert csv_steps(b) == csv_steps(a)
    kept = sum(s <= CHECKPOINT for s in csv_steps(a))
    assert csv_column(b, LOSS[algo])[:kept] == csv_column(a, LOSS[algo])[:kept]
    # TensorBoard: the killed session's events after the checkpoint are purged.
    steps = {}
    for run in (uninterrupted, out):
        events = EventAccumulator(str(run / "logs"))
        events.Reload()
        steps[run] = [e.step for e in events.Scalars("eval/mean_reward")]
    assert steps[out] == steps[uninterrupted] == [192, 384, 576, 768]

    # Evaluations: every one of the run, the kept ones as they were.
    ea, eb = evaluations(uninterrupted), evaluations(out)
    assert eb["timesteps"] == ea["timesteps"] == [192, 384, 576, 768]
    assert eb["results"][:2] == ea["results"][:2]

    # The best policy is the best of those evaluations, not of the last session's alone.
    means = [sum(r) / len(r) for r in eb["results"]]
    best = read_json(out / "best" / "policy.json")["evaluation"]
    assert best["timesteps"] == eb["timesteps"][means.index(max(means))]
    assert best["mean_reward"] == pytest.approx(max(means))
    assert killed_best in eb["timesteps"]

    # Summary and policies: one run's, its first command; the resume recorded.
    assert summary["timesteps"] == STEPS and summary["sessions"] == 2
    assert summary["resumes"][0]["from_timesteps"] == CHECKPOINT
    assert summary["resumes"][0]["redone_timesteps"] > 0
    assert summary["command"] == "first"
    assert read_json(out / "final" / "policy.json")["command"] == "first"
    assert summary["wall_time_s"] > read_json(uninterrupted / "summary.json")["wall_time_s"] / 3

    if algo == "ddpg":
        # The replay buffer: the resumed session starts from the checkpoint's transitions, all
        # of them and no other (the killed session's after the checkpoint are gone).
        assert (int(saved["pos"]), bool(saved["full"])) == (CHECKPOINT, False)
        assert restored[0].keys() == saved.keys()
        for name, values in saved.items():
            np.testing.assert_array_equal(restored[0][name], values, err_msg=name)
        # Up to the checkpoint they are the uninterrupted run's (the same seeds and steps); after
        # it, the resumed session's own: its envs are seeded anew (`_resume_seed`), so its
        # episodes differ from those the uninterrupted (and the killed) run had there.
        final = _replay_buffer(out / "checkpoints" / f"ckpt-{STEPS:012d}")
        twin = _replay_buffer(uninterrupted / "checkpoints" / f"ckpt-{STEPS:012d}")
        assert int(final["pos"]) == int(twin["pos"]) == STEPS
        for name in REPLAY_BUFFER_ARRAYS:
            np.testing.assert_array_equal(final[name][:CHECKPOINT], saved[name], err_msg=name)
            np.testing.assert_array_equal(final[name][:CHECKPOINT], twin[name][:CHECKPOINT])
        after = (final["observations"][CHECKPOINT:], twin["observations"][CHECKPOINT:])
        assert not np.array_equal(*after)

    # A resume with nothing left to do changes no history.
    rows, before = b.read_text(), evaluations(out)
    again = train(config, out, resume=True, progress_bar=False, command="third")
    assert b.read_text() == rows and evaluations(out) == before
    assert again["sessions"] == 3 and again["timesteps"] == STEPS
    assert read_json(out / "best" / "policy.json")["evaluation"] == best


# -- a run that fails to start can be resumed or reused -----------------------------


def test_a_run_that_fails_to_start_leaves_a_directory_that_can_be_reused(tmp_path):
    out = tmp_path / "run"
    broken = tmp_path / "broken_policy"
    broken.mkdir()
    (broken / "policy.json").write_text("{not json")
    config = dataclasses.replace(tiny_config(128), init_from=str(broken))
    with pytest.raises(ValueError, match="corrupt policy metadata"):
        train(config, out, progress_bar=False)
    assert not (out / "config.json").exists()
    assert train(tiny_config(128), out, progress_bar=False)["timesteps"] == 128


@pytest.mark.parametrize("how", [pytest.param("failed", marks=pytest.mark.slow), "killed"])
def test_a_run_stopped_before_its_first_checkpoint_resumes_or_is_reused(tmp_path, how):
    config = tiny_config(256)

    def stopped_run(out):
        on_step = train_module._Run._on_step

        def patched(self):
            if self.model.num_timesteps >= 40:
                if how == "killed":
                    die()
                raise RuntimeError("a failure in the first rollout")
            return on_step(self)

        train_module._Run._on_step = patched
        train(config, out, progress_bar=False)

    for out in (tmp_path / "resumed", tmp_path / "reused"):
        if how == "killed":
            assert run_killed(stopped_run, out) == KILLED
        else:
            saved = train_module._Run._on_step
            try:
                with pytest.raises(RuntimeError, match="first rollout"):
                    stopped_run(out)
            finally:
                train_module._Run._on_step = saved
        assert (out / "config.json").is_file() and not checkpoint_dirs(out)
    assert train(config, tmp_path / "resumed", resume=True, progress_bar=False)["timesteps"] == 256
    assert train(config, tmp_path / "reused", progress_bar=False)["timesteps"] == 256
    for out in (tmp_path / "resumed", tmp_path / "reused"):
        assert csv_steps(out / "logs" / "progress.csv")[-1] == 256
        assert len(list((out / "logs").glob("events.out.tfevents.*"))) == 1
