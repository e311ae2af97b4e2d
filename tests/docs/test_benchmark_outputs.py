"""The benchmark scripts that write one JSON of results write it to a new run directory by
default and the tracked docs/results/ file only when asked (`--update-docs`); the stored files
hold no machine's absolute paths."""

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.benchmark_scripts import benchmark_script
from tests.docs.common import strings

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = [
    "env_fidelity",
    "env_memory",
    "env_throughput",
    "hook_vision_accuracy",
    "ik_closed_loop",
    "ik_kinematic",
    "open_loop_variants",
    "vision_accuracy",
]


class _Parsed(Exception):
    """Stops a script's main() right after it parsed its arguments."""

    def __init__(self, namespace):
        super().__init__()
        self.namespace = namespace


def _parsed_args(module, argv, monkeypatch) -> argparse.Namespace:
    """The namespace the script's own main() parses from `argv`."""
    parse_args = argparse.ArgumentParser.parse_args

    def parse_and_stop(parser, args=None, namespace=None):
        raise _Parsed(parse_args(parser, args, namespace))

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_and_stop)
    monkeypatch.setattr(sys, "argv", [f"{module.__name__}.py", *argv])
    with pytest.raises(_Parsed) as parsed:
        module.main()
    return parsed.value.namespace


def _docs_digest() -> str:
    digest = hashlib.sha256()
    for path in sorted((ROOT / "docs").rglob("*")):
        if path.is_file():
            digest.update(str(path.relative_to(ROOT)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


@pytest.mark.parametrize("name", SCRIPTS)
def test_by_default_a_script_writes_a_new_run_directory_and_the_docs_only_when_asked(
    name, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    module = benchmark_script(name)
    default = module.OUTPUT.path(_parsed_args(module, [], monkeypatch))
    assert default.parent.parent == Path("runs"), default
    assert default.parent.name.startswith(f"{name}-") and default.name == f"{name}.json"
    given = tmp_path / "elsewhere.json"
    assert module.OUTPUT.path(_parsed_args(module, ["--out", str(given)], monkeypatch)) == given
    docs = module.OUTPUT.path(_parsed_args(module, ["--update-docs"], monkeypatch))
    assert docs == ROOT / "docs" / "results" / f"{name}.json"
    assert docs.is_file()  # the tracked file the docs quote


@pytest.mark.slow  # ~1.5-2.5 s: with the slow tests CI runs
def test_a_run_without_update_docs_leaves_the_docs_untouched(tmp_path):
    before = _docs_digest()
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "ik_kinematic.py"), "--poses", "3"]
        + ["--lengths", "0.125"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert done.returncode == 0, done.stderr
    assert _docs_digest() == before
    (written,) = (tmp_path / "runs").glob("ik_kinematic-*/ik_kinematic.json")
    assert json.loads(written.read_text())["results"]


@pytest.mark.parametrize("name", SCRIPTS)
def test_the_stored_results_hold_no_absolute_paths(name):
    stored = json.loads((ROOT / "docs" / "results" / f"{name}.json").read_text())
    absolute = [s for s in strings(stored) if os.path.isabs(s)]
    assert not absolute, absolute[:3]
