"""The Zarr output (``siku_io.output.zarr_store``): the writer ``[output] writer = "zarr"`` and
``siku export --to zarr``.

* A Zarr store holds what the HDF5 file of the same run holds: every array, value for value,
  with the same attributes, and the same dataset through the xarray engine; ``xr.open_zarr``
  reads its groups as they are.
* A restart from a Zarr store continues it bit for bit with an uninterrupted run.
* ``--overwrite`` replaces only a store the writer made; a run stopped before its first
  snapshot leaves nothing.
* ``kill -9`` mid-run leaves a store that opens with complete snapshots only, equal to the
  uninterrupted run's, and restarts to the uninterrupted run's end, bit for bit (slow).
* ``siku export --to zarr`` writes the CF trajectory layout of the NetCDF export.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr
import zarr

from siku_core.run.cli import main
from siku_core.errors import DataError
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_io.output.results import last_snapshot

ROOT = Path(__file__).resolve().parents[1]
#: root attributes that depend on the scene's text (which names the writer)
SCENE = ("scene_file", "scene_sha256")
N = 6
DT = 60.0
ELEMENTS = [
    {"center": (-150.0, 75.0), "velocity": (0.10, 0.05), "spin": 1e-5},
    {"center": (-147.5, 74.2), "velocity": (-0.05, 0.12)},
    {"center": (-152.0, 76.0), "spin": -2e-5},
]
FORCING = [
    {"source": "air_drag", "field": {"type": "cyclone", "params": {
        "lat": 74.5, "lon": -149.0, "vmax": 18.0, "rmax": 150e3, "move_east": 6.0}}},
    {"source": "water_drag"},
    {"source": "coriolis"},
]


def write_scene(path: Path, writer: str, out: str, steps: int = 2 * N, every: int = N) -> str:
    path.write_text(scene_text(ELEMENTS, forcing=FORCING, dt=DT, duration=steps * DT,
                               start=None, output={"file": out, "every": every * DT,
                                                   "writer": writer}), encoding="utf-8")
    return str(path)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same tiny scene written by the HDF5 and the Zarr writer (12 steps, 3 snapshots)."""
    d = tmp_path_factory.mktemp("zarr")
    for writer, out in (("hdf5", "run.h5"), ("zarr", "run.zarr")):
        Simulation(write_scene(d / f"{writer}.toml", writer, str(d / out)),
                   progress=False).run()
    return d


def h5_leaves(f) -> dict:
    out = {}
    f.visititems(lambda name, obj: out.__setitem__(name, obj)
                 if isinstance(obj, h5py.Dataset) else None)
    return out


def test_a_zarr_output_round_trips_equal_to_the_hdf5_output(runs):
    store = zarr.open_consolidated(str(runs / "run.zarr"), mode="r")
    with h5py.File(runs / "run.h5", "r") as f:
        for key, value in f.attrs.items():  # the same root attributes (but the scene's,
            if key not in SCENE:            # which names the writer)
                assert np.array_equal(store.attrs[key], value), key
        comps = [json.loads(text) for text in (store.attrs["components"], f["components"][()])]
        assert [c for c in comps[0] if c["kind"] != "writer"] == [
            c for c in comps[1] if c["kind"] != "writer"]
        record = [json.loads(text) for text in (store.attrs["run_record"], f["run_record"][()])]
        for r in record:
            assert r["scene"].pop("output")["writer"] in ("zarr", "hdf5")
        assert record[0] == record[1]
        assert dict(store["plugins"].attrs) == dict(f["plugins"].attrs)
        arrays = {k: ds for k, ds in h5_leaves(f).items()
                  if k not in ("scene", "run_record", "components")}
        assert arrays, "the HDF5 output holds arrays"
        for path, ds in arrays.items():  # every array: the same values, times and attributes
            z = store[path]
            assert z.shape == ds.shape and np.dtype(z.dtype) == ds.dtype, path
            assert np.array_equal(z[...], ds[...], equal_nan=ds.dtype.kind == "f"), path
            for key, value in ds.attrs.items():
                assert np.array_equal(z.attrs[key], value), (path, key)
        assert store["states/step"][:].tolist() == [0, N, 2 * N]
        assert np.array_equal(store["states/time"][:], f["states/time"][:])
    for group in (None, "diagnostics", "breaks"):  # the xarray engine: the same dataset
        a = xr.open_dataset(runs / "run.h5", engine="siku", group=group)
        b = xr.open_dataset(runs / "run.zarr", engine="siku", group=group)
        for ds in (a, b):
            for key in ("source", "scene", *SCENE):
                ds.attrs.pop(key, None)
        xr.testing.assert_identical(a, b)
    states = xr.open_zarr(runs / "run.zarr", group="states")  # plain xarray, no siku engine
    assert states["q"].dims == ("time", "element", "quaternion")
    assert states["w"].attrs["units"] == "rad s-1"
    with h5py.File(runs / "run.h5", "r") as f:
        assert np.array_equal(states["time"].values, f["states/time"][:])
        assert np.array_equal(states["lat"].values, f["states/lat"][:])


def test_siku_info_summarises_a_zarr_output_as_the_hdf5_one(runs, capsys):
    assert main(["info", str(runs / "run.h5"), str(runs / "run.zarr")]) == 0
    text = capsys.readouterr().out.replace("run.zarr", "run.h5").split("\n\n")
    assert len(text) == 2 and text[0].strip() == text[1].strip()
    assert "steps     12 of 60 s" in text[0]


