"""A stranger's policy directory: it reads nothing outside itself and the package's data, its
numbers are checked against its weights file before any network is built, and each bad file
is one line that names the file and the field (exit 2), never a bug's exit 1.

Covers: the policy directory's paths (scenario by name, inside it or shipped); shapes and sizes
against the safetensors header before anything is built; `net_arch` and `policy` values;
NaN weights, malformed header metadata, 5,000-digit integers, 10,000-deep JSON and
kilobyte-long values named in one short line; and policy.json fuzzed (hypothesis)."""

import dataclasses as dc
import json
import re
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from safetensors.torch import load_file, save_file

import drake_tooluse.learning.policy_dir as policy_dir
from drake_tooluse.cli import EXIT_USAGE, main
from drake_tooluse.learning.policy_dir import load_policy, save_policy
from drake_tooluse.paths import SCENARIOS_DIR, TRANSFER_POLICY
from drake_tooluse.world.scenario import load_scenario

SECRET = "secret_token_1234"


def policy_copy(tmp_path, name="policy", **changes) -> Path:
    """A copy of the shipped tool-tip policy with policy.json's fields changed (`env_kwargs`
    entries by `env_<key>`)."""
    d = tmp_path / name
    shutil.copytree(TRANSFER_POLICY, d)
    meta = json.loads((d / "policy.json").read_text())
    for key, value in changes.items():
        if key.startswith("env_"):
            meta["env_kwargs"][key[4:]] = value
        else:
            meta[key] = value
    (d / "policy.json").write_text(json.dumps(meta))
    return d


def evaluate_error(capsys, policy, *extra) -> str:
    """`evaluate --policy` must be exit 2 with one line on stderr; returns it."""
    code = main(["evaluate", "--policy", str(policy), "--episodes", "1", *extra])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def outside(tmp_path):
    """A folder beside the policy with a scenario-looking file that holds a secret."""
    folder = tmp_path / "outside"
    folder.mkdir()
    (folder / "secret.yaml").write_text(f"{SECRET}: 1\nanother_secret_key: 2\n")
    return folder


@pytest.fixture
def reads(monkeypatch):
    """The files read through Python (Path.read_text / read_bytes, open) while the test runs."""
    seen = []
    for name in ("read_text", "read_bytes"):
        original = getattr(Path, name)

        def wrapper(self, *args, _original=original, **kwargs):
            seen.append(self.resolve())
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(Path, name, wrapper)
    return seen


# -- a policy directory reads nothing outside itself --------------------------------------


def _absolute(d, outside):
    return str(outside / "secret.yaml")


def _parent(d, outside):
    return "../outside/secret.yaml"


def _inner_parent(d, outside):
    (d / "sub").mkdir()
    return "sub/../../outside/secret.yaml"


def _symlink(d, outside):
    (d / "scenario.yaml").symlink_to(outside / "secret.yaml")
    return "scenario.yaml"


def _base_outside(d, outside):
    (d / "scenario.yaml").write_text("base: ../outside/secret.yaml\n")
    return "scenario.yaml"


def _model_outside(d, outside):
    (outside / "tool.urdf").write_text(f"<robot name='{SECRET}'/>\n")
    (d / "scenario.yaml").write_text("tool:\n  model: ../outside/tool.urdf\n")
    return "scenario.yaml"


def _foreign_package(d, outside):
    (d / "scenario.yaml").write_text("tool:\n  model: package://drake_models/x.urdf\n")
    return "scenario.yaml"


@pytest.mark.parametrize(
    "reference",
    [
        _absolute,
        _parent,
        _inner_parent,
        _symlink,
        _base_outside,
        _model_outside,
        _foreign_package,
    ],
    ids=lambda f: f.__name__[1:],
)
def test_a_policy_directory_reads_nothing_outside_itself(
    tmp_path, outside, capsys, reads, reference
):
    policy = policy_copy(tmp_path)
    meta = json.loads((policy / "policy.json").read_text())
    meta["env_kwargs"]["scenario"] = reference(policy, outside)
    (policy / "policy.json").write_text(json.dumps(meta))
    line = evaluate_error(capsys, policy)
    assert "env_kwargs.scenario" in line or "tool.model" in line, line
    assert SECRET not in line and "another_secret_key" not in line, line
    assert not [p for p in reads if p.is_relative_to(outside.resolve())], reads


