"""The spectral wave field (siku_forcing.waves.spectral, spectral_transport): transport, absorption
by
the ice, the local sea the elements feel, and bad input."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from siku_core.testing import conformance
from siku_forcing.waves.spectral_transport import absorb, steady_ratio, transport


def test_transport_in_a_closed_domain_conserves_energy_to_round_off():
    rng = np.random.default_rng(5)
    E = rng.random((4, 15, 20))
    th = np.radians([10.0, 100.0, 200.0, 290.0])
    cg = np.array([6.0, 4.0, 3.0, 9.0])
    cx, cy = cg * np.sin(th), cg * np.cos(th)
    dx, dy = 50.0, 40.0
    dt = 0.9 / np.max(np.abs(cx) / dx + np.abs(cy) / dy)
    total = E.sum()
    for _ in range(300):
        E, inflow = transport(E, cx, cy, dx, dy, dt, closed=True)
        assert not inflow.any()
    assert abs(E.sum() - total) <= 1e-12 * total
    assert (E >= 0).all()


@pytest.mark.parametrize("nu", [0.5, 0.9, 1.0])
def test_a_front_arrives_at_cg_t_within_one_cell_after_100_cells(nu):
    nx, dx, c = 200, 10.0, 5.0
    dt = nu * dx / c
    E = np.zeros((1, 1, nx))
    n = int(round(100 * dx / (c * dt)))
    for _ in range(n):
        E, _ = transport(E, np.array([c]), np.array([0.0]), dx, 1.0, dt, closed=False,
                         E_in=np.array([1.0]))
    # where the energy crosses half the incident level, in cells from the upstream edge
    e = E[0, 0]
    i = int(np.flatnonzero(e < 0.5)[0])
    front = i - 1 + (e[i - 1] - 0.5) / (e[i - 1] - e[i]) + 0.5  # interpolated, cell centres
    assert abs(front - c * n * dt / dx) <= 1.0


def test_uniform_ice_at_courant_one_gives_exactly_the_exponential():
    nx, dx, c, alpha = 100, 20.0, 4.0, 2e-4
    dt = dx / c
    E = np.zeros((1, 1, nx))
    ki, C = np.full((1, 1, nx), alpha), np.ones((1, nx))
    for _ in range(nx + 5):
        E, _ = transport(E, np.array([c]), np.array([0.0]), dx, 1.0, dt, False, np.ones(1))
        E, _ = absorb(E, np.array([c]), ki, C, dt)
    x = (np.arange(nx) + 1) * dx
    assert np.allclose(E[0, 0], np.exp(-2 * alpha * x), rtol=1e-12, atol=0)


def test_uniform_ice_at_any_courant_number_reaches_the_schemes_steady_state():
    nx, dx, c, alpha, nu = 60, 20.0, 4.0, 2e-3, 0.6
    dt = nu * dx / c
    E = np.zeros((1, 1, nx))
    ki, C = np.full((1, 1, nx), alpha), np.full((1, nx), 0.5)
    for _ in range(3000):
        E, _ = transport(E, np.array([c]), np.array([0.0]), dx, 1.0, dt, False, np.ones(1))
        E, _ = absorb(E, np.array([c]), ki, C, dt)
    r = steady_ratio(nu, 2 * c * alpha * 0.5 * dt)
    assert np.allclose(E[0, 0], r ** (np.arange(nx) + 1.0), rtol=1e-6, atol=0)
    # the discrete rate is the continuous one, 2 alpha C, to first order in 2 alpha C dx
    assert math.log(r) / dx == pytest.approx(-2 * alpha * 0.5, rel=2 * alpha * 0.5 * dx)


def test_the_energy_budget_closes_inflow_absorption_and_content():
    rng = np.random.default_rng(2)
    nx, ny, dx = 12, 8, 30.0
    th = np.radians([45.0, 90.0, 170.0])
    cg = np.array([5.0, 7.0, 3.0])
    cx, cy = cg * np.sin(th), cg * np.cos(th)
    E = np.zeros((3, ny, nx))
    E_in = np.array([0.2, 0.5, 0.1])
    ki = rng.uniform(0, 1e-3, (3, ny, nx))
    C = rng.uniform(0, 1, (ny, nx))
    dt = 0.9 / np.max(np.abs(cx) / dx + np.abs(cy) / dx)
    gained = absorbed = 0.0
    for _ in range(200):
        E, inflow = transport(E, cx, cy, dx, dx, dt, False, E_in)
        E, lost = absorb(E, cg, ki, C, dt)
        gained += inflow.sum()
        absorbed += lost.sum() * dx * dx
    assert E.sum() * dx * dx == pytest.approx(gained - absorbed, rel=1e-12)


# ----------------------------------------------------------------------- the field in a run
def flume_scene(tmp_path, field_params, n_ice=6, out=False):
    """A 1-D flume 0..2000 m east of the origin at the equator, one 100 m cell wide, with
    ``n_ice`` 100 m elements from x = 1000 m on."""
    from siku_core.testing import scene_text
    from siku_core.testing.contact_cases import square_pack

    pack = square_pack(math.degrees(1000.0 / 6_371_000.0), -math.degrees(50 / 6_371_000.0),
                       n_ice, 1, size=100.0)
    field = {"type": "spectral", "params": {
        "spectrum": "monochromatic", "amplitude": 0.5, "period": 8.0, "x": [0.0, 2000.0],
        "y": [-50.0, 50.0], "resolution": 100.0, "origin": [0.0, 0.0], **field_params}}
    txt = scene_text([], packs=[pack], dt=0.05, duration=0.2, thickness=1.0, forcing=[
        {"source": "waves", "params": {"drag": True}, "field": field}],
        output={"file": str(tmp_path / "flume.h5"), "every": "0.1s"} if out else None)
    path = tmp_path / "flume.toml"
    path.write_text(txt)
    return path


def build(path):
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    return Simulation(load_scene(path), out=False, progress=False)


def test_the_field_damps_the_sea_where_the_elements_are(tmp_path):
    alpha = 5e-4
    sim = build(flume_scene(tmp_path, {"attenuation": "constant",
                                       "attenuation_params": {"alpha": alpha},
                                       "start": "calm"}))
    f = sim.forcing[0].field
    assert f.C[0, :10].max() == 0.0 and (f.C[0, 10:16] > 0.99).all()
    f.advance(2000.0)  # 2000 s: about 3 crossings of the flume at c_g = 6.2 m/s
    e = f.E[0, 0] / f.E_in[0]
    assert np.allclose(e[:10], 1.0, rtol=1e-9)  # open water upstream of the ice
    nu = f.cx[0] * (2000.0 / math.ceil(2000.0 * f.cx[0] / f.dx / 0.9)) / f.dx
    dt = nu * f.dx / f.cx[0]
    want = np.cumprod([steady_ratio(nu, 2 * f.cg[0] * alpha * C * dt) for C in f.C[0, 10:16]])
    assert np.allclose(e[10:16], want, rtol=1e-6)
    # the absorbed power per unit area, rho g 2 c_g alpha C E [W/m2]
    P = f.dissipation()[0]
    assert P[:10].max() == 0.0
    assert P[10] == pytest.approx(1025.0 * 9.81 * 2 * f.cg[0] * alpha * f.C[0, 10] * f.E[0, 0, 10],
                                  rel=1e-12)


def test_without_ice_the_elements_feel_the_incident_wave(tmp_path):
    from siku_forcing.waves.wave_field import LinearWave

    sim = build(flume_scene(tmp_path, {"attenuation": "constant",
                                       "attenuation_params": {"alpha": 0.0}}))
    f = sim.forcing[0].field
    w = LinearWave({**{k: p.default for k, p in LinearWave.params.items()},
                    "amplitude": 0.5, "period": 8.0, "origin": [0.0, 0.0]})
    w.radius = f.radius
    lat = np.zeros(7)
    lon = np.linspace(10.0, 1990.0, 7) / 6_371_000.0
    for t in (0.0, 3.3):
        a, b = f.evaluate(t, lat, lon), w.evaluate(t, lat, lon)
        for k in ("eta", "eta_e", "eta_n", "u", "v"):
            assert np.allclose(a[k], b[k], rtol=1e-12, atol=1e-15), k
    se, sn = np.ones(7), np.zeros(7)
    assert np.allclose(f.curvature(1.0, lat, lon, se, sn), w.curvature(1.0, lat, lon, se, sn),
                       rtol=1e-12, atol=1e-18)


def test_a_run_writes_the_wave_height_and_dissipation_of_each_element(tmp_path):
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    path = flume_scene(tmp_path, {"attenuation": "constant",
                                  "attenuation_params": {"alpha": 1e-3}}, out=True)
    sim = Simulation(load_scene(path), progress=False)
    sim.run()
    sim.close()
    f = sim.forcing[0].field
    assert f.t_wave > 0.0
    h = sim.context.fields["wave_height"]
    assert np.allclose(h, f.height().ravel()[f.element_cell], rtol=1e-14)
    assert (sim.context.fields["wave_dissipation"] > 0).all()


def run_cli(path):
    return subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(path),
                           "--no-progress"], capture_output=True, text=True, cwd=path.parent)


@pytest.mark.parametrize("params, words", [
    ({"spectrum": "table", "frequencies": [0.1, 0.12], "energy": [1.0, -0.5]},
     "no negative energy"),
    ({"x": [0.0, 1200.0]}, "does not cover the ice"),
    ({"attenuation": "no_such_law"}, "unknown attenuation law 'no_such_law'"),
    ({"boundary": "closed", "start": "calm"}, "no sea ever enters the grid"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, params, words):
    r = run_cli(flume_scene(tmp_path, params))
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.strip().splitlines() if ln]
    assert len(lines) == 1 and words in lines[0], r.stderr


def test_a_restart_continues_the_evolving_spectrum_bit_for_bit(tmp_path):
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    path = flume_scene(tmp_path, {"attenuation": "doble2015", "start": "calm"}, out=True)
    scene = load_scene(path)
    whole = Simulation(scene, out=tmp_path / "whole.h5", progress=False).run()
    part = tmp_path / "part.h5"
    Simulation(scene, out=part, progress=False).run(steps=2)
    second = Simulation(scene, out=part, restart=part, progress=False)
    assert second.restarted_from == 2
    second.run()
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(second.state, k), getattr(whole.state, k)), k
    a, b = second.forcing[0].field, whole.forcing[0].field
    assert a.t_wave == b.t_wave > 0 and np.array_equal(a.E, b.E)
    assert np.array_equal(second.context.fields["wave_height"],
                          whole.context.fields["wave_height"])


def test_the_breakup_front_stalls_where_the_attenuated_strain_falls_below_the_critical():
    """A strip of 5 m elements bonded by uniform joints from x = 0 to 400 m, held still (no
    wave forces), under a monochromatic swell (a0 = 0.5 m, T = 8 s) damped at a constant
    rate: joints break where the surface strain (h/2) a k² exceeds the critical strain. From a
    calm start the spectrum rises monotonically to its steady state, so the front advances
    and stalls. In the discrete steady state cell i holds a(face i+1), so the front is the
    downstream face of the last cell whose amplitude exceeds a_c = 2 eps_c / (k² h): the last
    broken joint lies within one cell upstream of it, and that face within one cell of the
    continuous position x* = ln(a0 / a_c) / (alpha C)."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.testing import scene_text
    from siku_core.testing.contact_cases import square_pack

    R, a0, alpha, h, eps_c, dx = 6_371_000.0, 0.5, 2e-3, 1.0, 6.6e-4, 25.0
    pack = square_pack(0.0, -math.degrees(2.5 / R), 80, 1, size=5.0)
    field = {"type": "spectral", "params": {
        "spectrum": "monochromatic", "amplitude": a0, "period": 8.0, "x": [-100.0, 500.0],
        "y": [-2.5, 2.5], "resolution": dx, "origin": [0.0, 0.0], "start": "calm",
        "attenuation": "constant", "attenuation_params": {"alpha": alpha}}}
    txt = scene_text([], packs=[pack], dt=0.25, duration=400.0, thickness=h,
                     materials={"ice": {"youngs_modulus": 1e4, "poisson_ratio": 0.3}},
                     forcing=[{"source": "waves", "field": field, "params": {
                         "drag": False, "slope": False, "breaking": True,
                         "critical_strain": eps_c}}],
                     extra='[contact]\nlaw = "distributed_spring"\n'
                           'params = { tensile_strain = 1.0 }\n')
    sim = Simulation(scene_from_text(txt, "<breakup front>"), out=False, progress=False)
    f, cm = sim.forcing[0].field, sim.contacts
    C = f.C[0, 4:20]
    assert np.allclose(C, C[0], rtol=1e-6) and C[0] > 0.99  # uniform ice over x = 0..400 m
    sim.run()
    k = float(f.k[0])
    a_c = 2 * eps_c / (k * k * h)
    lat, lon, *_ = cm.joint_lines()
    xj, _ = f.plane(lat, lon)
    broken = ~cm.intact
    assert broken.any() and not broken.all()
    x_b = xj[broken].max()
    # (upstream of the front some joints hold: pieces shorter than the rigid-floe length
    # cannot break, siku_forcing.waves.wave_breaking)
    amp = np.sqrt(2 * f.E[0, 0])  # per cell, steady by now
    faces = f.x0 + (np.arange(f.nx) + 1) * f.dx
    over = (amp > a_c) & (faces > 0) & (faces <= 400.0)
    x_front = faces[over].max()
    # (a joint on the face itself, x = x_front to round-off, belongs to either cell)
    assert x_front - dx <= x_b <= x_front + 1e-6
    x_star = math.log(a0 / a_c) / (alpha * C[0])
    assert abs(x_front - x_star) <= dx


