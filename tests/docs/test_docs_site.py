"""The docs site (docs/conf.py: the user guide, the pages docs/*.md and the API reference)
builds with warnings as errors, a broken link between its pages among them; every page is on
it; every LeafSystem's `.. pydrake_system::` block renders as its port figure, and each block
names the ports its system declares.

Needs the `docs` extra (Sphinx, myst-parser). Slow: the build imports every module (25–55 s
here, by the load on the machine).
"""

import html
import importlib
import inspect
import pkgutil
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import drake_tooluse

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
EXT = DOCS / "api" / "_ext"  # the site's own Sphinx extensions
sys.path.insert(0, str(EXT))

# A port figure in the built HTML: (inputs cell, name cell, outputs cell).
FIGURE = re.compile(
    r'<table class="pydrake-system[^"]*">.*?'
    r'<td class="pydrake-system-inputs">(.*?)</td>\s*'
    r'<td class="pydrake-system-name"><p>(.*?)</p></td>\s*'
    r'<td class="pydrake-system-outputs">(.*?)</td>',
    flags=re.S,
)


def _sphinx(source: Path, out: Path) -> subprocess.CompletedProcess:
    """The documented build command: html, warnings as errors."""
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    return subprocess.run(
        [*command, str(source), str(out)], cwd=ROOT, capture_output=True, text=True, timeout=600
    )


def _paragraphs(cell: str) -> list[str]:
    return [html.unescape(p) for p in re.findall(r"<p>(.*?)</p>", cell)]


def _figures(folder: Path) -> dict:
    """{system name: (input lines, output lines)} of every port figure in the built pages."""
    figures = {}
    for page in folder.rglob("*.html"):
        for inputs, name, outputs in FIGURE.findall(page.read_text()):
            figures[html.unescape(name)] = (_paragraphs(inputs), _paragraphs(outputs))
    return figures


def _leaf_systems() -> dict:
    """{name: class} of every LeafSystem the package defines."""
    from pydrake.systems.framework import LeafSystem

    found = {}
    for module in pkgutil.walk_packages(drake_tooluse.__path__, prefix="drake_tooluse."):
        if module.name.startswith(("drake_tooluse.cli", "drake_tooluse.models")):
            continue
        for name, value in vars(importlib.import_module(module.name)).items():
            if (
                inspect.isclass(value)
                and issubclass(value, LeafSystem)
                and value.__module__ == module.name
            ):
                found[name] = value
    return found


def _block(docstring: str) -> str | None:
    """The YAML of a docstring's `.. pydrake_system::` block: the lines indented below it."""
    lines = docstring.splitlines()
    for i, line in enumerate(lines):
        if line.strip() == ".. pydrake_system::":
            indent = len(line) - len(line.lstrip())
            content = []
            for below in lines[i + 1 :]:
                if below.strip() and len(below) - len(below.lstrip()) <= indent:
                    break
                content.append(below)
            return textwrap.dedent("\n".join(content))
    return None


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("docs-html")
    result = _sphinx(DOCS, out)
    assert result.returncode == 0, f"the docs site has warnings:\n{result.stderr}"
    return out


def test_every_page_is_on_the_site(built):
    pages = [*DOCS.glob("*.md"), *(DOCS / "guide").glob("*.md")]
    assert len(pages) >= 15
    for page in pages:
        html_page = built / page.relative_to(DOCS).with_suffix(".html")
        assert html_page.is_file(), page
    assert (built / "api" / "index.html").is_file()


def test_a_broken_link_between_pages_fails_the_build(tmp_path):
    """The build's `-W` is what holds the pages' links (as GitHub writes them: `page.md#anchor`)
    to pages and headings that exist."""
    conf = "extensions = ['myst_parser']\nmyst_heading_anchors = 3\n"
    for link, ok in [("b.md#a-heading", True), ("b.md#no-such-heading", False), ("c.md", False)]:
        source = tmp_path / link.replace("#", "_").replace(".", "_")
        source.mkdir()
        (source / "conf.py").write_text(conf)
        (source / "index.md").write_text(f"# A\n\n[b]({link})\n\n```{{toctree}}\nb\n```\n")
        (source / "b.md").write_text("# B\n\n## A heading\n")
        result = _sphinx(source, source / "html")
        assert (result.returncode == 0) == ok, (link, result.stderr)


def test_push_outcome_ports_render(built):
    inputs, outputs = _figures(built)["PushOutcome"]
    assert inputs == ["body_poses →", "contact_results →"]
    assert outputs == ["→ metrics", "→ reward", "→ success"]


