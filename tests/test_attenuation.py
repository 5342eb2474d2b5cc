"""Attenuation laws (siku_forcing.waves.attenuation): a plugin kind, and each shipped law against
the value its reference publishes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.errors import PluginError
from siku_core.interfaces import AttenuationLaw
from siku_core.plugins import get_registry
from siku_forcing.waves.attenuation import (
    Constant, Doble2015, Meylan2014, ViscousLayer, group_velocity,
)


def law(cls, **params):
    return cls({**{k: p.default for k, p in cls.params.items()}, **params})


def test_the_laws_are_registered_as_their_own_kind():
    reg = get_registry()
    for name in ("constant", "meylan2014", "doble2015", "viscous_layer"):
        assert issubclass(reg.get("attenuation_law", name), AttenuationLaw)
    with pytest.raises(PluginError, match="unknown attenuation law 'nope'"):
        reg.get("attenuation_law", "nope")


def test_a_third_party_law_registers_like_a_contact_law(siku_register):
    import types

    from siku_core import Param, hookimpl

    class Linear(AttenuationLaw):
        """k_i proportional to frequency."""

        name = "test_linear_in_f"
        params = {"c": Param(1e-4, "s m-1", "slope")}

        def rate(self, frequency, thickness, depth):
            return self.p["c"] * np.asarray(frequency, float)

    mod = types.ModuleType("third_party_attenuation")
    mod.siku_register_attenuation_laws = hookimpl(lambda: [Linear])
    reg = siku_register(mod)
    assert reg.get("attenuation_law", "test_linear_in_f") is Linear


def test_constant_is_alpha_everywhere():
    k = law(Constant, alpha=3e-5).rate(np.array([0.05, 0.1, 0.3]), 1.0, math.inf)
    assert np.array_equal(k, [3e-5] * 3)


def test_meylan2014_is_their_fit_in_period_with_half_the_energy_rate():
    # Meylan, Bennetts & Kohout (2014) eq. 3: alpha = 2.12e-3 T^-2 + 4.59e-2 T^-4 [1/m] for the
    # energy; the amplitude rate is half of it (WAVEWATCH III IC4M2)
    T = np.array([6.0, 8.0, 10.0, 14.0, 20.0])
    alpha = 2.12e-3 * T**-2 + 4.59e-2 * T**-4
    k = law(Meylan2014).rate(1.0 / T, 0.5, math.inf)
    assert np.allclose(k, alpha / 2, rtol=1e-13, atol=0)
    # the published coefficients give, at T = 10 s, alpha = 2.579e-5 1/m
    assert 2 * k[2] == pytest.approx(2.579e-5, rel=1e-12)


def test_doble2015_gives_the_rates_reported_for_20_cm_pancakes():
    # Doble et al. (2015) eq. 3: alpha = 0.2 T^-2.13 h; for 20 cm pancakes at the frequencies
    # of 0.075-0.15 Hz their rates lie between 1e-4 and 1e-3 1/m (as Orzech et al. 2018 sum
    # them up)
    f = np.linspace(0.075, 0.15, 7)
    k = law(Doble2015).rate(f, 0.2, math.inf)
    assert np.allclose(2 * k, 0.2 * (1 / f) ** -2.13 * 0.2, rtol=1e-13, atol=0)
    assert (2 * k > 1e-4).all() and (2 * k < 1e-3).all()
    # proportional to the thickness: thin pancakes damp less
    assert law(Doble2015).rate(0.1, 0.05, math.inf) == pytest.approx(
        law(Doble2015).rate(0.1, 0.2, math.inf) / 4, rel=1e-14)


def test_viscous_layer_in_deep_water_is_the_closed_form():
    # deep water: k = omega^2/g, c_g = g/(2 omega): k_i = sqrt(nu/2) omega^(7/2) / g^2
    nu, g = 1e-3, 9.81
    f = np.array([0.05, 0.1, 0.2])
    om = 2 * np.pi * f
    k = law(ViscousLayer, viscosity=nu).rate(f, 1.0, math.inf)
    assert np.allclose(k, math.sqrt(nu / 2) * om**3.5 / g**2, rtol=1e-13, atol=0)
    # the IC2 laminar source term: S/E = -2 c_g k_i = -k sqrt(nu omega / 2)
    assert np.allclose(2 * group_velocity(om, math.inf) * k,
                       om**2 / g * np.sqrt(nu * om / 2), rtol=1e-13, atol=0)


def test_viscous_layer_in_finite_depth_uses_the_finite_depth_k_and_group_velocity():
    from siku_forcing.waves.wave_field import wavenumber

    f, h = 0.1, 20.0
    om = 2 * math.pi * f
    k = wavenumber(om, h)
    cg = om / k * (0.5 + k * h / math.sinh(2 * k * h))
    got = law(ViscousLayer, viscosity=1e-3).rate(f, 1.0, h)
    assert float(got) == pytest.approx(k * math.sqrt(1e-3 * om / 2) / (2 * cg), rel=1e-13)
    # shallower water: slower groups, shorter waves, faster decay in space
    assert float(got) > float(law(ViscousLayer, viscosity=1e-3).rate(f, 1.0, math.inf))


@pytest.mark.parametrize("name", ["constant", "meylan2014", "doble2015", "viscous_layer"])
@pytest.mark.parametrize("depth", [math.inf, 30.0])
def test_every_law_gives_finite_nonnegative_rates_that_broadcast(name, depth):
    cls = get_registry().get("attenuation_law", name)
    f = np.array([0.03, 0.1, 0.5])[:, None, None]
    h = np.array([[0.0, 0.2], [1.0, 3.0]])[None]
    k = np.asarray(law(cls).rate(f, h, depth))
    assert k.shape == (3, 2, 2)
    assert np.isfinite(k).all() and (k >= 0).all()