def test_the_ice_edge_example_builds_and_steps():
    from pathlib import Path

    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    path = Path(__file__).resolve().parents[1] / "examples" / "miz" / "miz.toml"
    assert path.read_text(encoding="utf-8").startswith("#")
    sim = Simulation(load_scene(path), out=False, progress=False)
    assert sim.dt <= sim.scene.cfg.run.dt_safety * sim.critical_dt
    f = sim.forcing[0].field
    assert f.law.name == "doble2015" and (f.C[:, 10:40] > 0.99).all()
    sim.run(steps=5)
    assert np.isfinite(sim.state.q).all() and f.t_wave > 0


def test_the_drag_power_is_the_drag_force_times_the_orbital_velocity(tmp_path):
    from siku_forcing.waves.spectral import add_slope_drag
    from siku_core.geometry.element_geometry import east_north

    sim = build(flume_scene(tmp_path, {"attenuation": "constant",
                                       "attenuation_params": {"alpha": 1e-3}}))
    st = sim.state
    rng = np.random.default_rng(4)
    V = rng.normal(0, 0.2, (st.n, 2))
    r = rng.normal(0, 0.3, (st.n, 5))  # eta, slopes, orbital u east, v north
    F, power = np.zeros((st.n, 2)), np.zeros(st.n)
    coef = 1025.0 * 0.003
    add_slope_drag(st.q, V, st.m, st.area, np.ones(st.n, bool), r, 9.81, False, coef, F, power)
    ue, un = east_north(st.q, V)
    de, dn = r[:, 3] - ue, r[:, 4] - un
    s = st.area * coef * np.hypot(de, dn)
    assert np.allclose(power, s * de * r[:, 3] + s * dn * r[:, 4], rtol=1e-12, atol=0)
    # and in a run: the field reports it per element per unit area, and its total
    sim.run(steps=3)
    f = sim.forcing[0].field
    assert (f.drag_power != 0).any()
    assert np.allclose(sim.context.fields["wave_drag_power"] * st.area, f.drag_power,
                       rtol=1e-14)
    assert sim.diagnostics()["wave_drag_power"] == pytest.approx(f.drag_power.sum(), rel=1e-14)


