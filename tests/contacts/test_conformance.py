"""Contact-law conformance suite over every registered contact law (PHYSICS.md §4.3).

The checks live in :mod:`siku_core.testing.contact_conformance` so that plugin authors can run
them on their own law class (``check_contact_law(MyLaw)``). Built-in laws are also checked with
every option switched on (sqrt-area elasticity, eq. 11 viscosity, friction, softening, partial
breaking), so that every branch of the evaluators is compared with its pure-Python form.
"""
from __future__ import annotations

import subprocess
import sys

import pytest

from siku_core.plugins import get_registry
from siku_core.testing import contact_conformance as cc

LAWS = get_registry().names("contact_law")

#: non-default parameters exercising the optional branches of the built-in laws
OPTIONS = {
    "collision": {"sqrt_area": True, "viscosity": 2.0, "friction": 0.3, "damping_ratio": 0.2},
    "distributed_spring": {"sqrt_area": True, "friction": 0.3, "damage_onset": 0.5,
                           "joint_damping_ratio": 0.3},
    "mohr_coulomb": {"friction": 0.3, "viscosity": 1.0, "break_share": 0.6, "n_segments": 7,
                     "sigma_c": 2e6, "friction_angle": 30.0},
    "bonded_particle": {"sqrt_area": True, "friction": 0.3, "sigma_crit": 1e5,
                        "tau_crit": 3e4, "joint_damping_ratio": 0.3},
}


def law(name):
    return get_registry().get("contact_law", name)


def param_sets(name):
    return [None, OPTIONS.get(name)] if name in OPTIONS else [None]


@pytest.mark.parametrize("name", LAWS)
def test_newton_third_law_both_evaluators(name):
    for params in param_sets(name):
        cc.check_newton_third_law(law(name), params)


@pytest.mark.parametrize("name", LAWS)
def test_zero_force_for_separated_pair(name):
    cc.check_zero_force_when_apart(law(name))


@pytest.mark.parametrize("name", LAWS)
def test_compiled_evaluator_equals_python(name):
    for params in param_sets(name):
        cc.check_compiled_matches_python(law(name), params)


@pytest.mark.parametrize("name", LAWS)
def test_degenerate_geometry_gives_finite_output(name):
    for params in param_sets(name):
        cc.check_degenerate_finite(law(name), params)


def test_third_party_law_class_runs_unregistered():
    """An unregistered law (a subclass with its own name and evaluators) runs through the same
    entry point a plugin author uses."""
    from siku_plugins.contact_laws import DistributedSpring

    class StiffSpring(DistributedSpring):
        """Test law: the distributed spring under another name."""

        name = "stiff_spring_conformance_test"

    assert StiffSpring.name not in get_registry().names("contact_law")
    cc.check_contact_law(StiffSpring, {"tensile_strain": 1e-3})


def test_conformance_module_is_import_light():
    code = ("import sys, siku_core.testing.contact_conformance; "
            "heavy = [m for m in ('h5py', 'netCDF4', 'xarray', 'siku_plugins', 'siku_io', "
            "'siku_forcing') if m in sys.modules]; print(heavy); assert not heavy")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
