"""What differs between the Drake releases the project supports: 1.51.1 (the last one for
Python 3.11) up to the newest (Python 3.12+). Everything that depends on the Drake release goes
through this module.

Checked on Drake 1.58.0 (Python 3.13, `.ci/py313_check.sh`): the Drake names the project calls
are all still there (it already uses the 1.54 names `SetDefaultFloatingBaseBodyPose` and
`is_floating_base_body`; `SetFreeBodyPose` stayed). What differs:

- the bindings: pybind11 up to 1.57, nanobind from 1.58 (`BINDINGS`). A Python system's
  overrides are looked up differently (`NO_WITNESS_FUNCTIONS`);
- block diagrams: 1.56 added the plant ports `surface_speeds` (input) and
  `surface_displacements` (output), so a diagram's Graphviz text changes with the release;
- simulated episodes: on 1.58 the shipped policies' evaluations differ slightly (7–23 of 100
  episodes, by up to 1 cm at the end; the means by at most 0.22 mm).

So files that record what Drake computed (the committed block diagrams, the shipped policies'
metrics) record the release that made them, and are reproduced exactly only on that release
(`reproduces_exactly`); elsewhere their checks compare what the project owns within stated
tolerances. A rollout's floats also move with the builds of numpy, torch and OpenCV, so the
shipped policies' first episodes are compared bit for bit only where the builds that made them are
all installed (`exact_versions_installed`, with the pins of `.ci/exact-versions.txt`), and
only on the kind of CPU that made them (`cpu_kernels`, `.ci/exact-cpu.txt`): torch's and
numpy's kernels are chosen at run time by the CPU's vector instructions and maker.
"""

from __future__ import annotations

import platform
import re
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from pydrake.systems.framework import LeafSystem

__all__ = [
    "BINDINGS",
    "DRAKE_VERSION",
    "NO_WITNESS_FUNCTIONS",
    "cpu_kernels",
    "drake_version",
    "exact_versions_installed",
    "read_pins",
    "reproduces_exactly",
]


def _installed_drake() -> str:
    try:
        return version("drake")
    except PackageNotFoundError:  # a Drake built from source or unpacked from a tarball
        return "unknown"


# The installed Drake release, as pip names it ("1.51.1"), or "unknown".
DRAKE_VERSION: str = _installed_drake()


def drake_version(text: str = DRAKE_VERSION) -> tuple[int, ...]:
    """A release as numbers, for ordering: "1.58.0" -> (1, 58, 0); () for an unknown one."""
    match = re.match(r"\d+(?:\.\d+)*", text)
    return tuple(int(p) for p in match.group(0).split(".")) if match else ()


def reproduces_exactly(recorded: str | None) -> bool:
    """Whether a result recorded with Drake `recorded` must come out bit for bit (to rounding)
    on the installed Drake: only on that same release. Another release may move simulated
    episodes by millimetres and draws other plant ports."""
    return recorded is not None and recorded != "unknown" and recorded == DRAKE_VERSION


def exact_versions_installed(pins: dict[str, str]) -> tuple[bool, str]:
    """Whether every package of `pins` ({pip name: version}, e.g. {"numpy": "2.4.6"}) is
    installed at exactly that version: float results of a policy rollout move with the builds
    of Drake, numpy, torch and OpenCV, so a figure is reproduced bit for bit only under the
    builds that made it. Returns (the answer, the first difference in words or "")."""
    for name, wanted in pins.items():
        try:
            installed = version(name)
        except PackageNotFoundError:
            installed = "not installed"
        if installed != wanted:
            return False, f"{name} {installed} is installed, the exact figures need {wanted}"
    return True, ""


def cpu_kernels() -> str:
    """The CPU as the float kernels see it, e.g. "x86_64 AuthenticAMD-25-17 AVX512": the
    machine, the CPU's maker, family and model (MKL and OpenBLAS pick their code paths by
    them) and the vector instruction set torch dispatches to (numpy's dispatch follows the
    same instructions)."""
    import torch  # only where a rollout's floats are compared: torch is slow to import

    fields = {}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            name, _, value = line.partition(":")
            fields.setdefault(name.strip(), value.strip())
    except OSError:  # not Linux: the CPU stays unknown, and so no exact comparison
        pass
    cpu = "-".join(fields.get(k, "unknown") for k in ("vendor_id", "cpu family", "model"))
    return f"{platform.machine()} {cpu} {torch.backends.cpu.get_cpu_capability()}"


def read_pins(text: str) -> dict[str, str]:
    """The `name==version` lines of a pip constraints file's `text` ({name: version});
    comments and blank lines skipped. A line of another form is a ValueError naming it."""
    pins = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        name, sep, pinned = line.partition("==")
        if not sep or not name.strip() or not pinned.strip():
            raise ValueError(f"constraint {line!r} must be of the form name==version")
        pins[name.strip()] = pinned.strip()
    return pins


# How pydrake is bound to C++: "pybind11" (up to Drake 1.57) or "nanobind" (from 1.58).
BINDINGS: str = "nanobind" if type(LeafSystem).__module__ == "nanobind" else "pybind11"


def _no_witness_functions(self, context) -> list:
    """Drake's default for a system: no witness functions."""
    return []


# For a Python LeafSystem's class body, `DoGetWitnessFunctions = NO_WITNESS_FUNCTIONS`: the
# simulator asks every system for its witness functions whenever the state changes, and this
# makes the answer "none" cheap (systems/tool_tip_ik.py says why). pybind11 takes a C++ function
# under the name for "not overridden" (it remembers that per class) and runs Drake's default;
# nanobind calls whatever is there with the context (a C++ function fails), so there it is a
# Python function giving no witness functions (on 1.58 as fast as having none: ~1 µs a step).
NO_WITNESS_FUNCTIONS = (
    LeafSystem.MakeWitnessFunction if BINDINGS == "pybind11" else _no_witness_functions
)
