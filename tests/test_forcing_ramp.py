"""Forcing ramps (``[[forcing]] ramp``, siku_core.run.ramp): a source's force grows from zero to
full over the ramp time with a stated shape, times its unramped force to round-off; a run
restarted inside the ramp continues it bit for bit; without a ramp nothing changes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.errors import SceneError
from siku_core.run.ramp import ramp_factor
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_io.output.results import last_snapshot

DT = 60.0
RAMP = 600.0  # s: ten steps
ELEMENTS = [
    {"center": (-150.0, 75.0), "velocity": (0.10, 0.05), "spin": 1e-5},
    {"center": (-147.5, 74.2), "velocity": (-0.05, 0.12)},
]


def _forcing(ramp=None, shape=None):
    air = {"source": "air_drag", "field": {"type": "cyclone", "params": {
        "lat": 74.5, "lon": -149.0, "vmax": 18.0, "rmax": 150e3, "move_east": 6.0}}}
    if ramp is not None:
        air["ramp"] = ramp
    if shape is not None:
        air["ramp_shape"] = shape
    return [air, {"source": "water_drag"}, {"source": "coriolis"}]


def _sim(steps, ramp=None, shape=None, **kw):
    text = scene_text(ELEMENTS, forcing=_forcing(ramp, shape), dt=DT, duration=steps * DT,
                      **kw)
    return text


def test_the_ramp_functions_are_the_stated_ones():
    for x in (0.0, 0.1, 0.25, 0.5, 0.9):
        t = x * RAMP
        assert ramp_factor(t, RAMP, "cosine") == pytest.approx(
            math.sin(0.5 * math.pi * x) ** 2, abs=1e-15)
        assert ramp_factor(t, RAMP, "linear") == pytest.approx(x, abs=1e-15)
    for shape in ("cosine", "linear"):
        assert ramp_factor(RAMP, RAMP, shape) == 1.0
        assert ramp_factor(3 * RAMP, RAMP, shape) == 1.0
        assert ramp_factor(0.0, RAMP, shape) == 0.0


@pytest.mark.parametrize("shape", ["cosine", "linear"])
def test_the_ramped_force_is_the_ramp_times_the_full_force(shape):
    """At every time inside the ramp, the ramped scene's forcing is ``r(t)`` times the unramped
    scene's, to one rounding of the product (the other sources add unramped)."""
    ramped = Simulation(scene_from_text(_sim(20, "10min", shape)), out=False, progress=False)
    full = Simulation(scene_from_text(_sim(20)), out=False, progress=False)
    air_only = Simulation(scene_from_text(scene_text(
        ELEMENTS, forcing=_forcing()[:1], dt=DT, duration=20 * DT)), out=False, progress=False)
    st = full.state
    n = st.n
    for t in (0.0, 30.0, 150.0, 300.0, 599.0, 600.0, 900.0):
        r = ramp_factor(t, RAMP, shape)
        out = {}
        for name, sim in (("ramped", ramped), ("full", full), ("air", air_only)):
            F, T = np.zeros((n, 2)), np.zeros(n)
            sim.compute_forces(t, st.q, st.V, st.w, F, T)
            out[name] = (F, T)
        # the others' forces are the full run's minus its wind
        other_F = out["full"][0] - out["air"][0]
        other_T = out["full"][1] - out["air"][1]
        wind_F = out["ramped"][0] - other_F
        wind_T = out["ramped"][1] - other_T
        # the sums above round at the scale of the largest force: a few eps of it
        eps = np.finfo(float).eps
        tol_F = 8 * eps * np.abs(out["full"][0]).max()
        tol_T = 8 * eps * np.abs(out["full"][1]).max()
        np.testing.assert_allclose(wind_F, r * out["air"][0], rtol=0, atol=tol_F)
        np.testing.assert_allclose(wind_T, r * out["air"][1], rtol=0, atol=tol_T)
        if r == 1.0:  # past the ramp: the same additions in the same order, bit for bit
            assert np.array_equal(out["ramped"][0], out["full"][0])


def test_restart_inside_the_ramp_is_bit_for_bit(tmp_path):
    """Twelve steps with a 10-min (10-step) ramp in one go, or six, a restart, and six."""
    path = tmp_path / "scene.toml"
    path.write_text(_sim(12, "10min", output={"file": "run.h5", "every": 6 * DT}))
    whole = Simulation(str(path), out=tmp_path / "whole.h5", progress=False).run()
    part = tmp_path / "part.h5"
    Simulation(str(path), out=part, progress=False).run(steps=6)
    second = Simulation(str(path), out=part, restart=part, progress=False)
    assert second.step_index == 6 and ramp_factor(6 * DT, RAMP) < 1.0
    second.run()
    a, b = last_snapshot(part), last_snapshot(tmp_path / "whole.h5")
    assert a["step"] == b["step"] == 12
    for k in ("q", "V", "w"):
        assert np.array_equal(a[k], b[k]), k
        assert np.array_equal(getattr(second.state, k), getattr(whole.state, k)), k


def test_a_ramp_changes_the_run():
    ramped = Simulation(scene_from_text(_sim(12, "10min")), out=False, progress=False).run()
    full = Simulation(scene_from_text(_sim(12)), out=False, progress=False).run()
    assert not np.array_equal(ramped.state.V, full.state.V)


@pytest.mark.parametrize("bad", ['"-1h"', '"0s"', '"soon"'])
def test_a_bad_ramp_is_refused_naming_the_key(bad):
    text = _sim(2, "10min").replace('ramp = "10min"', f"ramp = {bad}")
    with pytest.raises(SceneError, match=r"ramp"):
        scene_from_text(text)


def test_an_unknown_ramp_shape_is_refused():
    with pytest.raises(SceneError, match=r"ramp_shape"):
        scene_from_text(_sim(2, "10min", "quadratic"))
