"""Restarts, property-based: a small scene stopped at a random step and continued with
``restart`` (with the same step or another, with or without a further NetCDF writer, which
continues its own file, on one thread or two) gives the time axis of an uninterrupted run in
every file, and its states (bit for bit with the same step; up to the restart with another)."""
from __future__ import annotations

import math
import os
from pathlib import Path

import h5py
import numba
import numpy as np
import xarray as xr
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text

DURATION, EVERY = 1200.0, 240.0
SIZE = 2000.0
DLON = math.degrees(SIZE / 6371000.0) / math.cos(math.radians(80.0))


def text(dt: float, netcdf: str | None) -> str:
    """Three 2 km floes at 80°N, the first two closing at 2 cm/s (they collide), under
    Coriolis; snapshots every 240 s, optionally a NetCDF writer beside the HDF5 file."""
    els = [{"center": (0.0, 80.0), "velocity": (0.01, 0.002), "thickness": 1.0},
           {"center": (1.05 * DLON, 80.0), "velocity": (-0.01, 0.0), "thickness": 1.0},
           {"center": (0.5 * DLON, 80.0 + 1.2 * SIZE / 111195.0), "spin": 1e-5,
            "thickness": 1.0}]
    extra = (f'[[output.extra]]\nwriter = "netcdf"\nfile = "{netcdf}"\n' if netcdf else "")
    return scene_text(els, size=SIZE, dt=dt, duration=DURATION, forcing=[{"source": "coriolis"}],
                      output={"file": "run.h5", "every": EVERY}, extra=extra)


def run(d: Path, dt: float, netcdf: str | None, steps=None, restart=None, force=False):
    cwd = os.getcwd()
    os.chdir(d)
    try:
        sim = Simulation(scene_from_text(text(dt, netcdf), "<restart>"), out=d / "run.h5",
                         restart=restart, force=force, progress=False)
        sim.run(steps=steps)
    finally:
        os.chdir(cwd)
    return sim


REFERENCE: dict[tuple, tuple] = {}


def reference(tmp: Path, dt: float):
    """The uninterrupted run's time axis and states (one per step)."""
    if dt not in REFERENCE:
        d = tmp / f"ref{dt:g}"
        d.mkdir()
        run(d, dt, "ref.nc")
        with h5py.File(d / "run.h5", "r") as f:
            REFERENCE[dt] = (f["states/time"][:], {k: f[f"states/{k}"][:] for k in "qVw"},
                             xr.open_dataset(d / "ref.nc").load())
    return REFERENCE[dt]


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@example(dt=120.0, stop=3, new_dt=60.0, netcdf=True, threads=2)  # a finer step: snapshots
@example(dt=60.0, stop=7, new_dt=None, netcdf=True, threads=1)    # on the model time
@given(dt=st.sampled_from([60.0, 120.0]), stop=st.integers(1, 19), new_dt=st.sampled_from(
    [None, 60.0, 240.0]), netcdf=st.booleans(), threads=st.sampled_from([1, 2]))
def test_a_stopped_run_continues_as_an_uninterrupted_one(tmp_path_factory, dt, stop, new_dt,
                                                         netcdf, threads):
    tmp = tmp_path_factory.mktemp("prop")
    n = int(DURATION / dt)
    stop = min(stop, n - 1)
    t_ref, s_ref, nc_ref = reference(tmp_path_factory.getbasetemp(), dt)
    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        run(tmp, dt, "a.nc" if netcdf else None, steps=stop)
        dt2 = new_dt or dt
        sim = run(tmp, dt2, "a.nc" if netcdf else None, restart=tmp / "run.h5",
                  force=dt2 != dt)
    finally:
        numba.set_num_threads(before)
    kept = int(stop * dt // EVERY)  # the snapshots before the stop: where the run continued
    assert sim.restarted_from == kept * int(EVERY / dt)
    with h5py.File(tmp / "run.h5", "r") as f:
        t = f["states/time"][:]
        states = {k: f[f"states/{k}"][:] for k in "qVw"}
    # the time axis: every snapshot of the scene once, rising, to the scene's end
    assert np.array_equal(t, t_ref), (t, t_ref)
    for k in "qVw":  # the states up to the restart are the file's own, after it the run's
        assert np.array_equal(states[k][:kept + 1], s_ref[k][:kept + 1]), k
        if dt2 == dt:  # bit for bit an uninterrupted run
            assert np.array_equal(states[k], s_ref[k]), k
    # (with another step the states after the restart are another discretisation's: no
    # uninterrupted run has them; their time axis is the scene's, asserted above)
    if netcdf:  # the further writer continues its own file: one file, the same time axis
        a = xr.open_dataset(tmp / "a.nc").load()
        assert np.array_equal(a["time"].values, nc_ref["time"].values)
        for k in a.data_vars:  # and, with the same step, the same values (bit for bit)
            if "time" in a[k].dims:
                n = len(a["time"]) if dt2 == dt else kept + 1
                assert np.array_equal(a[k].values[:n], nc_ref[k].values[:n], equal_nan=True), k
