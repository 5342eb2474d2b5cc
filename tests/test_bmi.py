"""The Basic Model Interface of a siku run (``siku_io.coupling.bmi``) and its exchange grid
(``siku_forcing.gridded.exchange``): the CSDMS bmi-tester suite, set/update/get against the same
forcing
given by a scene, and the momentum handed over through the grid."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from siku_core import SceneError
from siku_core.geometry.quat import centers
from siku_core.run.simulation import Simulation
from siku_io.coupling.bmi import INPUT_NAMES, OUTPUT_NAMES, SikuBmi
from siku_core.geometry.element_geometry import east_north

HERE = Path(__file__).parent
R = 6_371_000.0

BASE = """title = "coupled test"
[time]
duration = 600.0
dt = 10.0
[elements]
thickness = 1.0
[[elements.pack]]
lon = [-0.0135, 0.0135]
lat = [-0.0135, 0.0135]
nx = 3
ny = 3
gap = 0.1
"""
GRID = """[coupling.grid]
kind = "lonlat"
lon = [-0.03, 0.03]
lat = [-0.03, 0.03]
resolution = 0.01
"""
EXCHANGE = """[[forcing]]
source = "exchange"
params = {C = 0.0045}
"""


def scene(tmp_path: Path, text: str, name: str = "coupled.toml") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


@pytest.fixture
def bmi(tmp_path):
    b = SikuBmi()
    b.initialize(scene(tmp_path, BASE + EXCHANGE + GRID))
    yield b
    b.finalize()


def test_bmi_tester_suite_passes(tmp_path):
    """The CSDMS bmi-tester suite, all four stages, on a coupled scene."""
    scene(tmp_path, BASE + EXCHANGE + GRID)
    r = subprocess.run([sys.executable, str(HERE / "bmi_check.py"), "coupled.toml"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    for stage in ("_bootstrap", "stage_1", "stage_2", "stage_3"):
        assert f"bmi-tester {stage}: exit 0" in r.stdout
    assert "failed" not in r.stdout and "error" not in r.stdout.lower()


def test_names_units_and_grid(bmi):
    assert set(INPUT_NAMES) & set(OUTPUT_NAMES) == set()
    assert bmi.get_grid_type(0) == "uniform_rectilinear"
    shape = bmi.get_grid_shape(0, np.zeros(2, int))
    assert shape.tolist() == [6, 6]
    assert bmi.get_grid_spacing(0, np.zeros(2)).tolist() == pytest.approx([0.01, 0.01])
    assert bmi.get_grid_origin(0, np.zeros(2)).tolist() == pytest.approx([-0.025, -0.025])
    assert bmi.get_var_units("sea_ice__volume") == "m3"
    assert bmi.get_end_time() == 600.0 and bmi.get_time_step() == 10.0
    with pytest.raises(KeyError, match="siku has: sea_water_surface__elevation"):
        bmi.get_var_units("no_such__thing")
    with pytest.raises(ValueError, match="36 nodes"):
        bmi.set_value("sea_water_surface__elevation", np.zeros(5))
    with pytest.raises(ValueError, match="an output of siku"):
        bmi.set_value("sea_ice__volume", np.zeros(36))
    with pytest.raises(ValueError, match="finite"):
        bmi.set_value("sea_water_surface__elevation", np.full(36, np.nan))


def test_update_until_lands_on_steps(bmi):
    bmi.update()
    assert bmi.get_current_time() == 10.0
    bmi.update_until(95.0)  # between steps: stops at the earlier one
    assert bmi.get_current_time() == 90.0
    bmi.update_until(10_000.0)
    assert bmi.get_current_time() == bmi.get_end_time()


def test_round_trip_moves_ice_as_the_scene_forcing(tmp_path):
    """Water velocity and wind set through the BMI on every cell move the ice exactly as the
    same velocities given by the scene to ``water_drag`` (same coefficient, no turning, no spin
    drag) and ``air_drag`` (eq. 19 defaults)."""
    u, v, ua, va = 0.3, -0.12, 8.0, 5.0
    ref_text = BASE + f"""[[forcing]]
