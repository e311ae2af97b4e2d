"""Sphinx's napoleon reads a property docstring whose first line holds ": " as "type:
description", and the API reference (built with warnings as errors) then fails on a type it
cannot find. Checked here in the default suite, in seconds, not only when the slow docs build
runs."""

import importlib
import inspect
import pkgutil

import drake_tooluse


def _properties():
    for info in pkgutil.walk_packages(drake_tooluse.__path__, "drake_tooluse."):
        if info.name.endswith("__main__"):  # runs the command line
            continue
        try:
            module = importlib.import_module(info.name)
        except ImportError:  # an optional dependency (the docs build skips it too)
            continue
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ != module.__name__:
                continue
            for name, value in vars(cls).items():
                if isinstance(value, property) and value.__doc__:
                    yield f"{cls.__module__}.{cls.__qualname__}.{name}", value.__doc__


def test_no_property_docstring_reads_as_a_type():
    found = list(_properties())
    assert len(found) >= 3  # (the walk found the package)
    bad = [name for name, doc in found if ": " in doc.strip().splitlines()[0]]
    assert not bad, f"first lines with ': ' (napoleon reads a type): {bad}"
