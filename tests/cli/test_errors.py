"""Every bad input (a value, option, file or path) is one line on stderr naming the value,
the file or option and what is allowed, exit code 2, and no traceback; what each exit code
means."""

import json
import re
from dataclasses import asdict

import pytest

import drake_tooluse.cli.robot as robot_cli
from drake_tooluse.cli import EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_USAGE, main
from drake_tooluse.learning.config import resolve_config
from drake_tooluse.paths import TRANSFER_POLICY
from tests.cli.test_parser import strict_json

SIMULATE = ["simulate", "--tip-waypoints", "0.66,-0.2,-0.12", "--move-time", "0.1", "--dwell", "0"]


def run(capsys, argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    if "--json" in map(str, argv):
        strict_json(captured.out)  # strict JSON, errors included
    return code, captured.out, captured.err


def assert_one_line_error(capsys, argv, message):
    code, out, err = run(capsys, argv)
    assert code == EXIT_USAGE, (code, err)
    assert "Traceback" not in err + out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert re.search(message, lines[0]), lines[0]
    return lines[0]


# -- files prepared for the cases ------------------------------------------------------------

SCENARIOS = {
    "syntax.yaml": "tool: [1, 2\n",
    "scalar_group.yaml": "tool: 5\n",
    "wrong_type.yaml": "box: {size: 0.04}\n",
    "heavy.yaml": "box:\n  mass: heavy\n",
    "twice.yaml": "box:\n  mass: 0.3\n  mass: 0.4\n",
}


@pytest.fixture
def files(tmp_path):
    for name, text in SCENARIOS.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "a_file").write_text("not a directory")
    (tmp_path / "a_dir").mkdir()
    (tmp_path / "truncated.npz").write_bytes(b"PK\x03\x04" + b"\x00" * 20)
    policy = tmp_path / "policy"
    policy.mkdir()
    for name in ("policy.safetensors", "normalization.json"):
        (policy / name).write_bytes((TRANSFER_POLICY / name).read_bytes())
    meta = json.loads((TRANSFER_POLICY / "policy.json").read_text())
    (policy / "policy.json").write_text(json.dumps({**meta, "env_kwargs": "x"}))
    return tmp_path


