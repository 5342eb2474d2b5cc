"""Contact-law conformance suite over every registered contact law.

docs/explanation/physics.md §4.3.

The checks live in :mod:`siku_core.testing.contact_conformance` so that plugin authors can run
them on their own law class (``check_contact_law(MyLaw)``). Built-in laws are also checked with
every option switched on (sqrt-area elasticity, eq. 11 viscosity, friction, softening, partial
breaking), so that every branch of the evaluators is compared with its pure-Python form.
"""
from __future__ import annotations

import subprocess
import sys

import pytest

import conformance_faulty_laws as faulty
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


@pytest.mark.parametrize("name", LAWS)
def test_passive_over_push_release_cycles(name):
    for params in param_sets(name):
        cc.check_passivity(law(name), params)


@pytest.mark.parametrize("name", LAWS)
def test_joint_force_is_the_gradient_of_the_declared_energy(name):
    for params in param_sets(name):
        cc.check_energy(law(name), params)


@pytest.mark.parametrize("name", LAWS)
def test_history_changes_only_as_declared(name):
    for params in param_sets(name):
        cc.check_history(law(name), params)


def test_laws_that_store_energy_declare_it():
    """The check is not vacuous for the built-ins that have an energy."""
    for name in ("distributed_spring", "bonded_particle"):
        assert callable(getattr(law(name), "joint_energy", None)), name


# anti_spring compiles the collision loop for its own evaluator (a minute or two of a core):
# slow; anti_joint, caught by the same passivity check, is its fast check
@pytest.mark.parametrize("fault", [pytest.param(f, marks=pytest.mark.slow)
                                   if f == "anti_spring" else f for f in sorted(faulty.FAULTY)])
def test_the_suite_fails_a_law_with_a_planted_fault_naming_the_check(fault):
    """An anti-spring (collision and joint), a call-counting history, a 0/0 evaluator, an
    energy that is not the force's, and a history write past the declared columns: each fails
    ``check_contact_law`` with a one-check message, not a raw exception."""
    law_cls, expected = faulty.FAULTY[fault]
    with pytest.raises(AssertionError) as ei:
        cc.check_contact_law(law_cls)
    assert str(ei.value).startswith(expected), str(ei.value)


def test_a_zero_over_zero_in_degenerate_geometry_is_a_finding():
    with pytest.raises(AssertionError, match="zero_over_zero_test: degenerate geometry: "
                                             "collision evaluator raised ZeroDivisionError: "
                                             "division by zero on zero area"):
        cc.check_degenerate_finite(faulty.ZeroOverZero)


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
