"""Letting go of a diagram's Python systems, which pydrake 1.51 would otherwise keep forever.

A LeafSystem written in Python, once added to a DiagramBuilder, is kept alive by its C++ half,
and through pydrake's reference bookkeeping (the `ref_cycle` peers it holds) it keeps its
builder and the whole Diagram alive with it: plant, scene graph, contexts, caches. Python's
garbage collector cannot see the C++ edge, so every built-and-dropped diagram with a Python
system stays in memory (upstream: RobotLocomotion/drake/issues/22515 and /23161; measured
here ≈ 2–3 MB per push env).
`release_diagram` clears the Python systems' attributes (their ports, models and that
bookkeeping): the Diagram is then freed with its last reference. A system whose calc
callbacks are its own bound methods stays behind as an empty shell (≈ 70 kB with its C++
half: the callbacks, held in C++, keep it); one that declares them through `weak_method`
is freed entirely.
"""

from __future__ import annotations

import weakref

from pydrake.systems.framework import Diagram


def weak_method(method):
    """A callback for a port or event of a Python system that calls `method` (a bound method
    of the system) without keeping the system alive: with its C++ half holding the callback,
    a bound method would make the system immortal (see the module docstring)."""
    ref = weakref.WeakMethod(method)

    def call(*args):
        return ref()(*args)

    call.__name__ = getattr(method, "__name__", "call")
    return call


def release_diagram(diagram) -> None:
    """Clears the instance attributes of every Python-defined system in `diagram` (and in the
    diagrams inside it). Call it when the diagram, its simulator and its contexts will not be
    used again (an env's `close()`, the end of a run): those systems cannot be used after."""
    for system in diagram.GetSystems():
        if isinstance(system, Diagram):
            release_diagram(system)
        if type(system).__module__.split(".")[0] == "pydrake":
            continue
        attributes = getattr(system, "__dict__", None)
        if attributes is not None:
            attributes.clear()