@pytest.mark.parametrize("name", ["reality.yaml", "scenario.yaml"])
def test_a_scenario_by_name_is_the_directory_s_own_or_a_shipped_one(tmp_path, name):
    policy = policy_copy(tmp_path, env_scenario=name)
    if name == "scenario.yaml":  # the directory's own, on a base beside it
        shutil.copy(SCENARIOS_DIR / "push_tool_125.yaml", policy / name)
        (policy / "push.yaml").write_bytes((SCENARIOS_DIR / "push.yaml").read_bytes())
    loaded = load_policy(policy).meta.env_kwargs["scenario"]
    expected = policy / name if name == "scenario.yaml" else SCENARIOS_DIR / name
    assert Path(loaded) == expected.resolve()
    assert load_scenario(loaded).tool.length == 0.125


def test_an_env_check_that_reads_the_scenario_reads_the_directory_s_own(tmp_path, monkeypatch):
    """A delay range is checked against the scenario's plant step, which the env reads from
    its scenario: the directory's, resolved before that check (not a file of that name
    wherever the command runs)."""
    policy = policy_copy(
        tmp_path, env_scenario="scenario.yaml", env_actuation_delay_range=[0.0, 0.04]
    )
    shutil.copy(SCENARIOS_DIR / "push_tool_125.yaml", policy / "scenario.yaml")
    (policy / "push.yaml").write_bytes((SCENARIOS_DIR / "push.yaml").read_bytes())
    monkeypatch.chdir(tmp_path)  # no scenario.yaml here
    meta = load_policy(policy).meta
    assert Path(meta.env_kwargs["scenario"]) == (policy / "scenario.yaml").resolve()
    assert meta.env_kwargs["actuation_delay_range"] == [0.0, 0.04]


