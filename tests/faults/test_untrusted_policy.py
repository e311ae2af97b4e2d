"""Booby-trapped policy directories: a pickle whose `__reduce__` runs code,
beside a policy or inside its SB3 zip. Loading runs no code from a policy's files; the older
pickle format loads only with the explicit opt-in, and then the code does run."""

import base64
import json
import pickle
import shutil
import zipfile

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import drake_tooluse.learning.policy_dir as policy_dir
from drake_tooluse.cli import main
from drake_tooluse.learning.policy_dir import build_model, load_policy
from drake_tooluse.paths import TRANSFER_POLICY


class Trap:
    """Unpickling it writes `marker`: the proof that foreign code ran."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (exec, (f"open({self.marker!r}, 'w').write('ran')",))


def _legacy_dir(tmp_path, marker, trap_in_zip: bool = False):
    """A policy directory in the older pickle format (an SB3 zip, a pickled normaliser) with a
    trap in `vecnormalize.pkl` or, `trap_in_zip`, in one of the zip's cloudpickled entries."""
    legacy = tmp_path / "legacy"
    legacy.mkdir()
    meta = json.loads((TRANSFER_POLICY / "policy.json").read_text())
    (legacy / "policy.json").write_text(json.dumps(meta))
    model = build_model(policy_dir.parse_meta(meta, TRANSFER_POLICY / "policy.json"))
    model.save(legacy / "policy.zip")
    if trap_in_zip:
        with zipfile.ZipFile(legacy / "policy.zip") as z:
            entries = {name: z.read(name) for name in z.namelist()}
        data = json.loads(entries["data"])
        data["observation_space"][":serialized:"] = base64.b64encode(
            pickle.dumps(Trap(marker))
        ).decode()
        entries["data"] = json.dumps(data).encode()
        with zipfile.ZipFile(legacy / "policy.zip", "w") as z:
            for name, content in entries.items():
                z.writestr(name, content)
        (legacy / "vecnormalize.pkl").write_bytes(pickle.dumps({"not": "used"}))
    else:
        (legacy / "vecnormalize.pkl").write_bytes(pickle.dumps(Trap(marker)))
    return legacy


def test_a_trap_beside_a_policy_is_never_opened(tmp_path, capsys):
    marker = tmp_path / "ran.txt"
    policy = tmp_path / "policy"
    shutil.copytree(TRANSFER_POLICY, policy)
    (policy / "vecnormalize.pkl").write_bytes(pickle.dumps(Trap(marker)))
    load_policy(policy)
    assert main(["evaluate", "--policy", str(policy), "--episodes", "1", "--json"]) == 0
    assert not marker.exists()


def test_loading_a_policy_unpickles_nothing(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("a pickle was loaded")

    for name in ("load", "loads"):
        monkeypatch.setattr(pickle, name, refuse)
    monkeypatch.setattr(pickle, "Unpickler", refuse)
    monkeypatch.setattr(policy_dir.pickle, "load", refuse)
    policy = load_policy(TRANSFER_POLICY)
    assert policy.act([0.0] * 12).shape == (3,)


@pytest.mark.parametrize("trap_in_zip", [False, True], ids=["vecnormalize.pkl", "policy.zip"])
def test_the_pickle_format_needs_the_opt_in(tmp_path, capsys, trap_in_zip):
    marker = tmp_path / "ran.txt"
    legacy = _legacy_dir(tmp_path, marker, trap_in_zip)
    with pytest.raises(ValueError, match=r"older pickle format.*--trust-pickle"):
        load_policy(legacy)
    for argv in (
        ["evaluate", "--policy", str(legacy), "--episodes", "1"],
        ["transfer", "--policy", str(legacy), "--runs", "1", "--out", str(tmp_path / "t")],
        ["demo", "--policy", str(legacy), "--out", str(tmp_path / "d"), "--no-progress"],
        ["trajectory", "--policy", str(legacy), "--episodes", "1", "--out", str(tmp_path / "j")],
        ["convert-policy", "--policy", str(legacy), "--out", str(tmp_path / "c")],
    ):
        assert main(argv) == 2, argv
        assert "--trust-pickle" in capsys.readouterr().err
    assert not marker.exists()
    assert not (tmp_path / "t").exists() and not (tmp_path / "d").exists()
    # The opt-in is real: told to trust the files, the loader runs their pickles (and then
    # finds no model or normaliser in them).
    with pytest.raises(ValueError, match="cannot load"):
        load_policy(legacy, trust_pickle=True)
    assert marker.read_text() == "ran"


class _Spaces(gym.Env):
    """An env with the tool-tip policy's spaces, for a real pickled VecNormalize."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (12,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)

    def reset(self, *, seed=None, options=None):
        return np.zeros(12, np.float32), {}

    def step(self, action):
        return np.zeros(12, np.float32), 0.0, False, False, {}


def test_convert_policy_writes_a_directory_without_pickles(tmp_path):
    legacy = tmp_path / "legacy"
    legacy.mkdir()
    shutil.copy(TRANSFER_POLICY / "policy.json", legacy / "policy.json")
    shutil.copy(TRANSFER_POLICY / "metrics.json", legacy / "metrics.json")
    old = load_policy(TRANSFER_POLICY)
    old.model.save(legacy / "policy.zip")
    normalizer = VecNormalize(DummyVecEnv([_Spaces]))
    normalizer.obs_rms = old.obs_rms
    normalizer.save(str(legacy / "vecnormalize.pkl"))
    argv = ["convert-policy", "--policy", str(legacy), "--out", str(tmp_path / "new")]
    assert main(argv) == 2  # not without the opt-in
    assert main([*argv, "--trust-pickle"]) == 0
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == [
        "metrics.json",
        "normalization.json",
        "policy.json",
        "policy.safetensors",
    ]
    new = load_policy(tmp_path / "new")
    assert new.meta.policy_kwargs == {"net_arch": [128, 128]}
    rng = np.random.default_rng(0)
    for obs in rng.normal(0, 0.5, (50, 12)).astype(np.float32):
        np.testing.assert_array_equal(new.act(obs), old.act(obs))


def test_a_trusted_old_directory_without_its_zip_is_named(tmp_path):
    legacy = tmp_path / "legacy"
    legacy.mkdir()
    shutil.copy(TRANSFER_POLICY / "policy.json", legacy / "policy.json")
    (legacy / "vecnormalize.pkl").write_bytes(pickle.dumps({}))
    with pytest.raises(
        FileNotFoundError, match=r"has no policy.safetensors \(nor the older policy.zip\)$"
    ):
        load_policy(legacy, trust_pickle=True)


@pytest.mark.parametrize("name", ["policy.json", "normalization.json", "policy.safetensors"])
def test_a_policy_file_linked_out_of_its_directory_is_refused_unread(tmp_path, capsys, name):
    policy = tmp_path / "policy"
    shutil.copytree(TRANSFER_POLICY, policy)
    foreign = tmp_path / "elsewhere" / name
    foreign.parent.mkdir()
    foreign.write_bytes((policy / name).read_bytes())
    (policy / name).unlink()
    (policy / name).symlink_to(foreign)
    with pytest.raises(ValueError, match=r"is a symbolic link to .*outside the policy directory"):
        load_policy(policy)
    assert main(["evaluate", "--policy", str(policy), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "outside the policy directory" in err
    # A link that stays inside the directory is the directory's own file.
    (policy / name).unlink()
    foreign.rename(policy / f"real-{name}")
    (policy / name).symlink_to(policy / f"real-{name}")
    assert load_policy(policy).meta.env_id
