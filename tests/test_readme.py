"""Every Python example in the README runs."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parent.parent / "README.md"
EXAMPLES = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_has_examples():
    assert len(EXAMPLES) >= 3


@pytest.mark.parametrize("index", range(len(EXAMPLES)))
def test_readme_example_runs(index, tmp_path, monkeypatch):
    # Run from the repo root (examples name diagrams/...), writing into a temporary runs/.
    monkeypatch.chdir(README.parent)
    code = EXAMPLES[index].replace('"runs/', f'"{tmp_path}/')
    exec(compile(code, f"README example {index}", "exec"), {})