CASES = [
    # scenario files
    (
        SIMULATE + ["--scenario", "{d}/syntax.yaml"],
        r"syntax.yaml': not YAML: .*\(line 2, column 1\)",
    ),
    (
        SIMULATE + ["--scenario", "{d}/scalar_group.yaml"],
        r"tool=5 must be a group of values \(length,",
    ),
    (SIMULATE + ["--scenario", "{d}/wrong_type.yaml"], r"box.size=0.04 must be a list of numbers"),
    # output paths, checked before any work
    (SIMULATE + ["--record", "{d}/a_dir"], r"--record '.*a_dir' is a directory; give a file name"),
    (
        SIMULATE + ["--record", "{d}/a_file/x.html"],
        r"--record .*a_file' is a file, not a directory",
    ),
    (
        ["transfer", "--runs", "1", "--out", "{d}/a_file"],
        r"--out '.*a_file' is a file; give a directory",
    ),
    (["demo", "--out", "{d}/a_file"], r"--out '.*a_file' is a file; give a directory"),
    (
        ["trajectory", "--policy", TRANSFER_POLICY, "--out", "{d}/a_file"],
        r"--out '.*a_file' is a file",
    ),
    (["measure", "--save-images", "{d}/a_file"], r"--save-images '.*a_file' is a file"),
    (["measure-shape", "--family", "spoon"], r"tool family|--family.*'spoon'.*straight"),
    (["measure-shape", "--tool-seed", "3"], r"--tool-seed draws a generated tool: give --family"),
    (["measure-shape", "--family", "arc", "--tool-seed", "-1"], r"--tool-seed"),
    (["measure-shape", "--depth-noise", "0.5"], r"--depth-noise=0.5.*\[0, 0.01\]"),
    (
        [
            "export-csv",
            "--trajectory",
            "{d}/truncated.npz",
            "--tool-length",
            "0.175",
            "--out",
            "{d}/x.csv",
        ],
        r"malformed trajectory file '.*truncated.npz'",
    ),
    (
        [
            "export-csv",
            "--trajectory",
            "{d}/truncated.npz",
            "--tool-length",
            "0.175",
            "--out",
            "{d}/a_dir",
        ],
        r"--out '.*a_dir' is a directory",
    ),
    # JSON options
    (
        ["evaluate", "--policy", TRANSFER_POLICY, "--env-kwargs", '{"colour": 1}'],
        r"unknown argument\(s\) \['colour'\] for a drake_tooluse env",
    ),
    (
        ["evaluate", "--policy", TRANSFER_POLICY, "--env-kwargs", "[1, 2]"],
        r"--env-kwargs must be a JSON object of names to values",
    ),
    (["train", "--out", "{d}/run", "--hyperparams", "5"], r"--hyperparams must be a JSON object"),
    (["train", "--out", "{d}/run", "--hyperparams", "{nope"], r"--hyperparams is not valid JSON"),
    (
        ["train", "--out", "{d}/run", "--hyperparams", '{"nope": 1}'],
        r"unknown hyperparameter\(s\) \['nope'\] for ppo",
    ),
    (
        ["train", "--out", "{d}/run", "--hyperparams", '{"n_envs": 0}'],
        r"n_envs=0 is outside the allowed range \[1, 64\]",
    ),
    # seeds name their option
    (
        ["evaluate", "--policy", TRANSFER_POLICY, "--seed", "-1"],
        r"--seed=-1 is outside the allowed range \[0, 4294967295\]",
    ),
    (["train", "--out", "{d}/run", "--seed", "-1"], r"--seed=-1 is outside the allowed range"),
    (["transfer", "--seed", "-1", "--out", "{d}/t"], r"--seed=-1 is outside the allowed range"),
    (["demo", "--seed", "-1", "--out", "{d}/t"], r"--seed=-1 is outside the allowed range"),
    (["sweep", "--seeds", "0", "-1", "--out", "{d}/s"], r"--seeds=-1 is outside the allowed range"),
    # policy.json with env_kwargs "x"
    (
        ["evaluate", "--policy", "{d}/policy"],
        r"policy.json': env_kwargs must be a mapping .* got str 'x'",
    ),
    # non-finite and out-of-range numbers
    (
        ["fk", "--tool-length", "nan", "--q", *["0"] * 7],
        r"--tool-length=nan must be a finite number in the allowed range \(0, 0.6\] m",
    ),
    (
        SIMULATE + ["--scenario", "{d}/heavy.yaml"],
        r"invalid scenario '.*heavy.yaml': box.mass='heavy' must be a number",
    ),
    (
        SIMULATE + ["--scenario", "{d}/twice.yaml"],
        r"twice.yaml': .*key 'mass' is given twice \(first on line 2\)",
    ),
    (
        ["ik", "--tool-length", "0.1", "--position", "1e300", "0", "0", "--json"],
        r"--position=\[1e\+300, 0.0, 0.0\] m is outside the allowed range \[-10, 10\] m",
    ),
    (
        ["simulate", "--tip-waypoints", "1e300,0,0"],
        r"waypoint '1e300,0,0': positions must be in \[-10, 10\] m",
    ),
    (
        ["simulate", *SIMULATE[1:], "--believed-tool-length", "0.9"],
        r"--believed-tool-length=0.9 m is outside",
    ),
    # env kwargs, through the command line
    (
        ["evaluate", "--policy", TRANSFER_POLICY, "--env-kwargs", '{"randomize": "yes"}'],
        r"randomize='yes' must be True or False",
    ),
    (
        ["evaluate", "--policy", TRANSFER_POLICY, "--env-kwargs", '{"include_tool_length": "no"}'],
        r"include_tool_length='no' must be True or False",
    ),
    # the sweep checks everything before Ray starts
    (["sweep", "--episodes", "0", "--out", "{d}/s"], r"--episodes=0 is outside the allowed range"),
    (
        ["sweep", "--timesteps", "0", "--out", "{d}/s"],
        r"--timesteps=0 is outside the allowed range",
    ),
    (["sweep", "--num-cpus", "0", "--out", "{d}/s"], r"--num-cpus=0 is outside the allowed range"),
    (["sweep", "--out", "{d}/a_file"], r"--out '.*a_file' is a file"),
    (
        ["transfer", "--mode", "open-loop", "--calibration-draws", "-1", "--out", "{d}/t"],
        r"--calibration-draws=-1 is outside the allowed range \[0, 1000\]",
    ),
    (
        [
            "trajectory",
            "--policy",
            TRANSFER_POLICY,
            "--calibration-draws",
            "1001",
            "--out",
            "{d}/t",
        ],
        r"--calibration-draws=1001 is outside the allowed range \[0, 1000\]",
    ),
    # paths that name no file (an unset shell variable: the current directory), values
    # dropped or checked only after the work
    (["measure", "--scenario", "", "--json"], r"argument --scenario: '' is not a path"),
    (["train", "--out", " ", "--json"], r"argument --out: ' ' is not a path"),
    (["demo", "--out", "a\x00b", "--json"], r"argument --out: 'a\\x00b' holds a NUL byte"),
    (["train", "--out", "{d}/run", "--hyperparams", ""], r"--hyperparams is not valid JSON .*''"),
    (
        ["train", "--out", "{d}/run", "--hyperparams", '{"n_steps": NaN}'],
        r"n_steps=nan must be finite",
    ),
    (
        ["ik", "--tool-length", "0.1", "--position", "0.6", "0", "0", "--scenario", "{d}/a_dir"],
        r"--scenario is the world --measure measures: give --measure with it",
    ),
    (
        ["sweep", "--out", "{d}/s", "--address", "nowhere"],
        r"address='nowhere' is not a Ray cluster's address",
    ),
    (
        ["transfer", "--runs", "1", "--trajectory", "{d}/a_file", "--out", "{d}/t"],
        r"trajectory_path='.*a_file' is replayed in open loop only; mode='closed-loop'",
    ),
    (
        ["study", "--out", "{d}/st", "--status", "--runs-dir", "{d}/a_file"],
        r"--runs-dir '.*a_file' is a file",
    ),
    (
        [
            "dev",
            "render-figures",
            "--check",
            "--figures-dir",
            "{d}/a_dir",
            "--only",
            "simulate_meshcat",
        ],
        r"simulate_meshcat.png or its simulate_meshcat.json is missing",
    ),
]


