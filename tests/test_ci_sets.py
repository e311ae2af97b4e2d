"""Every slow test runs in CI: `.ci/run` selects them by marker, not by a list of files."""

import re
import shlex
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _slow_runs() -> list[list[str]]:
    """The arguments of each `python -m pytest -m slow …` line of .ci/run."""
    runs = []
    for line in (ROOT / ".ci" / "run").read_text().splitlines():
        for command in line.split("&&"):
            words = shlex.split(command.strip(), comments=True)
            if words[:5] == ["python", "-m", "pytest", "-m", "slow"]:
                runs.append(words[5:])
    return runs


def _selected(path: str, args: list[str]) -> bool:
    """Whether `pytest -m slow ARGS` from the root collects the file `path`."""
    ignored = [a.split("=", 1)[1] for a in args if a.startswith("--ignore=")]
    if any("-k" == a for a in args):
        return False  # a -k selection is not the whole file
    paths = [a for a in args if not a.startswith("-")]
    if any(path == p or path.startswith(p.rstrip("/") + "/") for p in ignored):
        return False
    return not paths or any(path == p or path.startswith(p.rstrip("/") + "/") for p in paths)


def test_every_file_with_a_slow_test_is_in_a_ci_run():
    slow = sorted(
        str(p.relative_to(ROOT))
        for p in (ROOT / "tests").rglob("test_*.py")
        if re.search(r"pytest\.mark\.slow", p.read_text())
    )
    runs = _slow_runs()
    assert len(slow) >= 10 and runs
    missing = [f for f in slow if not any(_selected(f, args) for args in runs)]
    assert not missing, f"slow tests no CI run selects: {missing}"


def test_the_check_sees_a_file_left_out():
    assert not _selected("tests/x/test_a.py", ["tests/y"])
    assert not _selected("tests/docs/test_a.py", ["--ignore=tests/docs"])
    assert _selected("tests/x/test_a.py", ["--ignore=tests/docs", "-rs"])
