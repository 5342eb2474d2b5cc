"""Diagnostics: the forces on held elements, diagnostics reported by components, the catalogue
of names and units, and output files that depend only on the scene (byte for byte)."""
from __future__ import annotations

import types

import h5py
import numpy as np
import pytest

from siku_core import Simulation, hookimpl
from siku_core.interfaces import ForcingSource
from siku_core.diagnostics import DIAGNOSTICS, catalogue
from siku_core.scene.scene_file import scene_from_text
from siku_core.state import STATIC, STEADY

RHO_A, C_A, U = 1.3, 0.0016, 10.0

SCENE = f"""
[time]
duration = "2min"
dt = 10.0
[[elements.polygon]]
vertices = [[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]]
flag = "static"
[[elements.polygon]]
vertices = [[0.5, 0.0], [0.7, 0.0], [0.7, 0.2], [0.5, 0.2]]
flag = "steady"
velocity = [0.5, 0.0]
[[elements.polygon]]
vertices = [[1.0, 0.0], [1.1, 0.0], [1.1, 0.1], [1.0, 0.1]]
[[forcing]]
source = "air_drag"
params = {{ C = {C_A}, rho = {RHO_A} }}
field = {{ type = "uniform", params = {{ u = {U}, v = 0.0 }} }}
"""


def test_forces_on_static_and_steady_elements_are_the_wind_stress_times_area():
    """Quadratic air drag without the ice velocity (``relative = false``): each held element
    feels ``rho_a C_a |U| U S`` (eq. 19) along the wind, east. The static element's frame is
    east-north: the force is east to round-off. The steady one has moved 60 m east along its
    great circle, so its frame has turned a little from local east: the magnitude is exact, the
    direction within 1e-4 rad."""
    sim = Simulation(scene_from_text(SCENE), out=False, progress=False)
    sim.run()
    d = sim.diagnostics()
    st = sim.state
    for name, code in (("static", STATIC), ("steady", STEADY)):
        want = RHO_A * C_A * U * U * float(st.area[st.flags == code].sum())
        east, north = d[f"{name}_force_east"], d[f"{name}_force_north"]
        assert np.hypot(east, north) == pytest.approx(want, rel=1e-12)
        assert abs(north) <= (1e-12 if name == "static" else 1e-4) * want
    assert set(DIAGNOSTICS) >= {k for k in d if not k.startswith("joints_broken_")}


def test_scenes_without_held_elements_report_no_held_forces():
    text = SCENE.replace('flag = "static"', 'flag = "free"').replace('flag = "steady"',
                                                                      'flag = "free"')
    d = Simulation(scene_from_text(text), out=False, progress=False).diagnostics()
    assert not any(k.endswith(("_force_east", "_force_north")) for k in d)


class Push(ForcingSource):
    """A constant eastward force on every free element."""

    name = "constant_push"
    diagnostic_units = {"push_total": "N"}

    def setup(self, ctx):
        self.st = ctx.state

    def add(self, t, q, V, w, F, T):
        F[self.st.flags == 0, 0] += 2.5

    def diagnostics(self, ctx):
        return {"push_total": 2.5 * float(np.sum(self.st.flags == 0))}


@pytest.fixture
def push(siku_register):
    mod = types.ModuleType("push_pkg")

    def siku_register_forcing_sources():
        return [Push]

    mod.siku_register_forcing_sources = hookimpl(siku_register_forcing_sources)
    siku_register(mod)


def test_a_component_reports_diagnostics_with_units(push, tmp_path):
    assert catalogue()["push_total"][0] == "N"
    text = SCENE + '\n[[forcing]]\nsource = "constant_push"\n'
    out = tmp_path / "push.h5"
    Simulation(scene_from_text(text), out=out, progress=False).run()
    with h5py.File(out, "r") as f:
        ds = f["diagnostics/push_total"]
        assert ds.attrs["units"] == "N"
        assert np.all(ds[:] == 2.5)  # one free element
        assert f["diagnostics/static_force_east"].attrs["units"] == "N"
        assert f["diagnostics/kinetic_energy"].attrs["units"] == "J"


def test_same_scene_same_file_byte_for_byte(tmp_path):
    """An output file depends only on the scene, its seed and the versions: no time or place
    of writing is recorded, so two runs write the same bytes."""
    a, b = tmp_path / "a.h5", tmp_path / "sub" / "b.h5"
    for out in (a, b):
        Simulation(scene_from_text(SCENE), out=out, progress=False).run()
    assert a.read_bytes() == b.read_bytes()
