"""`.. package-modules:: drake_tooluse.robot`: a section and an `automodule` for each module of
a package, found by walking the package, so a new module appears without editing a page.
With `:top-level:`, only the package's own plain modules (not its subpackages)."""

from __future__ import annotations

import importlib
import pkgutil

from docutils import nodes
from docutils.parsers.rst import Directive, directives
from docutils.statemachine import StringList
from sphinx.util.nodes import nested_parse_with_titles


def package_modules(package: str, top_level: bool = False) -> list[str]:
    """Every module below `package` (subpackages included, `__main__` left out), sorted; with
    `top_level`, only its plain modules."""
    path = importlib.import_module(package).__path__
    if top_level:
        found = [m for m in pkgutil.iter_modules(path, prefix=f"{package}.") if not m.ispkg]
    else:
        found = pkgutil.walk_packages(path, prefix=f"{package}.")
    return sorted(m.name for m in found if not m.name.endswith(".__main__"))


class PackageModulesDirective(Directive):
    required_arguments = 1
    option_spec = {"top-level": directives.flag}

    def run(self):
        package = self.arguments[0]
        try:
            names = package_modules(package, top_level="top-level" in self.options)
        except ImportError as error:
            raise self.error(f"package-modules: cannot import {package!r} ({error})") from None
        text = StringList()
        for name in names:
            title = f"``{name}``"
            for line in (title, "-" * len(title), "", f".. automodule:: {name}", ""):
                text.append(line, f"<package-modules {package}>")
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, text, node)
        return node.children


def setup(app):
    app.add_directive("package-modules", PackageModulesDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
