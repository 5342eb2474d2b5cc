"""Tests of siku-tidal-bonds: siku's conformance suites and the physics of each component."""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.contacts import (
    BREAK_SHEAR, BREAK_TENSION, J_BX, J_HI, J_HJ, J_K, J_S1X, J_S1Y, J_S2X, J_S2Y, J_W,
)
from siku_core.geometry.quat import east_north_local
from siku_core.plugins import get_registry
from siku_core.testing import conformance
from siku_core.testing.contact_conformance import check_contact_law
from siku_tidal_bonds.beam import BondedBeam, bonded_beam_evaluator


class TestTidalConformance(conformance.TestForcingSourceConformance):
    """Finite at the poles and antimeridian, only adds, compiled == py_add (siku_core.testing)."""

    sources = ("tidal_current",)
    fields = ()
    source_params = {"tidal_current": {"u_east": 0.3, "u_north": -0.1, "tidal_phase": 20.0}}


def test_components_are_registered_by_name():
    reg = get_registry()
    assert reg.get("contact_law", "bonded_beam") is BondedBeam
    assert reg.get("forcing", "tidal_current").__module__ == "siku_tidal_bonds.tide"


def test_bonded_beam_conforms():
    """Newton's third law, no force apart, history as declared, compiled == py_func, finite in
    degenerate geometry, passive."""
    check_contact_law(BondedBeam)
    check_contact_law(BondedBeam, {"stiffness_scale": 2.0, "joint_damping_ratio": 0.5})


def _joint(s1y, s2y, K=5.0e5, h=1.0, width=2000.0):
    """A joint along x of ``width`` [m] whose ends open by ``s1y``, ``s2y`` [m] towards -y."""
    g = np.zeros(32)
    g[J_BX], g[J_W], g[J_K], g[J_HI], g[J_HJ] = width, width, K, h, h
    g[J_S1Y], g[J_S2Y] = s1y, s2y
    return g


def _evaluate(g, tensile=3.0e5, shear=5.0e5):
    out, hist = np.zeros(4), np.zeros(2)
    bonded_beam_evaluator(g, np.array([tensile, shear, 1.0, 0.0]), hist, out)
    return out, hist


def test_a_beam_opened_evenly_pulls_back_with_K_w_d_and_breaks_at_the_strength():
    """Even opening d (n = -y): axial stress K d / h, force K w d back towards i; the bond
    breaks in tension once K d / h exceeds tensile_strength (0.6 m at K = 5e5 Pa/m, h = 1 m)."""
    out, hist = _evaluate(_joint(-0.5, -0.5))
    assert out[3] == 0.0
    assert out[1] == pytest.approx(5.0e5 * 2000.0 * 0.5, rel=1e-12)
    assert hist[0] == pytest.approx(5.0e5 * 0.5, rel=1e-12)
    out, _ = _evaluate(_joint(-0.61, -0.61))
    assert out[3] == BREAK_TENSION


def test_bending_adds_to_the_axial_stress():
    """Ends opened by 0 and 0.8 m: axial 0.4 K / h plus bending 0.4 K / h = 4e5 Pa > 3e5 Pa,
    though the mean opening alone (2e5 Pa) would hold."""
    out, hist = _evaluate(_joint(0.0, -0.8))
    assert hist[0] == pytest.approx(4.0e5, rel=1e-12)
    assert out[3] == BREAK_TENSION


def test_a_beam_sheared_past_the_shear_strength_breaks_in_shear():
    g = _joint(0.0, 0.0)
    g[J_S1X] = g[J_S2X] = 1.2  # both ends slid 1.2 m along the joint: tau = 6e5 Pa > 5e5 Pa
    out, _ = _evaluate(g)
    assert out[3] == BREAK_SHEAR


def test_tidal_drag_on_ice_at_rest_is_rho_cd_area_u_squared(siku_simulation_factory):
    """At t = 0 (phase 0) ice at rest feels rho C_d A |u| u; a quarter period later the
    current and the force vanish; ice moving with the current feels nothing."""
    sim = siku_simulation_factory(
        elements=[(-150.0, 75.0), (180.0, 10.0)], integrator="rk4", dt=60.0, duration=600.0,
        forcing=[{"source": "tidal_current", "params": {"u_east": 0.3, "u_north": 0.4}}])
    src, st = sim.forcing[0], sim.state
    k = 1026.0 * 5.5e-3
    F, T = np.zeros((st.n, 2)), np.zeros(st.n)
    V = np.zeros((st.n, 2))
    src.add(0.0, st.q, V, st.w, F, T)
    for i in range(st.n):
        ex, ey, nx, ny = east_north_local(st.q[i])
        east = F[i, 0] * ex + F[i, 1] * ey
        north = F[i, 0] * nx + F[i, 1] * ny
        assert east == pytest.approx(k * st.area[i] * 0.5 * 0.3, rel=1e-12)
        assert north == pytest.approx(k * st.area[i] * 0.5 * 0.4, rel=1e-12)
        V[i] = (0.3 * ex + 0.4 * nx, 0.3 * ey + 0.4 * ny)
    F[:] = 0.0
    src.add(0.0, st.q, V, st.w, F, T)
    assert np.abs(F).max() <= 1e-9 * k * st.area.max() * 0.25
    F[:] = 0.0
    src.add(44712.0 / 4.0, st.q, np.zeros_like(V), st.w, F, T)
    assert np.abs(F).max() <= 1e-9 * k * st.area.max() * 0.25
    assert not T.any()
