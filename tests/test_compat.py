"""drake_tooluse.compat: the installed Drake release, what pyproject.toml asks for it, and the
Drake names the project calls whose neighbours were renamed or removed after 1.51."""

import platform
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RigidBody
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import LeafSystem

from drake_tooluse import compat

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def test_the_installed_drake_is_the_one_pyproject_asks_for_on_this_python():
    drake = [
        Requirement(d)
        for d in tomllib.loads(PYPROJECT.read_text())["project"]["dependencies"]
        if Requirement(d).name == "drake"
    ]
    assert len(drake) == 2  # one per Python range
    (here,) = [r for r in drake if r.marker is None or r.marker.evaluate()]
    assert here.specifier.contains(compat.DRAKE_VERSION), (here, compat.DRAKE_VERSION)
    if sys.version_info < (3, 12):
        assert compat.DRAKE_VERSION == "1.51.1"  # the last Drake with Python 3.11 wheels
    else:
        assert compat.drake_version() >= (1, 52)


def test_drake_version_orders_releases():
    assert compat.drake_version("1.51.1") == (1, 51, 1)
    assert compat.drake_version("1.58.0") > compat.drake_version("1.51.1")
    assert compat.drake_version("1.9.0") < compat.drake_version("1.51.1")
    assert compat.drake_version("unknown") == ()
    assert compat.drake_version() == compat.drake_version(compat.DRAKE_VERSION) >= (1, 51)


def test_only_the_same_release_reproduces_exactly():
    assert compat.reproduces_exactly(compat.DRAKE_VERSION)
    assert not compat.reproduces_exactly("1.0.0")
    assert not compat.reproduces_exactly(None)
    assert not compat.reproduces_exactly("unknown")


def test_bindings_are_named_for_the_release():
    # Drake 1.58 moved its Python bindings from pybind11 to nanobind.
    release = compat.drake_version()
    assert compat.BINDINGS == ("nanobind" if release >= (1, 58) else "pybind11") or not release


class _Counter(LeafSystem):
    DoGetWitnessFunctions = compat.NO_WITNESS_FUNCTIONS

    def __init__(self):
        super().__init__()
        self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(0.01, 0.0, self._count)

    def _count(self, context, state):
        state.get_mutable_vector().SetAtIndex(0, context.get_discrete_state_vector()[0] + 1)


def test_a_system_marked_with_no_witness_functions_simulates_with_none():
    """The marker runs on either binding (a C++ function in pybind11's, a Python one in
    nanobind's, where a C++ function under the name fails at the first step)."""
    system = _Counter()
    simulator = Simulator(system)
    simulator.AdvanceTo(0.1)
    assert simulator.get_context().get_discrete_state_vector()[0] == 10  # at 0, 0.01, …, 0.09
    assert system.GetWitnessFunctions(simulator.get_context()) == []


def test_the_drake_names_the_project_calls_are_there():
    """Drake 1.54 removed the "free body" names beside these (SetFreeBodyPoseInWorldFrame,
    Set/GetDefaultFreeBodyPose, RigidBody.is_floating, ...); the project calls only these,
    which 1.51.1 and 1.58.0 both have. A release that drops one fails here first: route it
    through compat."""
    for name in ("SetFreeBodyPose", "SetDefaultFloatingBaseBodyPose"):
        assert hasattr(MultibodyPlant, name), name
    assert hasattr(RigidBody, "is_floating_base_body")


def test_exact_versions_are_all_pins_installed():
    assert compat.exact_versions_installed({"drake": compat.DRAKE_VERSION}) == (True, "")
    exact, why = compat.exact_versions_installed({"drake": "0.0.1"})
    assert not exact and why == (
        f"drake {compat.DRAKE_VERSION} is installed, the exact figures need 0.0.1"
    )
    exact, why = compat.exact_versions_installed({"no-such-package-x": "1"})
    assert not exact and "no-such-package-x not installed" in why


def test_pins_are_read_from_a_constraints_file():
    text = "# made here\n\ndrake==1.51.1  # Drake\ntorch==2.13.0+cpu\n"
    assert compat.read_pins(text) == {"drake": "1.51.1", "torch": "2.13.0+cpu"}
    with pytest.raises(ValueError, match=r"constraint 'numpy>=2' must be of the form"):
        compat.read_pins("numpy>=2")
    shipped = Path(__file__).resolve().parents[1] / ".ci" / "exact-versions.txt"
    assert set(compat.read_pins(shipped.read_text())) == {
        "drake",
        "numpy",
        "torch",
        "opencv-python-headless",
    }


def test_the_cpu_is_named_as_its_float_kernels_see_it():
    import torch

    machine, cpu, capability = compat.cpu_kernels().split(" ")
    assert machine == platform.machine() and cpu.count("-") >= 2
    assert capability == torch.backends.cpu.get_cpu_capability()