def test_a_directional_sea_without_ice_stays_the_incident_sea_at_open_edges(tmp_path):
    # every component enters across the edges it travels in from: the uniform incident sea is
    # the steady state, kept to round-off in every cell
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.testing import scene_text

    field = {"type": "spectral", "params": {
        "spectrum": "jonswap", "hs": 1.0, "tp": 8.0, "n_frequencies": 4, "n_directions": 8,
        "spreading": 2.0, "x": [-300.0, 300.0], "y": [-200.0, 200.0], "resolution": 50.0,
        "attenuation": "constant", "attenuation_params": {"alpha": 0.0}}}
    txt = scene_text([(0.0, 0.0)], size=20.0, dt=0.05, duration=0.1, forcing=[
        {"source": "waves", "field": field}])
    sim = Simulation(scene_from_text(txt, "<directional>"), out=False, progress=False)
    f = sim.forcing[0].field
    assert len(f.E_in) == 32 and (f.cx < 0).any() and (f.cy < 0).any()
    f.advance(600.0)
    assert np.allclose(f.E, f.E_in[:, None, None], rtol=1e-12, atol=0)
    assert f.height() == pytest.approx(np.full((8, 12), f.height()[0, 0]), rel=1e-12)


def test_a_drag_that_takes_the_field_as_its_current_advances_the_sea(tmp_path):
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    txt = flume_scene(tmp_path, {"attenuation": "constant", "start": "calm"}).read_text()
    txt = txt.replace('source = "waves"', 'source = "water_drag"').replace(
        "params = { drag = true }", "")
    sim = Simulation(scene_from_text(txt, "<water drag>"), out=False, progress=False)
    f = sim.forcing[0].field
    sim.run(steps=3)
    assert f.t_wave == pytest.approx(2 * sim.dt) and f.E.sum() > 0
    # two sub-steps of upwind transport carry the sea two cells in, not to the ice at 1000 m
    assert (f.E[:, :, :2] > 0).all() and (f.E[:, :, 2:] == 0).all()
    assert (sim.context.fields["wave_height"] == 0).all()