@pytest.mark.parametrize("argv, message", CASES, ids=[" ".join(map(str, c[0]))[:60] for c in CASES])
def test_bad_input_is_one_line_and_exit_2(files, capsys, argv, message):
    argv = [str(a).replace("{d}", str(files)) for a in argv]
    line = assert_one_line_error(capsys, argv, message)
    assert "Errno" not in line and ".zip.zip" not in line


def test_a_result_naming_a_file_of_non_utf8_bytes_prints_under_a_strict_locale(monkeypatch, capsys):
    # (capsys' stdout is strict UTF-8, as under a UTF-8 locale)
    monkeypatch.setattr(robot_cli, "cmd_fk", lambda args: {"file": "/tmp/a\udcffb"})
    monkeypatch.setattr(robot_cli, "format_fk", lambda out: f"wrote {out['file']}")
    assert main(["fk", "--no-tool", "--q", *["0"] * 7]) == 0
    assert capsys.readouterr().out == "wrote /tmp/a\\udcffb\n"


def test_a_read_only_directory_is_refused_before_work(tmp_path, capsys):
    import os

    if os.geteuid() == 0:
        pytest.skip("root writes into read-only directories")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert_one_line_error(capsys, [*SIMULATE, "--record", ro / "x.html"], r"is not writable")
        assert_one_line_error(capsys, ["demo", "--out", ro / "demo"], r"is not writable")
    finally:
        ro.chmod(0o700)


def test_the_sweep_refuses_cells_its_cpus_cannot_hold_before_ray_starts(tmp_path, capsys):
    ray = pytest.importorskip("ray")
    argv = ["sweep", "--num-cpus", "1", "--out", tmp_path / "s", "--timesteps", "100"]
    assert_one_line_error(
        capsys, argv, r"reserves 2 CPUs, but num_cpus \(--num-cpus\) gives 1: Ray would wait"
    )
    assert not ray.is_initialized()
    assert not (tmp_path / "s").exists()  # nothing trained, nothing written


def test_the_sweep_refuses_a_bad_value_of_any_cell_before_training(tmp_path, capsys):
    argv = [
        "sweep",
        "--algos",
        "ppo",
        "ddpg",
        "--out",
        tmp_path / "s",
        "--hyperparams",
        '{"n_steps": 8}',
    ]
    # n_steps is PPO's (and DDPG's n-step returns): fine; clip_range is PPO's only.
    argv[-1] = '{"clip_range": 0.1}'
    assert_one_line_error(capsys, argv, r"unknown hyperparameter\(s\) \['clip_range'\] for ddpg")
    assert not (tmp_path / "s").exists()


