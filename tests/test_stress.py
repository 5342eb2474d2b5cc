"""Element stress from contact forces (siku_core.contact.stress) and its gridded mean.

Uniaxial tension: a bonded block pulled by its handles (``siku lab`` tension test, elastic
range). For the free part of the block in equilibrium the area integral of the stress is the
first moment of the forces on its boundary, so its mean ``sigma_xx`` is the mean end load per
unit width. Loading at a finite rate, the two ends carry slightly different loads (their
difference accelerates the block); the interior carries their mean, ``(F_fixed + F_moving) /
(2 W)`` [N/m]. A free-drifting pack with unstrained joints carries none.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.geometry.quat import centers
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.state import STATIC, STEADY
from siku_core.contact.stress import principal
from siku_core.testing.scenes import make_scene
from siku_plugins.lab import _scene_text

E, RHO, H, D, L, W = 1e9, 910.0, 1.0, 1.0, 24.0, 12.0
SIGMA = 1e6  # Pa, bond strength (not reached: the block is loaded to half of it)


@pytest.fixture(scope="module")
def pulled():
    pars = {"sigma_crit": SIGMA, "tau_crit": SIGMA}

    def scene(speed, dt, duration):
        return scene_from_text(_scene_text("tension", L, W, D, speed, dt, duration, H, E, 0.3,
                                           RHO, "bonded_particle", pars, 0), "<tension>")

    probe = Simulation(scene(0.0, 1e-9, 1e-9), out=False, progress=False)
    st = probe.state
    cen = centers(st.q) * probe.radius
    moving, fixed = st.flags == STEADY, st.flags == STATIC
    gauge = float(cen[moving, 1].mean() - cen[fixed, 1].mean())
    rate = (SIGMA / E) / (30 * L / math.sqrt(E / RHO))  # as the lab test: 30 crossing times
    speed = rate * gauge
    sim = Simulation(scene(speed, 0.4 * probe.critical_dt, 0.5 * (SIGMA / E) * gauge / speed),
                     out=False, progress=False)
    sim.run()
    return sim


def test_uniaxial_tension_gives_the_applied_stress_in_the_interior(pulled):
    sim = pulled
    st = sim.state
    f = sim.element_fields()
    moving, fixed = st.flags == STEADY, st.flags == STATIC
    applied = 0.5 * (st.F[fixed, 0].sum() - st.F[moving, 0].sum()) / W  # N/m
    assert applied > 0.3 * SIGMA * H  # well into the elastic range
    cen = centers(st.q) * sim.radius
    x = cen[:, 1]  # east, near 0°E on the equator
    mid = 0.5 * (x[moving].mean() + x[fixed].mean())
    gauge = x[moving].mean() - x[fixed].mean()
    inner = (st.flags == 0) & (np.abs(x - mid) < 0.25 * gauge)
    a = st.area[inner]
    mean = {k: np.sum(f[k][inner] * a) / a.sum() for k in ("stress_ee", "stress_nn",
                                                           "stress_en")}
    assert mean["stress_ee"] == pytest.approx(applied, rel=0.02)
    # uniaxial: no load across the block, no shear
    assert abs(mean["stress_nn"]) < 0.02 * applied
    assert abs(mean["stress_en"]) < 0.02 * applied
    s1, s2, sI, sII = principal(mean["stress_ee"], mean["stress_nn"], mean["stress_en"])
    assert s1 == pytest.approx(applied, rel=0.02) and abs(s2) < 0.02 * applied
    assert sI == pytest.approx(applied / 2, rel=0.04) and sII == pytest.approx(applied / 2,
                                                                                rel=0.04)


def test_the_gridded_stress_of_the_interior_is_the_applied_stress(pulled):
    from siku_io.analysis.gridded_fields import grid_snapshot, snapshot_of
    from siku_forcing.gridded.regular_grid import Grid, GridCfg

    sim = pulled
    st = sim.state
    moving, fixed = st.flags == STEADY, st.flags == STATIC
    applied = 0.5 * (st.F[fixed, 0].sum() - st.F[moving, 0].sum()) / W
    # one cell over the middle half of the block, its full width
    deg = 180 / math.pi / sim.radius
    cfg = GridCfg(kind="lonlat", lon=(-L * deg / 4, L * deg / 4), lat=(-W * deg, W * deg),
                  dlon=L * deg / 2, dlat=2 * W * deg)
    f = grid_snapshot(Grid(cfg, sim.radius), snapshot_of(sim))
    assert f["stress_xx"][0, 0] == pytest.approx(applied, rel=0.02)
    assert f["stress_I"][0, 0] == pytest.approx(applied / 2, rel=0.04)


def test_floes_in_free_drift_carry_no_stress():
    """Free drift: floes pushed by the wind that never touch carry no internal stress, so
    every element's stress is exactly zero (their contact pairs are found and tested, and
    none carries force)."""
    floes = [(lon, lat) for lon in (0.0, 0.3, 0.6) for lat in (70.0, 70.12)]
    scene = make_scene(floes, size=8e3, dt=1.5, duration=3600.0,
                       forcing=[{"source": "air_drag", "field": {
                           "type": "uniform", "params": {"u": 10.0, "v": 0.0}}},
                           {"source": "water_drag"}],
                       extra='[contact]\nlaw = "collision"\nskin = 10e3\n')
    sim = Simulation(scene, out=False, progress=False)
    sim.run()
    assert len(sim.contacts.pairs) > 0 and sim.contacts.n_overlap == 0
    assert np.hypot(*sim.state.V.T).min() > 0.05  # drifting
    f = sim.element_fields()
    for k in ("stress_ee", "stress_nn", "stress_en"):
        assert np.all(f[k] == 0.0)
