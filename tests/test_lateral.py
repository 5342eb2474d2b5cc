"""The ice volume of an element with thickness categories, ``A sum_k a_k h_k`` (mass and inertia
follow it), and lateral (open-water) growth in ``thermodynamics`` (Hibler 1979: the open water
``o = 1 - sum a_k`` freezes new ice of thickness ``h_0`` at the rate ``o Q_o / (rho_i L_f h_0)``,
integrated exactly, so ``o(t) = o(0) exp(-t / tau)``, ``tau = rho_i L_f h_0 / Q_o``).

Tolerances: the open-water growth is integrated exactly, so the open water and the frozen
volume follow the closed form to round-off over any number of steps (1e-12); the mass is one
product (1e-15); the volume budget is a sum of per-step differences (1e-10 relative, the issue's
must-show)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.errors import SceneError
from siku_core.interfaces import ElementSource, ElementSpec, Process
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_core.testing.contact_cases import registry_with
from siku_core.testing.process_checks import check_process, ice_volume
from siku_core.testing.scenes import square
from siku_plugins.processes import Thermodynamics
from test_categories import _RidgeTrio

L_F, T_F, RHO = 3.34e5, -1.8, 910.0
#: the open-water case: surface temperature [°C], transfer [W m-2 K-1], new ice [m]
TS, C_O, H_0 = -20.0, 13.0, 0.1
#: fractions and thicknesses of the three squares (the third has no categories)
GIVEN = (([0.3, 0.2], [0.6, 1.5]), ([0.05, 0.6], [0.2, 2.5]), None)


class _Three(ElementSource):
    """Three free squares of 2 km at 80 N, 4 km apart: two with categories, one without."""

    name = "three_squares"

    def build(self, scene, seed, where):
        return [ElementSpec(np.array(square((k * 0.25, 80.0), 2000.0)), thickness=1.0,
                            label=f"square {k}",
                            categories=None if g is None else tuple(map(np.array, g)))
                for k, g in enumerate(GIVEN)]


def _three(process: str, dt: float, steps: int, registry=None) -> Simulation:
    txt = scene_text([], dt=dt, duration=steps * dt, extra=(
        '[[elements.source]]\nname = "three_squares"\n\n' + process))
    reg = registry_with("element_source", _Three, registry)
    return Simulation(scene_from_text(txt, "<three>"), out=False, progress=False, registry=reg)


def _lateral(every: float | None = None, extra: str = "") -> str:
    out = ('[[process]]\nname = "thermodynamics"\nparams = { surface_temperature = '
           f'{TS}, lateral = true, open_water_transfer = {C_O}, new_ice_thickness = {H_0}'
           f'{extra} }}\n')
    return out + (f"every = {every!r}\n" if every is not None else "")


@pytest.mark.parametrize("every", [None, 6 * 3600.0])
def test_open_water_freezes_at_the_predicted_rate_volume_and_area(every):
    sim = _three(_lateral(every), dt=3600.0, steps=120)
    st, cats = sim.state, sim.context.categories
    a0 = cats.fraction.copy()
    o0 = 1.0 - a0.sum(1)
    v0 = ice_volume(sim)
    tau = RHO * L_F * H_0 / (C_O * (T_F - TS))  # [s], about 36 h
    frozen = sim.context.fields["lateral_volume"]
    for _ in range(sim.n_steps // (1 if every is None else 6)):
        sim.run(steps=1 if every is None else 6)
        o = o0 * math.exp(-sim.time / tau)
        # the open water shrinks exponentially, the fractions never sum above 1
        np.testing.assert_allclose(1.0 - cats.fraction.sum(1), o, rtol=0, atol=1e-12)
        assert (cats.fraction.sum(1) <= 1.0).all()
        # the volume frozen in open water: A h_0 (o(0) - o(t)), to round-off
        np.testing.assert_allclose(frozen, st.area * H_0 * (o0 - o), rtol=1e-12, atol=0)
    # the run spans the fill-up: less than 4 % of the open water is left
    assert sim.time == 120 * 3600.0 and math.exp(-sim.time / tau) < 0.04
    # the new ice went into category 0 only; the element without categories has no open water
    assert np.array_equal(cats.fraction[:, 1], a0[:, 1])
    assert np.array_equal(cats.fraction[2], [1.0, 0.0]) and frozen[2] == 0.0
    # the volume budget closes: the engine counts A sum a_k h_k, as the process does
    budget = sim.processes[0].budget(sim.context)
    assert ice_volume(sim) - v0 == pytest.approx(budget, rel=1e-12)
    np.testing.assert_allclose(st.m, RHO * st.area * (cats.fraction * cats.thickness).sum(1),
                               rtol=1e-15)


def test_no_open_water_growth_above_freezing_or_when_the_ocean_flux_wins():
    # Q_o = C_o (T_f - T_s) - F_w = 13 * 18.2 - 300 < 0: nothing freezes in open water
    sim = _three(_lateral(extra=", ocean_heat_flux = 300.0"), dt=3600.0, steps=6)
    a0 = sim.context.categories.fraction.copy()
    sim.run()
    assert np.array_equal(sim.context.categories.fraction, a0)
    assert not sim.context.fields["lateral_volume"].any()


class _HalveFractions(Process):
    """Halves every category fraction (the mean thickness stays, bit for bit)."""

    name = "halve_fractions"

    def apply(self, ctx, dt):
        ctx.categories.fraction[:2] *= 0.5


def test_mass_and_inertia_follow_a_fraction_change_to_round_off():
    # fails on the rule m = rho h A (the mean thickness does not change, so neither did m)
    reg = registry_with("process", _HalveFractions)
    sim = _three('[[process]]\nname = "halve_fractions"\n', dt=60.0, steps=3, registry=reg)
    st, cats = sim.state, sim.context.categories
    h0, m0, I0 = st.thickness.copy(), st.m.copy(), st.I.copy()
    sim.run(steps=1)
    assert np.array_equal(st.thickness, h0)
    np.testing.assert_allclose(st.m[:2], 0.5 * m0[:2], rtol=1e-15)
    np.testing.assert_allclose(st.I[:2], 0.5 * I0[:2], rtol=1e-15)
    assert st.m[2] == m0[2] and st.I[2] == I0[2]
    np.testing.assert_allclose(st.m, RHO * st.area * (cats.fraction * cats.thickness).sum(1),
                               rtol=1e-15)


def test_the_volume_budget_closes_with_growth_lateral_growth_melt_and_ridging():
    """The issue's must-show: thin ice grows, the wall's thicker ice melts (ocean heat flux
    60 W/m², -40 °C), open water freezes, thin ice ridges onto a carrier: the change of the
    total ice volume equals the thermodynamic budget to 1e-10 relative (ridging moves volume,
    adds none). Each part is at least 1000 times that tolerance."""
    thermo = ('[[process]]\nname = "thermodynamics"\nparams = { surface_temperature = -40.0, '
              'ocean_heat_flux = 60.0, lateral = true, min_thickness = 0.01 }\nevery = 2.5\n')
    txt = scene_text([], dt=0.25, duration=100.0, extra=(
        '[[elements.source]]\nname = "ridge_trio"\n\n[contact]\nlaw = "ridging"\n'
        'joints = "none"\n\n[[process]]\nname = "ridging"\n\n' + thermo))
    sim = Simulation(scene_from_text(txt, "<budget>"), out=False, progress=False,
                     registry=registry_with("element_source", _RidgeTrio))
    v0 = ice_volume(sim)
    sim.run()
    tol = 1e-10 * v0
    f = sim.context.fields
    assert f["ridged_volume"][1] > 1e3  # m³: a ridge
    assert f["lateral_volume"].sum() > 1e4 * tol  # open water froze
    grown = f["grown_volume"]
    assert grown[0] < -1e3 * tol and grown[2] > 1e3 * tol  # the wall melts, thin ice grows
    budget = sum(p.budget(sim.context) for p in sim.processes)
    assert abs((ice_volume(sim) - v0) - budget) <= tol
    assert abs(budget) > 1e4 * tol


def test_lateral_growth_without_categories_is_refused_in_one_line():
    txt = scene_text([(0.0, 80.0)], dt=3600.0, duration=3600.0, extra=_lateral())
    with pytest.raises(SceneError, match=r"lateral = true needs thickness categories"):
        Simulation(scene_from_text(txt, "<plain>"), out=False, progress=False)
    with pytest.raises(SceneError, match=r"new_ice_category = 2; the scene has 2"):
        _three(_lateral(extra=", new_ice_category = 2"), dt=3600.0, steps=1)


def test_floating_refuses_an_element_its_ice_does_not_cover_in_one_line():
    # its floe of mass rho_i h A would weigh 1 / sum a_k times the engine's element
    with pytest.raises(SceneError, match=r"floating': element 0 has ice on 0.5 of its area"):
        _three('[[process]]\nname = "floating"\n', dt=1.0, steps=2)


def test_lateral_growth_passes_the_process_conformance_suite(tmp_path):
    """Finite, its budget closes to 1e-10, idempotent, restart bit for bit, in the bonded pack
    whose every element has 90 % ice in two categories."""
    check_process(Thermodynamics, {"surface_temperature": -30.0, "lateral": True,
                                   "new_ice_thickness": 0.1, "open_water_transfer": 1e3},
                  tmp_path, categories=([0.5, 0.4], [0.3, 0.75]))
