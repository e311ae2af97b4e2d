"""The `.. pydrake_system::` directive: a LeafSystem's port block, drawn as Drake's docs draw it.

Drake's own Sphinx extension (doc/pydrake/pydrake_sphinx_extension.py with
doc/doxygen_cxx/system_doxygen.py) reads the block's YAML and emits an HTML table: the input
ports on the left, each followed by an arrow, the system's name in a grey box, the output ports
on the right. This draws the same figure from docutils table nodes instead of raw HTML, so port
names are escaped and every builder (html, text, latex) gets it. A block that is not the YAML
Drake accepts (a mapping with `name`, and `input_ports`/`output_ports` lists of names) is an
error that names what is wrong, so `sphinx -W` fails on it.
"""

from __future__ import annotations

from pathlib import Path

import yaml
from docutils import nodes
from docutils.parsers.rst import Directive

KEYS = ("name", "input_ports", "output_ports")
STATIC_DIR = Path(__file__).resolve().parent.parent / "_static"


def parse_system_yaml(text: str) -> tuple[str, list[str], list[str]]:
    """(name, input ports, output ports) from a block's YAML; ValueError naming what is wrong."""
    try:
        block = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ValueError(f"the block is not YAML ({error})") from None
    if not isinstance(block, dict):
        raise ValueError(f"the block must be a mapping with keys {KEYS}, got {block!r}")
    unknown = sorted(set(block) - set(KEYS))
    if unknown:
        raise ValueError(f"unknown keys {unknown}; allowed: {KEYS}")
    name = block.get("name")
    if not isinstance(name, str) or not name:
        raise ValueError(f"`name` must be the system's name, got {name!r}")
    ports = []
    for key in ("input_ports", "output_ports"):
        names = block.get(key) or []
        if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
            raise ValueError(f"`{key}` must be a list of port names, got {names!r}")
        ports.append(names)
    return name, ports[0], ports[1]


def _cell(classes: list[str], lines: list[str]) -> nodes.entry:
    entry = nodes.entry(classes=classes)
    for line in lines:
        entry += nodes.paragraph(text=line)
    return entry


def system_table(name: str, inputs: list[str], outputs: list[str]) -> nodes.table:
    """The port block: inputs with arrows into the named box, arrows out to the outputs."""
    table = nodes.table(classes=["pydrake-system"])
    group = nodes.tgroup(cols=3)
    table += group
    for width in (1, 1, 1):
        group += nodes.colspec(colwidth=width)
    row = nodes.row()
    row += _cell(["pydrake-system-inputs"], [f"{port} \N{RIGHTWARDS ARROW}" for port in inputs])
    row += _cell(["pydrake-system-name"], [name])
    row += _cell(["pydrake-system-outputs"], [f"\N{RIGHTWARDS ARROW} {port}" for port in outputs])
    body = nodes.tbody()
    body += row
    group += body
    return table


class PydrakeSystemDirective(Directive):
    """`.. pydrake_system::` followed by the indented YAML of the system's name and ports."""

    has_content = True

    def run(self):
        try:
            name, inputs, outputs = parse_system_yaml("\n".join(self.content))
        except ValueError as error:
            raise self.error(f"pydrake_system: {error}") from None
        return [system_table(name, inputs, outputs)]


def _add_static_dir(app, config) -> None:
    config.html_static_path.append(str(STATIC_DIR))


def setup(app):
    app.add_directive("pydrake_system", PydrakeSystemDirective)
    app.connect("config-inited", _add_static_dir)
    app.add_css_file("pydrake_system.css")
    return {"parallel_read_safe": True, "parallel_write_safe": True}