source = "water_drag"
params = {{C = 0.0045, spin_drag = false}}
field = {{type = "uniform", params = {{u = {u}, v = {v}}}}}
[[forcing]]
source = "air_drag"
field = {{type = "uniform", params = {{u = {ua}, v = {va}}}}}
"""
    ref = Simulation(scene(tmp_path, ref_text, "ref.toml"), out=False, progress=False)
    ref.run(30)
    b = SikuBmi()
    b.initialize(scene(tmp_path, BASE + EXCHANGE + GRID))
    n = b.get_grid_size(0)
    b.set_value("sea_water_flowing__x_component_of_velocity", np.full(n, u))
    b.set_value("atmosphere_bottom_air_flow__x_component_of_velocity", np.full(n, ua))
    b.set_value("atmosphere_bottom_air_flow__y_component_of_velocity", np.full(n, va))
    b.set_value("sea_water_flowing__y_component_of_velocity", np.full(n, v))
    b.update_until(300.0)
    got = b.sim
    # the ice moved (about 4 m/s·min at these speeds) and the same way to round-off
    moved = R * np.linalg.norm(centers(got.state.q) - centers(ref.state.q), axis=1)
    travelled = R * np.linalg.norm(centers(got.state.q) - centers(
        Simulation(scene(tmp_path, ref_text, "ref.toml"), out=False).state.q), axis=1)
    assert travelled.min() > 10.0
    assert moved.max() <= 1e-9 * travelled.max()
    ue, ve = east_north(got.state.q, got.state.V)
    re_, rv = east_north(ref.state.q, ref.state.V)
    np.testing.assert_allclose(ue, re_, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ve, rv, rtol=1e-12, atol=1e-15)
    b.finalize()


def _one_evaluation(b):
    """Forces of the exchange source on the current state, recorded as in a step."""
    sim = b.sim
    ex = b.exchange
    ex.refresh()
    st = sim.state
    F = np.zeros((st.n, 2))
    sim._commit = True
    ex.add(sim.time, st.q, st.V, st.w, F, np.zeros(st.n))
    fe, fn = east_north(st.q, F)  # lonlat grid: its axes are east and north
    return fe, fn, ex.mean_cell_force()


def test_momentum_through_the_grid_is_conserved(bmi):
    """Random elevation, water velocity and stress on every cell, ice moving: the force the
    elements receive sums to the force the cells report, to 1e-12 relative."""
    rng = np.random.default_rng(5)
    n = bmi.get_grid_size(0)
    for name, scale in (("sea_water_surface__elevation", 0.5),
                        ("sea_water_flowing__x_component_of_velocity", 0.4),
                        ("sea_water_flowing__y_component_of_velocity", 0.4),
                        ("sea_ice_bottom_surface__x_component_of_stress", 0.2),
                        ("sea_ice_bottom_surface__y_component_of_stress", 0.2)):
        bmi.set_value(name, rng.normal(0, scale, n))
    bmi.update_until(60.0)  # the ice moves, so the drag sees a relative velocity
    fe, fn, cell = _one_evaluation(bmi)
    total = np.hypot(fe.sum(), fn.sum())
    assert total > 1e3
    assert abs(fe.sum() - cell[0].sum()) <= 1e-12 * total
    assert abs(fn.sum() - cell[1].sum()) <= 1e-12 * total


def test_stress_is_handed_over_cell_by_cell(bmi):
    """A force per area: each cell reports ``tau_c`` times the ice area in it (the area
    fraction the ice reports, times the cell area), to round-off."""
    n = bmi.get_grid_size(0)
    tau = np.linspace(-0.3, 0.5, n)
    bmi.set_value("sea_ice_bottom_surface__x_component_of_stress", tau)
    for name in ("sea_water_flowing__x_component_of_velocity",
                 "sea_water_flowing__y_component_of_velocity"):
        bmi.set_value(name, np.zeros(n))
    bmi.exchange.p["drag"] = False
    fe, fn, cell = _one_evaluation(bmi)
    conc = bmi.get_value("sea_ice__area_fraction", np.zeros(n))
    ice_area = conc * bmi.grid.cell_area.ravel()
    np.testing.assert_allclose(cell[0].ravel(), tau * ice_area, rtol=1e-12,
                               atol=1e-12 * np.abs(tau * ice_area).max())
    assert np.abs(cell[1]).max() == 0.0
    assert fe.sum() == pytest.approx(np.sum(tau * ice_area), rel=1e-12)


def test_elevation_slope_pushes_downhill(bmi):
    """A surface rising eastward by ``s`` per metre: every element gets ``-m g s`` east."""
    s = 2e-5
    lon, lat = bmi.grid.centres_lonlat
    x = R * np.cos(np.radians(lat)) * np.radians(lon)  # east distance in each row
    bmi.set_value("sea_water_surface__elevation", (s * x).ravel())
    bmi.exchange.p["drag"] = False
    fe, fn, _ = _one_evaluation(bmi)
    m = bmi.sim.state.m
    # differences of values ~ s x ~ 0.07 m at 1e-16: the slope to ~1e-12
    np.testing.assert_allclose(fe, -m * 9.81 * s, rtol=1e-11)
    # the rows' cos(lat) differ, so this surface also slopes north by s x tan(lat) / R:
    # at most |lon| |lat| = (0.03°)² = 2.7e-7 of the eastward slope
    assert np.abs(fn).max() <= 2.8e-7 * np.abs(fe).max()


def test_ice_reports_what_the_wave_model_needs(bmi):
    n = bmi.get_grid_size(0)
    eta = np.full(n, 0.2)
    bmi.set_value("sea_water_surface__elevation", eta)
    bmi.set_value("sea_water_flowing__x_component_of_velocity", np.full(n, 0.5))
    bmi.update_until(100.0)
    get = {k: bmi.get_value(k, np.zeros(n)) for k in OUTPUT_NAMES}
    st = bmi.sim.state
    A = bmi.grid.cell_area.ravel()
    # the ice area and volume on the grid are those of the elements (all inside it)
    assert np.sum(get["sea_ice__area_fraction"] * A) == pytest.approx(st.area.sum(), rel=1e-12)
    assert get["sea_ice__volume"].sum() == pytest.approx(np.sum(st.area * st.thickness),
                                                         rel=1e-12)
    ice = get["sea_ice__area_fraction"] > 0
    draft = 910.0 / 1026.0  # h = 1 m
    np.testing.assert_allclose(get["sea_ice_bottom_surface__elevation"][ice], 0.2 - draft,
                               rtol=1e-12)
    np.testing.assert_allclose(get["sea_ice_top_surface__elevation"][ice], 0.2 + 1 - draft,
                               rtol=1e-12)
    np.testing.assert_allclose(get["sea_ice_top_surface__elevation"][~ice], 0.2)
    # pushed east by the water: moving and accelerating east where there is ice
    assert (get["sea_ice__x_component_of_velocity"][ice] > 0).all()
    assert (get["sea_ice__x_component_of_acceleration"][ice] > 0).all()
    assert (get["sea_ice__x_component_of_velocity"][~ice] == 0).all()
    # the mass-weighted mean velocity of the grid is that of the elements
    ue, _ = east_north(st.q, st.V)
    total = np.sum(get["sea_ice__x_component_of_velocity"] * get["sea_ice__volume"])
    assert total == pytest.approx(np.sum(ue * st.area * st.thickness), rel=1e-9)


def test_bad_coupling_scenes(tmp_path):
    b = SikuBmi()
    with pytest.raises(SceneError, match=r"\[coupling.grid\]"):
        b.initialize(scene(tmp_path, BASE + EXCHANGE))
    with pytest.raises(SceneError, match='source = "exchange"'):
        b.initialize(scene(tmp_path, BASE + GRID))
    with pytest.raises(SceneError, match="unknown key"):
        Simulation(scene(tmp_path, BASE + EXCHANGE + "[coupling]\nfoo = 1\n" + GRID), out=False)


def test_cli_rejects_bad_coupling_grid(tmp_path):
    path = scene(tmp_path, BASE + EXCHANGE + GRID.replace("resolution = 0.01",
                                                          "resolution = 0.007"))
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", path, "--out",
                        str(tmp_path / "o.h5")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 2
    assert "[coupling.grid]" in r.stderr and "Traceback" not in r.stderr


def test_17_misuse_raises_exceptions_that_say_what_to_do(tmp_path):
    """Calls before initialize() and after finalize() raise a RuntimeError naming the state
    (they were AttributeErrors); time runs forward only and stops at the end; values, indices
    and destinations of the wrong kind are refused naming the variable, shape and dtype."""
    name = "sea_water_surface__elevation"
    b = SikuBmi()
    for call in (b.update, b.get_current_time, lambda: b.update_until(10.0),
                 lambda: b.get_value("sea_ice__volume", np.zeros(36)),
                 lambda: b.set_value(name, np.zeros(36)), lambda: b.get_grid_size(0)):
        with pytest.raises(RuntimeError, match="not initialized; call initialize"):
            call()
    b.initialize(scene(tmp_path, BASE + EXCHANGE + GRID))
    with pytest.raises(RuntimeError, match="already initialized"):
        b.initialize(scene(tmp_path, BASE + EXCHANGE + GRID))
    b.update_until(50.0)
    with pytest.raises(ValueError, match=r"at t = 50 s and runs forward only"):
        b.update_until(20.0)
    assert b.get_current_time() == 50.0
    bad = [(lambda: b.set_value(name, np.zeros(36) + 1j), "real numbers"),
           (lambda: b.set_value_at_indices(name, np.array([-1]), np.zeros(1)),
            r"indices must lie in \[0, 35\]"),
           (lambda: b.set_value_at_indices(name, np.array([1.5]), np.zeros(1)),
            "indices must be a 1-D integer array"),
           (lambda: b.get_value_at_indices(name, np.zeros(1), np.array([36])),
            r"indices must lie in \[0, 35\]"),
           (lambda: b.get_value("sea_ice__volume", np.zeros(36, dtype=np.int32)),
            r"writable float64 array of shape \(36,\); got a int32"),
           (lambda: b.get_value("sea_ice__volume", np.zeros(35)),
            r"float64 array of shape \(36,\)")]
    before = b.get_value(name, np.zeros(36)).copy()
    for call, msg in bad:
        with pytest.raises(ValueError, match=msg):
            call()
    assert np.array_equal(b.get_value(name, np.zeros(36)), before)
    b.update_until(1e9)
    assert b.get_current_time() == b.get_end_time()
    with pytest.raises(RuntimeError, match="at its end time"):
        b.update()
    assert b.get_current_time() == b.get_end_time()
    b.finalize()
    for call in (b.update, b.get_current_time, lambda: b.get_value(name, np.zeros(36))):
        with pytest.raises(RuntimeError, match="finalized; create a new SikuBmi"):
            call()


SPECTRAL = """[[forcing]]
source = "waves"
[forcing.field]
type = "spectral"
params = { spectrum = "table", frequencies = [0.006, 0.008], energy = [40.0, 20.0], \
x = [-2000.0, 2000.0], y = [-2000.0, 2000.0], resolution = 500.0, attenuation = "meylan2014" }
"""


@pytest.fixture
def wave_bmi(tmp_path):
    b = SikuBmi()
    b.initialize(scene(tmp_path, BASE + EXCHANGE + SPECTRAL + GRID))
    yield b
    b.finalize()


def test_bmi_tester_suite_passes_with_the_spectral_wave_field(tmp_path):
    scene(tmp_path, BASE + EXCHANGE + SPECTRAL + GRID)
    r = subprocess.run([sys.executable, str(HERE / "bmi_check.py"), "coupled.toml"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    assert "failed" not in r.stdout and "error" not in r.stdout.lower()


def test_wave_grids_and_names(wave_bmi, bmi):
    b = wave_bmi
    assert "sea_surface_wave__incident_energy" in b.get_input_var_names()
    assert "sea_ice__wave_energy_attenuation_rate" in b.get_output_var_names()
    assert "sea_surface_wave__incident_energy" not in bmi.get_input_var_names()
    with pytest.raises(KeyError, match="spectral wave field"):
        bmi.get_var_units("sea_surface_wave__incident_energy")
    assert b.get_var_units("sea_ice__wave_energy_attenuation_rate") == "m-1"
    assert b.get_var_units("sea_surface_wave__incident_energy") == "m2"
    g = b.get_var_grid("sea_ice__wave_energy_attenuation_rate")
    assert b.get_grid_shape(g, np.zeros(2, int)).tolist() == [8, 8]
    assert b.get_grid_spacing(g, np.zeros(2)).tolist() == [500.0, 500.0]
    assert b.get_grid_origin(g, np.zeros(2)).tolist() == [-1750.0, -1750.0]
    c = b.get_var_grid("sea_surface_wave__incident_energy")
    assert b.get_grid_rank(c) == 1 and b.get_grid_size(c) == 2
    f = b.get_value("sea_surface_wave__frequency", np.zeros(2))
    assert f.tolist() == pytest.approx([0.006, 0.008], rel=1e-12)
    assert b.get_value("sea_surface_wave__direction", np.zeros(2)).tolist() == [90.0, 90.0]
    with pytest.raises(ValueError, match="negative energy"):
        b.set_value("sea_surface_wave__incident_energy", np.array([1.0, -1.0]))
    with pytest.raises(KeyError, match="unknown grid 3"):
        b.get_grid_rank(3)


def test_the_spectrum_set_through_the_bmi_weights_the_attenuation_it_reads(wave_bmi):
    """Attenuation of the incident sea per cell: 2 k_i C weighted by the energy set, with k_i
    of the Meylan et al. (2014) law at each frequency and C the ice area of the elements whose
    centres lie in the cell over its area."""
    from siku_core.geometry.quat import latlon_of

    b = wave_bmi
    field = b.waves.field
    st = b.sim.state
    lat, lon = latlon_of(st.q)
    x = R * lon  # the field's origin is (0, 0)
    y = R * lat
    cell = np.floor((y + 2000) / 500).astype(int) * 8 + np.floor((x + 2000) / 500).astype(int)
    C = np.minimum(np.bincount(cell, st.area, 64) / 500.0**2, 1.0)
    assert C.max() > 0.5 and (C == 0).sum() > 20
    ki = [float(field.law.rate(f, 1.0, field.h)) for f in (0.006, 0.008)]
    assert ki[1] > 1.2 * ki[0]  # the weights matter
    n = b.get_grid_size(1)
    for E, want in (([1.0, 0.0], ki[0]), ([0.0, 3.0], ki[1]),
                    ([1.0, 1.0], 0.5 * (ki[0] + ki[1]))):
        b.set_value("sea_surface_wave__incident_energy", np.array(E))
        got = b.get_value("sea_ice__wave_energy_attenuation_rate", np.zeros(n))
        np.testing.assert_allclose(got, 2 * want * C, rtol=1e-12, atol=0)


def test_the_incident_energy_set_enters_the_grid(wave_bmi):
    # the open-water column at the west edge holds the incident sea once it has crossed
    # (group velocity 130 m/s at 0.006 Hz: a cell in 4 s; the upwind transport converges to the
    # boundary value geometrically); E = S df = 40 m2/Hz x 0.002 Hz
    b = wave_bmi
    n = b.get_grid_size(1)
    b.set_value_at_indices("sea_surface_wave__incident_energy", np.array([1]), np.array([0.0]))
    b.update_until(300.0)
    hs = b.get_value("sea_surface_wave__significant_height", np.zeros(n)).reshape(8, 8)
    np.testing.assert_allclose(hs[:, 0], 4 * np.sqrt(40.0 * 0.002), rtol=1e-9)
    power = b.get_value("sea_ice__absorbed_wave_power", np.zeros(n)).reshape(8, 8)
    assert (power[:, 0] == 0).all() and power.max() > 0  # absorbed under the ice only