def test_a_refused_resume_names_the_keys_that_differ(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    saved = resolve_config("drake_tooluse/ToolPush-v1", "ppo", 1000, 1, 0)
    (run / "config.json").write_text(json.dumps(asdict(saved)))
    line = assert_one_line_error(
        capsys,
        [
            "train",
            "--resume",
            run,
            "--n-envs",
            "1",
            "--timesteps",
            "2000",
            "--hyperparams",
            '{"learning_rate": 0.1}',
        ],
        r"refusing to resume .* different settings: hyperparams.learning_rate: saved 0.0003, asked 0.1$",
    )
    assert "n_steps" not in line  # only what differs


def test_corrupt_run_files_name_the_file(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text("{corrupt")
    assert_one_line_error(
        capsys, ["train", "--resume", run], r"corrupt run configuration '.*config.json'"
    )
    saved = resolve_config("drake_tooluse/ToolPush-v1", "ppo", 1000, 1, 0)
    (run / "config.json").write_text(json.dumps(asdict(saved)))
    checkpoint = run / "checkpoints" / "ckpt-000000000512"
    checkpoint.mkdir(parents=True)
    (checkpoint / "checkpoint.json").write_text("{corrupt")
    assert_one_line_error(
        capsys,
        ["train", "--resume", run, "--n-envs", "1", "--timesteps", "1000"],
        r"corrupt checkpoint '.*ckpt-000000000512/checkpoint.json'",
    )


def test_a_huge_scenario_is_refused_before_it_is_parsed(tmp_path, capsys):
    import time

    huge = tmp_path / "huge.yaml"
    huge.write_text("goal_offset: [" + ", ".join(["0.1"] * 2_000_000) + "]\n")
    start = time.perf_counter()
    assert_one_line_error(
        capsys, [*SIMULATE, "--scenario", huge], r"huge.yaml' is \d+\.\d MB; at most 1 MB"
    )
    assert time.perf_counter() - start < 5


def test_json_output_is_strict_json(monkeypatch, capsys):
    monkeypatch.setattr(
        robot_cli, "cmd_fk", lambda args: {"x": float("inf"), "y": [float("nan"), 1.0]}
    )
    code, out, _ = run(capsys, ["fk", "--no-tool", "--q", *["0"] * 7, "--json"])
    assert code == 0
    assert json.loads(out, parse_constant=lambda c: pytest.fail(f"{c} is not JSON")) == {
        "x": None,
        "y": [None, 1.0],
    }
    code, out, _ = run(
        capsys, ["ik", "--tool-length", "0.1", "--position", "1e300", "0", "0", "--json"]
    )
    assert code == EXIT_USAGE and "outside the allowed range" in json.loads(out)["error"]


@pytest.mark.parametrize(
    "error, code",
    [
        (TypeError("an internal bug"), EXIT_INTERNAL),
        (KeyboardInterrupt(), EXIT_INTERRUPTED),
        (PermissionError(13, "Permission denied", "/somewhere/x.csv"), EXIT_USAGE),
    ],
)
def test_exit_codes(monkeypatch, capsys, error, code):
    def fail(args):
        raise error

    monkeypatch.setattr(robot_cli, "cmd_fk", fail)
    got, _, err = run(capsys, ["fk", "--no-tool", "--q", *["0"] * 7])
    assert got == code and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    if code == EXIT_INTERNAL:
        assert (
            "internal error TypeError: an internal bug" in err and "DRAKE_TOOLUSE_TRACEBACK" in err
        )
        monkeypatch.setenv("DRAKE_TOOLUSE_TRACEBACK", "1")
        with pytest.raises(TypeError):
            main(["fk", "--no-tool", "--q", *["0"] * 7])
    if isinstance(error, PermissionError):
        assert "'/somewhere/x.csv': Permission denied" in err


def test_a_runtime_error_is_a_usage_error_only_when_drake_tooluse_raises_it(
    monkeypatch, capsys, tmp_path
):
    """The library's own RuntimeErrors name an environment problem (a missing program, a busy
    run directory): exit 2; one from inside a library it calls (Drake, torch) is a bug: exit 1."""
    from drake_tooluse.files import run_lock

    def busy(args):
        with run_lock(tmp_path):
            with run_lock(tmp_path):  # a second holder, as another process would be
                pass

    monkeypatch.setattr(robot_cli, "cmd_fk", busy)
    assert_one_line_error(capsys, ["fk", "--no-tool", "--q", *["0"] * 7], r"is in use by another")

    def drake_fails(args):
        from pydrake.multibody.plant import MultibodyPlant

        MultibodyPlant(0.0).GetBodyByName("nope")  # Drake's C++ throws a RuntimeError

    for fail in (drake_fails, lambda args: (_ for _ in ()).throw(RuntimeError("in a library"))):
        monkeypatch.setattr(robot_cli, "cmd_fk", fail)
        code, _, err = run(capsys, ["fk", "--no-tool", "--q", *["0"] * 7])
        assert code == EXIT_INTERNAL and "internal error RuntimeError" in err, err
