"""Every Python example in the README and the user guide (docs/guide/*.md) runs; the other
pages' Python blocks are reproductions their own tests run."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]
# docs/*.md pages with a Python block -> the test that runs it.
REPRODUCTIONS = {
    "CLOCK.md": "tests/test_clock_drift.py",
    "UPSTREAM.md": "tests/tasks/test_add_a_task.py",
}


def _examples(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)


EXAMPLES = [(page, k) for page in PAGES for k in range(len(_examples(page)))]
# Examples that start a Ray cluster (~10 s here): they run with the slow tests (CI runs both).
# Each over 1.5 s (a Ray cluster, a rack's shapes measured, a choice, a transfer): with the slow
# tests CI runs.
SLOW = {
    "docs/guide/sweeps.md:0",
    "docs/guide/tool-choice.md:0",
    "docs/guide/tool-choice.md:1",
    "docs/guide/transfer.md:0",
}


def _id(page: Path, index: int) -> str:
    return f"{page.relative_to(ROOT)}:{index}"


def test_the_readme_and_the_guide_have_examples():
    assert len(_examples(ROOT / "README.md")) >= 3
    assert len(EXAMPLES) >= 15
    assert SLOW <= {_id(p, k) for p, k in EXAMPLES}  # each slow one is still an example


def test_every_other_pages_python_block_has_its_test():
    pages = {p.name for p in (ROOT / "docs").glob("*.md") if _examples(p)}
    assert pages == set(REPRODUCTIONS)
    for page, test in REPRODUCTIONS.items():
        assert page in (ROOT / test).read_text(), (page, test)


@pytest.mark.parametrize(
    "page, index",
    [
        pytest.param(p, k, id=_id(p, k), marks=[pytest.mark.slow] if _id(p, k) in SLOW else [])
        for p, k in EXAMPLES
    ],
)
def test_the_example_runs(page, index, tmp_path, monkeypatch):
    # Run from the repo root (examples name diagrams/...), writing into a temporary runs/.
    monkeypatch.chdir(ROOT)
    code = _examples(page)[index].replace('"runs/', f'"{tmp_path}/')
    exec(compile(code, f"{page.relative_to(ROOT)} example {index}", "exec"), {})
