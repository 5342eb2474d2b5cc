"""Tests of siku-example-plugin: siku's conformance suite plus the physics of each component."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from siku_core.contact_law import BREAK_TENSION
from siku_core.plugins import get_registry
from siku_core.testing import conformance
from siku_core.testing.contact_conformance import check_contact_law
from siku_core.testing.writer_checks import DT, check_writer
from siku_example_plugin.laws import BrittleBond

SCENE = Path(__file__).parents[1] / "scenes" / "tilt_drift.toml"


class TestTiltConformance(conformance.TestForcingSourceConformance):
    """Finite at the poles and antimeridian, only adds, compiled == py_add (siku_core.testing)."""

    sources = ("sea_surface_tilt",)
    fields = ()  # a forcing source only: no drags to pair with fields, no field checks
    source_params = {"sea_surface_tilt": {"slope_east": 3e-6, "slope_north": -2e-6,
                                          "tidal_period": 44712.0, "tidal_phase": 30.0}}


def test_components_are_registered_with_their_package():
    reg = get_registry()
    assert reg.get("forcing", "sea_surface_tilt").__module__ == "siku_example_plugin.tilt"
    assert reg.get("integrator", "euler").order == 1


def test_tilt_accelerates_ice_at_rest_by_minus_g_slope(siku_simulation_factory):
    """Without drag or Coriolis, V(t) = -g s t exactly (Euler is exact for constant force)."""
    s_e, s_n, g = 2e-6, -1e-6, 9.81
    sim = siku_simulation_factory(
        elements=[(-150.0, 75.0), (180.0, 10.0)], integrator="euler", dt=60.0, duration=3600.0,
        forcing=[{"source": "sea_surface_tilt",
                  "params": {"slope_east": s_e, "slope_north": s_n, "g": g}}],
    )
    sim.run(steps=1)
    from siku_core.geometry.quat import east_north_local

    for i in range(sim.state.n):
        ex, ey, nx, ny = east_north_local(sim.state.q[i])
        east = sim.state.V[i, 0] * ex + sim.state.V[i, 1] * ey
        north = sim.state.V[i, 0] * nx + sim.state.V[i, 1] * ny
        assert east == pytest.approx(-g * s_e * 60.0, rel=1e-6)
        assert north == pytest.approx(-g * s_n * 60.0, rel=1e-6)


def test_euler_error_is_first_order(siku_simulation_factory):
    """Halving dt halves the error of a Coriolis inertial oscillation (against rk4)."""
    def final_V(integrator, dt):
        sim = siku_simulation_factory(
            elements=[{"center": (0.0, 80.0), "velocity": (0.3, 0.0)}], integrator=integrator,
            dt=dt, duration=7200.0, forcing=[{"source": "coriolis"}])
        sim.run()
        return sim.state.V[0].copy()

    ref = final_V("rk4", 60.0)
    e1 = np.linalg.norm(final_V("euler", 120.0) - ref)
    e2 = np.linalg.norm(final_V("euler", 60.0) - ref)
    assert 1.7 < e1 / e2 < 2.3


def test_example_scene_runs_by_name(siku_simulation_factory):
    sim = siku_simulation_factory(SCENE)
    assert sim.integrator.name == "euler"
    assert [f.name for f in sim.forcing] == ["sea_surface_tilt", "water_drag", "coriolis"]
    sim.run()
    assert np.isfinite(sim.state.V).all() and np.abs(sim.state.V).max() > 1e-3


BRITTLE_SCENE = Path(__file__).parents[1] / "scenes" / "brittle_pull.toml"


def test_brittle_bond_conforms():
    """Newton's third law, no force apart, history as declared, compiled == py_func, finite
    in degenerate geometry, passive, force = -grad(joint_energy)."""
    check_contact_law(BrittleBond)
    check_contact_law(BrittleBond, {"stiffness_scale": 2.0, "friction": 0.3,
                                    "joint_damping_ratio": 0.5})


def test_brittle_bonds_break_in_tension_when_the_stress_reaches_the_strength(
        siku_simulation_factory):
    """Held - free - pulled at v: each bond opens by v t / 2, so sigma = K v t / (2 h) reaches
    the strength at t = 2 h sigma_t / (K v); both bonds break within a step of it."""
    sim = siku_simulation_factory(BRITTLE_SCENE)
    cm = sim.contacts
    K, h, v = cm.jK[0], 1.0, 0.01
    sigma_t = sim.contacts.law.p["tensile_strength"]
    sim.run()
    assert not cm.intact.any()
    assert set(cm.break_mode) == {BREAK_TENSION}
    expected = 2.0 * h * sigma_t / (K * v)
    assert np.all(np.abs(cm.break_time - expected) <= sim.dt), (cm.break_time, expected)


@pytest.fixture(scope="module")
def tilted(siku_module_simulation_factory):
    """Ice on a sea surface tilted east for 6 h, run once for every test of the module."""
    return siku_module_simulation_factory(
        elements=[(-150.0, 75.0)], integrator="euler", dt=600.0, duration=6 * 3600.0,
        forcing=[{"source": "sea_surface_tilt", "params": {"slope_east": 2e-6, "g": 9.81}}],
    ).run()


def test_the_shared_run_reached_its_end(tilted):
    assert tilted.step_index == 36 and tilted.time == 6 * 3600.0


def test_the_shared_run_sped_up_at_g_times_the_slope(tilted):
    """|V| = g s t: the force keeps its size along the path (the local east turns under the
    floe by d tan(lat) / R = 3e-3 rad over its 4.5 km, a 4e-6 change of the force's share)."""
    assert np.hypot(*tilted.state.V[0]) == pytest.approx(9.81 * 2e-6 * 6 * 3600.0, rel=1e-5)


def csv_steps(path):
    """The steps of the snapshots in a centres_csv file: the times of element 0's rows / DT."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))[2:]
    return [round(float(r[0]) / DT) for r in rows if r[1] == "0"]


def test_centres_csv_passes_the_writer_suite(tmp_path):
    check_writer("centres_csv", tmp_path, steps=csv_steps)