def test_siku_export_to_zarr_writes_the_netcdf_exports_layout(runs, capsys):
    assert main(["export", str(runs / "run.h5"), "--to", "zarr",
                 "--out", str(runs / "run_cf.zarr")]) == 0
    assert main(["export", str(runs / "run.h5"), "--out", str(runs / "run_cf.nc")]) == 0
    z = xr.open_zarr(runs / "run_cf.zarr")
    nc = xr.open_dataset(runs / "run_cf.nc")
    xr.testing.assert_identical(z.load(), nc.load())
    assert z["element"].attrs["cf_role"] == "trajectory_id"
    assert main(["export", str(runs / "run.zarr"), "--to", "zarr",  # a Zarr output exports
                 "--out", str(runs / "from_zarr.zarr")]) == 0
    xr.testing.assert_equal(xr.open_zarr(runs / "from_zarr.zarr").load(), nc.load())
    capsys.readouterr()
    assert main(["export", str(runs / "run.h5"), "--to", "zarr",  # never over it unasked
                 "--out", str(runs / "run_cf.zarr")]) == 2
    assert "exists" in capsys.readouterr().err


def test_a_restart_from_a_zarr_output_continues_it_bit_for_bit(tmp_path):
    scene = write_scene(tmp_path / "scene.toml", "zarr", str(tmp_path / "whole.zarr"))
    whole = Simulation(scene, progress=False).run()
    part = tmp_path / "part.zarr"
    first = Simulation(scene, out=part, progress=False).run(steps=N)
    assert first.step_index == N
    assert zarr.open_consolidated(str(part))["states/step"][:].tolist() == [0, N]
    second = Simulation(scene, out=part, restart=part, progress=False)
    assert second.restarted_from == N
    second.run()
    a, b = last_snapshot(part), last_snapshot(tmp_path / "whole.zarr")
    assert a["step"] == b["step"] == 2 * N
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(second.state, k), getattr(whole.state, k)), k
        assert np.array_equal(a[k], b[k]), k
    za = zarr.open_consolidated(str(part))
    zb = zarr.open_consolidated(str(tmp_path / "whole.zarr"))
    assert za["states/step"][:].tolist() == [0, N, 2 * N]
    for path in ("states/q", "states/V", "states/w", "states/time", "diagnostics/step",
                 "diagnostics/kinetic_energy"):
        if path in zb:
            assert np.array_equal(za[path][:], zb[path][:]), path
    assert not list(tmp_path.glob(".*partial")), "no partial store is left"


def test_overwrite_replaces_only_a_store_of_the_writer(tmp_path, capsys):
    out = tmp_path / "run.zarr"
    scene = write_scene(tmp_path / "scene.toml", "zarr", str(out), steps=N)
    Simulation(scene, progress=False).run()
    with pytest.raises(DataError, match="exists"):
        Simulation(scene, progress=False)
    Simulation(scene, overwrite=True, progress=False).run()  # its own store: replaced
    assert zarr.open_consolidated(str(out))["states/step"][:].tolist() == [0, N]
    mine = tmp_path / "mine.zarr"  # a folder of the user's: never replaced
    mine.mkdir()
    (mine / "notes.txt").write_text("keep", encoding="utf-8")
    with pytest.raises(DataError, match="not an output file siku wrote"):
        Simulation(scene, out=mine, overwrite=True, progress=False)
    assert (mine / "notes.txt").read_text(encoding="utf-8") == "keep"
    # stopped before the first new snapshot (none is written at step 0 of a run of 0 steps):
    # the old store is whole and no partial store is left
    sim = Simulation(scene, overwrite=True, progress=False)
    for w in sim.writers:
        w.open(sim.context)
    for w in sim.writers:
        w.close(sim.context)
    assert zarr.open_consolidated(str(out))["states/step"][:].tolist() == [0, N]
    assert not list(tmp_path.glob(".*partial"))


@pytest.mark.slow
def test_a_killed_zarr_run_leaves_complete_snapshots_and_restarts_bit_for_bit(tmp_path):
    steps = 400
    scene = write_scene(tmp_path / "scene.toml", "zarr", "run.zarr", steps=steps, every=2)
    whole = tmp_path / "whole.zarr"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": "1"}
    cmd = [sys.executable, "-m", "siku_core.run.cli", "run", scene, "--no-progress", "--no-plots"]
    subprocess.run([*cmd, "--out", str(whole)], env=env, cwd=tmp_path, check=True,
                   capture_output=True)
    ref = zarr.open_consolidated(str(whole))
    killed = 0
    for k in range(3):
        out = tmp_path / f"killed{k}.zarr"
        p = subprocess.Popen([*cmd, "--out", str(out)], env=env, cwd=tmp_path,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 300
        while not out.exists() and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.05 + 0.2 * k)
        killed += p.poll() is None
        p.send_signal(signal.SIGKILL)
        p.wait()
        ds = xr.open_zarr(out, group="states")  # plain xarray: consistent lengths
        steps_on_disk = ds["step"].values
        n = len(steps_on_disk)
        assert n >= 1 and steps_on_disk.tolist() == list(range(0, 2 * n, 2))
        assert np.array_equal(ds["q"].values, ref["states/q"][:n])
        engine = xr.open_dataset(out, engine="siku")
        assert engine.sizes["time"] == n
        if n * 2 - 2 < steps:
            subprocess.run([*cmd, "--restart", str(out)], env=env, cwd=tmp_path, check=True,
                           capture_output=True)
        done = zarr.open_consolidated(str(out))
        for path in ("states/step", "states/q", "states/V", "states/w", "diagnostics/step"):
            assert np.array_equal(done[path][:], ref[path][:]), (k, path)
    assert killed >= 2, "the kills should land during the runs"
