"""Sphinx configuration of drake-tooluse's documentation site: the user guide (docs/guide/),
the pages docs/*.md and the API reference (docs/api/). Built from the repo's root with

    python -m sphinx -W --keep-going -b html docs build/docs-html

(warnings are errors; tests/docs/test_docs_site.py runs the same build)."""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# The checkout's package first (as the tests run it), then the local extension.
sys.path[:0] = [str(HERE.parent), str(HERE / "api" / "_ext")]

project = "drake-tooluse"
author = "drake-tooluse authors"
copyright = "2026, drake-tooluse authors"

extensions = [
    # The guide and the docs/*.md pages are Markdown (GitHub renders them too).
    "myst_parser",
    "sphinx.ext.autodoc",
    # The docstrings' `Args:` / `Attributes:` sections are Google style.
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    # `.. pydrake_system::` port blocks, drawn as Drake's docs draw them.
    "pydrake_system",
    # `.. package-modules::`: every module of a package, found by walking it.
    "package_modules",
    # The docstrings' Markdown code fences and pipe tables, as reST.
    "markdown_docstrings",
]

root_doc = "index"
# results/ holds the experiments' JSON and figures, read by the pages, not pages themselves.
exclude_patterns = ["_build", "api/_ext", "api/_static", "results", "figures"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
# GitHub's anchors (`BENCHMARKS.md#the-hook-policy`) for headings down to ###, so that the
# pages' links work on GitHub and on the site alike.
myst_heading_anchors = 3
# Docstrings write `name` (Markdown's code span) for code: render it as code, not as a citation.
default_role = "literal"

autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
# A method we override without a docstring is not ours to describe (argparse's, Drake's).
autodoc_inherit_docstrings = False
autodoc_typehints = "description"
# `RigidTransform`, not `pydrake.math.RigidTransform`, in signatures.
autodoc_typehints_format = "short"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# A LeafSystem's docstring lists its ports under these, one `name: description` each.
napoleon_custom_sections = [("Input ports", "params_style"), ("Output ports", "params_style")]

# Every cross-reference must resolve, except to third-party libraries: their inventories are
# not downloaded (the build runs offline), so their names stay plain text.
nitpicky = True
THIRD_PARTY = (
    "numpy|np|pydrake|torch|gymnasium|gym|stable_baselines3|sb3_contrib|ray|cv2|yaml|matplotlib"
    "|safetensors|tqdm|rich|numba"
)
STANDARD_LIBRARY = (
    "abc|argparse|collections|concurrent|dataclasses|enum|io|os|pathlib|subprocess|typing"
)
nitpick_ignore_regex = [(r"py:.*", rf"({THIRD_PARTY}|{STANDARD_LIBRARY})(\..*)?")]
# Two third-party names autodoc leaves bare (no module path) in a few signatures, which the
# pattern above cannot match: pathlib's Path and pydrake's CameraInfo.
nitpick_ignore = [("py:class", "Path"), ("py:class", "CameraInfo")]


def _skip_drake_functions(app, what, name, obj, skip, options):
    """Skips pydrake's own functions held under our names, and the no-witness-functions marker
    a LeafSystem's class body assigns (compat.NO_WITNESS_FUNCTIONS: Drake's function up to
    1.57, a one-line one after): Drake documents them, and they are no part of a system's API."""
    from drake_tooluse.compat import NO_WITNESS_FUNCTIONS

    if what == "class" and obj is NO_WITNESS_FUNCTIONS:
        return True
    if (getattr(obj, "__module__", None) or "").startswith("pydrake."):
        return True
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_drake_functions)


html_theme = "alabaster"
html_title = "drake-tooluse"