def test_every_leaf_system_has_its_port_figure(built):
    from pydrake_system import parse_system_yaml

    figures = _figures(built)
    systems = _leaf_systems()
    assert {"PushOutcome", "ToolTipIKSystem", "ToolLengthEstimator"} <= set(systems)
    for name, cls in systems.items():
        block = _block(cls.__doc__ or "")
        assert block, f"{name}'s docstring has no `.. pydrake_system::` block"
        _, block_inputs, block_outputs = parse_system_yaml(block)
        assert figures.get(name) == (
            [f"{port} →" for port in block_inputs],
            [f"→ {port}" for port in block_outputs],
        ), f"{name}'s port figure is missing or differs from its block"


def _leaves(diagram):
    for system in diagram.GetSystems():
        if hasattr(system, "GetSystems"):
            yield from _leaves(system)
        else:
            yield system


def test_every_port_block_names_the_systems_ports():
    """The figures tell the truth: each block lists the ports the built system declares, in
    order (the systems as the policy, pull, and tool, hook and shape measurement diagrams build
    them)."""
    import gymnasium as gym
    from pydrake_system import parse_system_yaml

    import drake_tooluse  # noqa: F401  (registers the envs)
    from drake_tooluse.builders.hook_measurement import build_hook_measurement_diagram
    from drake_tooluse.builders.measurement import build_measurement_diagram
    from drake_tooluse.builders.shape_measurement import build_shape_measurement_diagram
    from drake_tooluse.learning.policy_dir import load_policy
    from drake_tooluse.paths import TRANSFER_POLICY
    from drake_tooluse.tasks.deploy import build_policy_diagram
    from drake_tooluse.world.scenario import Scenario, ToolConfig, validate_scenario

    scenario = Scenario()
    hooked = validate_scenario(Scenario(tool=ToolConfig(kind="hook", length=0.25)))
    pull = gym.make("drake_tooluse/ToolPull-v1")
    pull.reset(seed=0)
    diagrams = [
        build_policy_diagram(scenario, load_policy(TRANSFER_POLICY)).diagram,
        build_measurement_diagram(scenario, noise_sigma=2.0).diagram,
        build_hook_measurement_diagram(hooked, noise_sigma=2.0).diagram,
        build_shape_measurement_diagram(hooked, noise_sigma=2.0, depth_noise_sigma=0.001).diagram,
        pull.unwrapped.diagram,
    ]
    checked = set()
    for diagram in diagrams:
        for system in _leaves(diagram):
            cls = type(system)
            if not cls.__module__.startswith("drake_tooluse."):
                continue
            name, inputs, outputs = parse_system_yaml(_block(cls.__doc__ or ""))
            assert name == cls.__name__
            ports_in = [
                system.get_input_port(i).get_name() for i in range(system.num_input_ports())
            ]
            ports_out = [
                system.get_output_port(i).get_name() for i in range(system.num_output_ports())
            ]
            assert (inputs, outputs) == (ports_in, ports_out), f"{name}'s block differs"
            checked.add(name)
    missing = set(_leaf_systems()) - checked
    assert not missing, f"no diagram here builds {sorted(missing)}: add one that does"


def test_a_markdown_table_becomes_a_list_table():
    from markdown_docstrings import markdown_to_rest

    lines = ["| mode | size |", "| --- | --- |", "| `pose` | 6 |", "after"]
    assert markdown_to_rest(lines) == [
        ".. list-table::",
        "   :header-rows: 1",
        "",
        "   * - mode",
        "     - size",
        "   * - `pose`",
        "     - 6",
        "",
        "after",
    ]


@pytest.mark.parametrize(
    "block, message",
    [
        ("name: A\ninput_ports: u", "`input_ports` must be a list of port names"),
        ("input_ports:\n- u", "`name` must be the system's name"),
        ("name: A\ninputs:\n- u", "unknown keys ['inputs']"),
    ],
)
def test_a_bad_block_fails_the_build(tmp_path, block, message):
    source = tmp_path / "source"
    source.mkdir()
    (source / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(EXT)!r})\nextensions = ['pydrake_system']\n"
    )
    indented = "\n".join(f"   {line}" for line in block.splitlines())
    (source / "index.rst").write_text(f"Title\n=====\n\n.. pydrake_system::\n\n{indented}\n")
    result = _sphinx(source, tmp_path / "html")
    assert result.returncode != 0
    assert message in result.stderr
