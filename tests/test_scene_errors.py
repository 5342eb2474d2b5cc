"""Every kind of bad input fails with a message naming the file, the key or the element."""
from __future__ import annotations

import types
import warnings

import h5py
import numpy as np
import pytest

from siku_core import (
    DataError,
    GeometryError,
    NonFiniteError,
    Param,
    PluginError,
    SceneError,
    StabilityError,
    hookimpl,
)
from siku_core.interfaces import ForcingSource
from siku_core.plugins import register_module, unregister_module
from siku_core.scene.scene_file import load_scene
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text

BASE = scene_text([(-150.0, 75.0), (-149.0, 75.0)], dt=60.0, duration=600.0)


def write(tmp_path, text: str, name: str = "scene.toml") -> str:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return str(path)


def scene_error(tmp_path, text: str, exc: type = SceneError) -> str:
    """Load and build the scene; return the message of the expected error."""
    path = write(tmp_path, text)
    with pytest.raises(exc) as ei:
        Simulation(path, out=False)
    msg = str(ei.value)
    assert path in msg, f"message does not name the file: {msg}"
    return msg


# ---------------------------------------------------------------------------- TOML and keys
def test_malformed_toml_names_the_file_and_line(tmp_path):
    msg = scene_error(tmp_path, BASE + "\n[output\nfile = 'x.h5'\n")
    assert "TOML syntax error" in msg and "line" in msg


def test_unknown_key_lists_the_allowed_keys(tmp_path):
    msg = scene_error(tmp_path, BASE.replace("dt = 60.0", "dt = 60.0\ntimestep = 30"))
    assert "unknown key 'time.timestep'" in msg
    assert "allowed keys here: dt, duration, end, start" in msg


def test_unknown_top_level_table_lists_the_tables(tmp_path):
    msg = scene_error(tmp_path, BASE + "\n[wind]\nu = 10\n")
    assert "unknown key 'wind'" in msg
    for table in ("elements", "forcing", "integrator", "output", "planet", "run", "time"):
        assert table in msg


def test_unknown_component_parameter_lists_its_parameters(tmp_path):
    msg = scene_error(tmp_path, BASE + '\n[[forcing]]\nsource = "water_drag"\n'
                                       "params = { Cw = 0.005 }\n")
    assert "[forcing[0]]" in msg and "(water_drag)" in msg
    assert "unknown key 'Cw'; allowed keys: C, max_relative_speed, rho, spin_drag" in msg


def test_wrong_type_names_the_key_and_value(tmp_path):
    msg = scene_error(tmp_path, BASE.replace("[elements]", '[elements]\nthickness = "thick"'))
    assert "key 'elements.thickness' = 'thick': input should be a valid number" in msg


def test_wrong_type_of_a_component_parameter_gives_the_allowed_type(tmp_path):
    msg = scene_error(tmp_path, BASE + '\n[[forcing]]\nsource = "water_drag"\n'
                                       'params = { spin_drag = "yes" }\n')
    assert "key 'spin_drag' = 'yes'" in msg and "allowed: bool" in msg


def test_out_of_range_value_gives_the_allowed_range(tmp_path):
    msg = scene_error(tmp_path, BASE + "\n[materials.ice]\npoisson_ratio = 0.7\n")
    assert "key 'materials.ice.poisson_ratio' = 0.7" in msg
    assert "allowed range: 0 <= poisson_ratio < 0.5" in msg


def test_out_of_range_duration_gives_range_and_unit(tmp_path):
    msg = scene_error(tmp_path, BASE.replace("dt = 60.0", "dt = -60.0"))
    assert "key 'time.dt' = -60.0" in msg and "allowed range: 0 < dt [s]" in msg


def test_out_of_range_component_parameter_gives_range_and_unit(tmp_path):
    msg = scene_error(tmp_path, BASE + '\n[[forcing]]\nsource = "air_drag"\n'
                      'params = { turning_angle = 120.0 }\nfield = { type = "uniform" }\n')
    assert "key 'turning_angle' = 120.0" in msg
    assert "allowed: float in [-90, 90] deg" in msg


def test_unreadable_duration_says_how_to_write_one(tmp_path):
    msg = scene_error(tmp_path, BASE.replace("duration = 600.0", 'duration = "2 fortnights"'))
    assert "time.duration" in msg and "s, min, h, d" in msg


# ---------------------------------------------------------------------------- names
def test_unknown_integrator_lists_the_known_ones(tmp_path):
    msg = scene_error(tmp_path, BASE.replace('name = "siku2"', 'name = "leapfrog"'), PluginError)
    assert "[integrator]: unknown integrator 'leapfrog'; known: " in msg
    assert "rk4" in msg and "siku2" in msg


def test_unknown_field_type_lists_the_known_ones(tmp_path):
    msg = scene_error(tmp_path, BASE + '\n[[forcing]]\nsource = "air_drag"\n'
                                       'field = { type = "hurricane" }\n', PluginError)
    assert "[forcing[0].field]: unknown field 'hurricane'; known: " in msg
    assert "cyclone" in msg and "uniform" in msg


def test_drag_without_its_field_and_field_on_a_non_drag_are_errors(tmp_path):
    msg = scene_error(tmp_path, BASE + '\n[[forcing]]\nsource = "air_drag"\n')
    assert "[forcing[0]]: forcing source 'air_drag' needs a 'field' table" in msg
    msg = scene_error(tmp_path, BASE + '\n[[forcing]]\nsource = "coriolis"\n'
                                       'field = { type = "uniform" }\n')
    assert "[forcing[0]]: forcing source 'coriolis' takes no 'field' table" in msg


