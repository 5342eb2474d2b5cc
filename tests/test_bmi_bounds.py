"""The BMI refuses values a model cannot mean with siku's own errors (also ``ValueError``s, as
BMI callers expect), and hands out outputs read-only."""
from __future__ import annotations

import numpy as np
import pytest
from test_bmi import bmi, wave_bmi  # noqa: F401  (fixtures)

from siku_core.errors import SikuError

ENERGY = "sea_surface_wave__incident_energy"


def refused(call, words):
    with pytest.raises(SikuError, match=words) as ei:
        call()
    assert isinstance(ei.value, ValueError)


def test_an_incident_energy_past_the_steepest_wave_is_refused(wave_bmi):  # noqa: F811
    """A component of frequency f holds at most (0.443 / k)² / 2, k = (2 pi f)² / g: the
    steepest Stokes wave. 1e300 m² is refused and nothing is written; the bound is taken."""
    b = wave_bmi
    f = b.get_value("sea_surface_wave__frequency", np.zeros(2))
    k = (2 * np.pi * f) ** 2 / 9.81
    top = 0.5 * (0.443 / k) ** 2
    before = b.get_value(ENERGY, np.zeros(2)).copy()
    refused(lambda: b.set_value(ENERGY, np.array([1e300, 0.0])),
            r"component 0 has 1e\+300 m2, above the .* m2 of the steepest wave")
    refused(lambda: b.set_value_at_indices(ENERGY, np.array([1]), np.array([top[1] * 1.01])),
            "component 1 has")
    assert np.array_equal(b.get_value(ENERGY, np.zeros(2)), before)
    b.set_value(ENERGY, top * 0.999)
    assert np.array_equal(b.get_value(ENERGY, np.zeros(2)), top * 0.999)


@pytest.mark.parametrize("name, value", [("sea_water_surface__elevation", 1e300),
                                         ("sea_water_surface__elevation", -101.0)])
def test_exchange_inputs_past_their_physical_range_are_refused(bmi, name, value):  # noqa: F811
    refused(lambda: bmi.set_value(name, np.full(36, value)), "beyond what the model can mean")
    assert not bmi.get_value(name, np.zeros(36)).any()


@pytest.mark.parametrize("inds", [np.array([2**62]), np.array([2**64 - 1], dtype=np.uint64),
                                  np.array([-1])])
def test_indices_off_the_grid_are_refused_uncast(bmi, inds):  # noqa: F811
    name = "sea_water_surface__elevation"
    refused(lambda: bmi.set_value_at_indices(name, inds, np.zeros(1)),
            f"indices must lie in \\[0, 35\\].*got {int(inds[0])}")
    refused(lambda: bmi.get_value_at_indices("sea_ice__volume", np.zeros(1), inds),
            "indices must lie in")


def test_outputs_are_read_only_and_inputs_writable(wave_bmi):  # noqa: F811
    b = wave_bmi
    for name in b.get_output_var_names():
        ptr = b.get_value_ptr(name)
        before = ptr.copy()
        with pytest.raises(ValueError, match="read-only"):
            ptr[:] = 1.0
        assert np.array_equal(b.get_value_ptr(name), before)
    ptr = b.get_value_ptr("sea_water_surface__elevation")
    ptr[0] = 0.5
    assert b.get_value("sea_water_surface__elevation", np.zeros(36))[0] == 0.5