def test_a_saved_policy_holds_its_scenario_and_names_it(tmp_path):
    """The scenario a policy was trained in (a file anywhere, layered on a base) is written
    into its directory, merged, and named there: the directory is whole without it."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "base.yaml").write_text("box:\n  mass: 0.3\n")
    (elsewhere / "mine.yaml").write_text("base: base.yaml\ntool:\n  length: 0.2\n")
    old = load_policy(TRANSFER_POLICY)
    meta = dc.replace(
        old.meta, env_kwargs={**old.meta.env_kwargs, "scenario": str(elsewhere / "mine.yaml")}
    )
    save_policy(old.model, None, dc.replace(meta, normalized=False), tmp_path / "saved")
    shutil.rmtree(elsewhere)
    saved = json.loads((tmp_path / "saved" / "policy.json").read_text())
    assert saved["env_kwargs"]["scenario"] == "scenario.yaml"
    scenario = load_scenario(load_policy(tmp_path / "saved").meta.env_kwargs["scenario"])
    assert (scenario.tool.length, scenario.box.mass) == (0.2, 0.3)
    # A shipped scenario is stored by its name.
    meta = dc.replace(
        meta, env_kwargs={**meta.env_kwargs, "scenario": str(SCENARIOS_DIR / "reality.yaml")}
    )
    save_policy(old.model, None, dc.replace(meta, normalized=False), tmp_path / "shipped")
    saved = json.loads((tmp_path / "shipped" / "policy.json").read_text())
    assert saved["env_kwargs"]["scenario"] == "reality.yaml"
    assert not (tmp_path / "shipped" / "scenario.yaml").exists()


# -- sizes against the weights file, before anything is built -------------------------------


@pytest.fixture
def no_build(monkeypatch):
    def refuse(meta):
        raise AssertionError(f"a network was built for {meta.policy_kwargs}")

    monkeypatch.setattr(policy_dir, "build_model", refuse)


@pytest.mark.parametrize(
    "net_arch, message",
    [
        ([4096, 4096], r"makes a network of at least 16,826,368 parameters, but .* holds 36,871"),
        ({"pi": [4096], "vf": [4096, 4096]}, r"makes a network of at least"),
        ([20000, 20000], r"net_arch\[0\]=20000 is outside the allowed range \[1, 4096\]"),
        ([200000, 200000], r"net_arch\[0\]=200000 is outside the allowed range"),
        ([64] * 17, r"net_arch=\[64, 64, .*\.\.\.\] must be a list of at most 16"),
    ],
)
def test_net_arch_is_checked_against_the_weights_before_a_network_is_built(
    tmp_path, no_build, net_arch, message
):
    policy = policy_copy(tmp_path, policy_kwargs={"net_arch": net_arch})
    with pytest.raises(ValueError, match=message):
        load_policy(policy)


def test_a_header_that_lies_about_its_tensors_is_refused_before_they_are_read(tmp_path, no_build):
    policy = policy_copy(tmp_path)
    weights = policy / "policy.safetensors"
    data = weights.read_bytes()
    n = int.from_bytes(data[:8], "little")
    header = json.loads(data[8 : 8 + n])
    key = next(k for k in header if k != "__metadata__")
    header[key]["shape"] = [200000, 200000]
    text = json.dumps(header).encode()
    weights.write_bytes(struct.pack("<Q", len(text)) + text + data[8 + n :])
    with pytest.raises(ValueError, match=rf"entry '{key}' .* is not a tensor stored in the file"):
        load_policy(policy)


# -- bad values: exit 2 naming the field, never a bug's exit 1 --------------------------------


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"policy_kwargs": {"net_arch": [-1]}}, r"policy_kwargs.net_arch\[0\]=-1 is outside"),
        ({"policy_kwargs": {"net_arch": [0, 128]}}, r"policy_kwargs.net_arch\[0\]=0 is outside"),
        ({"policy_kwargs": {"net_arch": {"pi": [128], "xx": [1]}}}, r"unknown networks \['xx'\]"),
        ({"policy_kwargs": {"log_std_init": 1e300}}, r"log_std_init=1e\+300 is outside"),
        ({"policy": "CnnPolicy"}, r"policy='CnnPolicy' is not allowed; choose one of"),
    ],
)
def test_bad_policy_values_are_one_line_naming_the_file_and_field(
    tmp_path, capsys, changes, message
):
    line = evaluate_error(capsys, policy_copy(tmp_path, **changes))
    assert "policy.json" in line, line
    assert re.search(message, line), line


def test_a_5000_digit_integer_and_10000_deep_json_name_the_file(tmp_path, capsys):
    policy = policy_copy(tmp_path)
    text = (policy / "policy.json").read_text()
    (policy / "policy.json").write_text(
        text.replace('"trained_timesteps": ', '"trained_timesteps": ' + "9" * 5000 + ', "x": ')
    )
    line = evaluate_error(capsys, policy)
    assert "policy.json" in line and "4300 digits" in line, line
    (policy / "policy.json").write_text(text[:-1] + ', "deep": ' + "[" * 10000 + "]" * 10000 + "}")
    line = evaluate_error(capsys, policy)
    assert "policy.json" in line and "nested more than" in line, line
    line = evaluate_error(
        capsys, TRANSFER_POLICY, "--env-kwargs", '{"a": ' + "[" * 10000 + "]" * 10000 + "}"
    )
    assert "--env-kwargs is nested more than" in line, line


def test_nan_weights_name_the_file_and_tensor(tmp_path, capsys):
    policy = policy_copy(tmp_path)
    tensors = load_file(str(policy / "policy.safetensors"))
    key = sorted(tensors)[0]
    tensors[key] = torch.full_like(tensors[key], float("nan"))
    save_file(tensors, str(policy / "policy.safetensors"))
    line = evaluate_error(capsys, policy)
    assert f"policy.safetensors': the weights '{key}' hold NaN" in line, line


def test_malformed_header_metadata_names_the_file(tmp_path, capsys):
    policy = policy_copy(tmp_path)
    tensors = load_file(str(policy / "policy.safetensors"))
    save_file(tensors, str(policy / "policy.safetensors"), metadata={"observation_shape": "[12"})
    line = evaluate_error(capsys, policy)
    assert "policy.safetensors': metadata observation_shape is not valid JSON" in line, line


@pytest.mark.parametrize(
    "changes",
    [
        {f"unknown_{i}": i for i in range(600)},
        {"env_reward_type": "x" * 10_000},
        {"env_action_mode": ["position"] * 2_000},
        {"observation_shape": list(range(3_000))},
    ],
    ids=["600 unknown keys", "10 kB string", "2000-item list", "3000 dims"],
)
def test_a_huge_value_makes_a_short_message(tmp_path, capsys, changes):
    line = evaluate_error(capsys, policy_copy(tmp_path, **changes))
    assert len(line) < 600, (len(line), line[:300])


# -- fuzzing policy.json ---------------------------------------------------------------------

_json = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**30), max_value=10**30)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=12),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4)
    ),
    max_leaves=8,
)
_FIELDS = [
    "env_kwargs",
    "observation_shape",
    "action_shape",
    "normalized",
    "policy",
    "policy_kwargs",
    "format",
    "algo",
    "trained_timesteps",
]
_NET_ARCH = st.one_of(
    st.just([128, 128]),  # the weights' own
    st.lists(st.integers(-3, 5000), max_size=3),
    st.dictionaries(
        st.sampled_from(["pi", "vf", "qf", "x"]),
        st.lists(st.integers(-3, 5000), max_size=3),
        max_size=3,
    ),
    _json,
)
_ENV_KWARGS = st.dictionaries(
    st.sampled_from(
        ["scenario", "action_mode", "observation_mode", "tool_length", "randomize", "x"]
    ),
    st.one_of(
        st.sampled_from(
            ["push.yaml", "/etc/passwd", "../policy.json", "position", "tip", "x.yaml"]
        ),
        _json,
    ),
    max_size=3,
)


_CHANGES = st.one_of(
    st.tuples(st.sampled_from(_FIELDS), _json),
    st.tuples(st.just("policy_kwargs"), st.fixed_dictionaries({"net_arch": _NET_ARCH})),
    st.tuples(st.just("env_kwargs+"), _ENV_KWARGS),  # (merged into the policy's own)
    st.tuples(st.just("policy"), st.sampled_from(["MlpPolicy", "CnnPolicy", "MultiInputPolicy"])),
)


@settings(
    max_examples=40,
    deadline=None,
    database=None,  # (nothing written into the checkout)
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(change=_CHANGES)
def test_a_fuzzed_policy_json_loads_or_is_a_value_error(tmp_path_factory, change):
    """Whatever one field of policy.json holds, loading it builds no network larger than its
    weights allow, reads no scenario outside the directory and the package's, and ends in a
    loaded policy or a ValueError/OSError: never another exception (a bug's exit 1), never
    Drake's or torch's abort."""
    field, value = change
    policy = tmp_path_factory.mktemp("fuzz") / "policy"
    shutil.copytree(TRANSFER_POLICY, policy)
    meta = json.loads((policy / "policy.json").read_text())
    if field == "env_kwargs+":
        meta["env_kwargs"].update(value)
    else:
        meta[field] = value
    (policy / "policy.json").write_text(json.dumps(meta))
    try:
        loaded = load_policy(policy)
    except (ValueError, OSError) as e:
        assert len(str(e)) < 2000
        return
    assert sum(p.numel() for p in loaded.model.policy.parameters()) < 10**6
    assert np.all(np.isfinite(loaded.act(np.zeros(12, np.float32))))
    scenario = loaded.meta.env_kwargs.get("scenario")
    if scenario is not None:
        folder = Path(scenario).resolve().parent
        assert folder in (policy.resolve(), SCENARIOS_DIR.resolve()), scenario