# ---------------------------------------------------------------------------- files
def test_missing_scene_file_is_named(tmp_path):
    path = tmp_path / "nowhere.toml"
    with pytest.raises(SceneError, match="nowhere.toml: scene file not found"):
        load_scene(path)


def test_missing_restart_file_is_named(tmp_path):
    path = write(tmp_path, BASE)
    with pytest.raises(DataError, match="gone.h5: restart file not found"):
        Simulation(path, out=False, restart=tmp_path / "gone.h5")


def test_restart_with_a_different_element_count_is_refused(tmp_path):
    first = write(tmp_path, BASE, "two.toml")
    Simulation(first, out=tmp_path / "two.h5", progress=False).run(steps=2)
    three = write(tmp_path, scene_text([(-150.0, 75.0), (-149.0, 75.0), (-148.0, 75.0)]),
                  "three.toml")
    with pytest.raises(DataError) as ei:
        Simulation(three, out=False, restart=tmp_path / "two.h5")
    assert "two.h5: restart has 2 elements but the scene builds 3" in str(ei.value)


# ---------------------------------------------------------------------------- geometry
def test_non_convex_polygon_names_the_element(tmp_path):
    ell = [[0, 70], [0.2, 70], [0.2, 70.1], [0.1, 70.1], [0.1, 70.2], [0, 70.2]]
    msg = scene_error(tmp_path, scene_text([(10.0, 70.0), ell]), GeometryError)
    assert "element 1" in msg and "[elements.polygon[1]]" in msg
    assert "polygon is not convex" in msg


@pytest.mark.parametrize("vertices, problem", [
    ([[0, 70], [0.1, 70], [0.1, 70], [0.1, 70.1], [0, 70.1]], "vertices 1 and 2 coincide"),
    ([[0, 70], [0, 70.5], [0, 71]], "zero area"),
], ids=["repeated-vertex", "collinear"])
def test_degenerate_polygon_names_the_element(tmp_path, vertices, problem):
    msg = scene_error(tmp_path, scene_text([vertices, (10.0, 70.0)]), GeometryError)
    assert "element 0" in msg and "[elements.polygon[0]]" in msg
    assert "degenerate polygon" in msg and problem in msg


# ---------------------------------------------------------------------------- stability
UNSTABLE = scene_text([(-150.0, 75.0)], dt="10min", duration="1h",
                      forcing=[{"source": "water_drag"}])


def test_dt_above_the_stability_limit_is_refused_naming_the_component(tmp_path):
    msg = scene_error(tmp_path, UNSTABLE, StabilityError)
    assert "dt = 600 s is above the safe step" in msg
    assert "set by 'water_drag'" in msg and "element 0" in msg
    assert "allow_unstable_dt = true" in msg


def test_allow_unstable_dt_turns_the_refusal_into_a_warning(tmp_path):
    path = write(tmp_path, UNSTABLE + "\n[run]\nallow_unstable_dt = true\n")
    with pytest.warns(UserWarning, match="set by 'water_drag'.*continuing because"):
        sim = Simulation(path, out=False, progress=False)
    sim.run(steps=1)


# ---------------------------------------------------------------------------- NaN guard
class NaNAfter(ForcingSource):
    """Adds NaN to one element's northward force from time ``after`` on (a broken source)."""

    name = "nan_after"
    params = {
        "after": Param(0.0, "s", "time from which the force is NaN", min=0.0),
        "element": Param(0, "1", "the element that gets the NaN", type=int, min=0),
    }

    def add(self, t, q, V, w, F, T):
        if t >= self.p["after"]:
            F[self.p["element"], 1] += np.nan


@pytest.fixture
def nan_plugin():
    mod = types.ModuleType("nan_test_plugin")
    mod.siku_register_forcing_sources = hookimpl(lambda: [NaNAfter])
    register_module(mod)
    yield
    unregister_module(mod)


def nan_scene(after: float) -> str:
    return scene_text(
        [(-150.0, 75.0), {"center": (-149.0, 75.0), "velocity": (0.1, 0.0)}, (-148.0, 75.0)],
        dt=60.0, duration=600.0, output={"every": 240.0},
        forcing=[{"source": "coriolis"},
                 {"source": "nan_after", "params": {"after": after, "element": 1}}])


def test_nan_in_forcing_stops_the_run_naming_step_element_and_quantity(tmp_path, nan_plugin):
    """The guard stops at the first non-finite value and goes back to the last snapshot (step
    4 of the 4-step schedule): the file ends there, with only finite rows of real data."""
    path = write(tmp_path, nan_scene(after=300.0))
    out = tmp_path / "nan.h5"
    sim = Simulation(path, out=out, progress=False)
    with pytest.raises(NonFiniteError) as ei:
        sim.run()
    msg = str(ei.value)
    assert "non-finite F of element 1 at step 6" in msg
    assert f"{out} holds the snapshots to the last good state (step 4, t = 240 s)" in msg

    reference = Simulation(write(tmp_path, nan_scene(after=1e9), "ref.toml"), out=False,
                           progress=False).run(steps=4)
    with h5py.File(out, "r") as f:  # closed, readable, ends with the last good state
        assert f["states/step"][:].tolist() == [0, 4]
        for k in ("q", "V", "w"):
            last = f[f"states/{k}"][-1]
            assert np.isfinite(last).all()
            assert np.array_equal(last, getattr(reference.state, k)), k
    assert sim.step_index == 4 and np.isfinite(sim.state.V).all()
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(sim.state, k), getattr(reference.state, k)), k


def test_nan_guard_without_output_still_names_step_element_and_quantity(tmp_path, nan_plugin):
    sim = Simulation(write(tmp_path, nan_scene(after=0.0)), out=False, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NonFiniteError, match="non-finite F of element 1 at step 1"):
            sim.run()