@pytest.mark.parametrize("nd, spreading", [(1, 10.0), (16, 2.0)])
def test_fast_jonswap_is_the_jonswap_sea_to_round_off_at_every_point(nd, spreading):
    from siku_forcing.waves.spectral_fast import FastJonswap
    from siku_forcing.waves.wave_field import Jonswap

    p = {k: v.default for k, v in Jonswap.params.items()}
    p.update(n_directions=nd, spreading=spreading, n_frequencies=48, seed=7,
             origin=[-150.0, 75.0])
    a, b = Jonswap(dict(p)), FastJonswap(dict(p))
    for w in (a, b):
        w._build()
    assert np.array_equal(a.phase, b.phase) and len(b.amp) == 48 * nd
    rng = np.random.default_rng(3)
    lat = np.radians(75 + rng.uniform(-0.005, 0.005, 500))
    lon = np.radians(-150 + rng.uniform(-0.02, 0.02, 500))
    tol = 1e-12 * a.amp.sum()  # of the largest possible elevation
    for t in (0.0, 37.5):
        A, B = a.evaluate(t, lat, lon), b.evaluate(t, lat, lon)
        # elevation [m], slopes [1] (times k), orbital velocities [m/s] (times omega)
        scales = {"eta": 1.0, "eta_e": a.k.max(), "eta_n": a.k.max(), "u": a.omega.max(),
                  "v": a.omega.max()}
        for k, scale in scales.items():
            assert np.abs(A[k] - B[k]).max() <= tol * scale, k
    se, sn = np.full(500, 0.6), np.full(500, 0.8)
    assert np.abs(a.curvature(5.0, lat, lon, se, sn) - b.curvature(5.0, lat, lon, se, sn)
                  ).max() <= tol * float(a.k.max()) ** 2


def test_fast_jonswap_refuses_finite_depth():
    from siku_core.errors import SceneError
    from siku_forcing.waves.spectral_fast import FastJonswap

    p = {k: v.default for k, v in FastJonswap.params.items()}
    with pytest.raises(SceneError, match="deep water only"):
        FastJonswap({**p, "depth": 50.0})._build()


class TestSpectralConformance(conformance.TestForcingSourceConformance):
    """The forcing conformance suite with the spectral field on a grid that covers the
    conformance elements (poles and antimeridian included: 1000 km cells over the whole
    plane of the field's origin)."""

    sources = ("waves", "water_drag", "air_drag")
    fields = ("spectral",)
    field_params = {"spectral": {"x": [-2.1e7, 2.1e7], "y": [-1.01e7, 1.01e7],
                                 "resolution": 1e6}}
