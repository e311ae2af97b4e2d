"""The README stays short and points into the docs site; every page of the site is in its
table of contents. In the default suite, in a second (the site's build is
tests/docs/test_docs_site.py, slow)."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()
GUIDE = sorted((ROOT / "docs" / "guide").glob("*.md"))


def test_the_readme_is_short():
    assert len(README.splitlines()) <= 150


def test_the_readme_names_more_than_the_straight_tool():
    first = README.split("\n\n")[1]  # the paragraph under the title
    assert "hook" in first and "chooses the tool" in first


def test_the_cpu_torch_line_comes_before_the_two_commands():
    blocks = re.findall(r"```bash\n(.*?)```", README, flags=re.S)
    assert "--index-url https://download.pytorch.org/whl/cpu" in blocks[0]
    assert "drake-tooluse demo" in blocks[1] and "python -m pytest" in blocks[2]


def test_the_readme_links_exist_and_reach_every_guide_page():
    links = re.findall(r"\]\(((?!https?:)[^)#]+)(?:#[^)]*)?\)", README)
    missing = [link for link in links if not (ROOT / link).exists()]
    assert not missing, f"the README links to what is not there: {missing}"
    assert {f"docs/guide/{p.name}" for p in GUIDE} <= set(links)


def test_every_page_is_in_the_sites_table_of_contents():
    index = (ROOT / "docs" / "index.md").read_text()
    entries = set()
    for body in re.findall(r"```\{toctree\}\n(.*?)```", index, flags=re.S):
        entries |= {line for line in body.splitlines() if line and not line.startswith(":")}
    pages = {f"guide/{p.stem}" for p in GUIDE} | {p.stem for p in (ROOT / "docs").glob("*.md")}
    assert pages - {"index"} <= entries
