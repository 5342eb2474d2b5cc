"""Declared per-element fields and a changing thickness in every output: HDF5 and the NetCDF
writer, the xarray engine (with units), ``siku grid`` (sum and mean as declared),
``siku export`` (CF checker, no high-priority failures), and restarts bit for bit."""
from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest
import xarray as xr

from siku_core.run.cli import main
from siku_core.testing import scene_text
from siku_core.testing.contact_cases import square_pack

PROC = ('[[process]]\nname = "thermodynamics"\nevery = 40.0\nparams = { surface_temperature '
        '= -30.0, ocean_heat_flux = 2.0 }\n\n[[process]]\nname = "refreeze"\n'
        'params = { freeze_time = 8.0 }\n')


def write(tmp_path, out="run.h5", writer="hdf5", steps=400):
    text = scene_text([], packs=[square_pack(0.0, 80.0, 4, 3, size=2000.0)], dt=0.4,
                      duration=steps * 0.4, thickness=0.5, start=dt.datetime(2001, 1, 1),
                      extra=('[contact]\nlaw = "distributed_spring"\n\n' + PROC +
                             f'\n[output]\nfile = "{out}"\nwriter = "{writer}"\n'
                             'every = 40.0\n'))
    path = tmp_path / f"{writer}.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("proc_out")
    assert main(["run", str(write(d)), "--out", str(d / "run.h5")]) == 0
    assert main(["run", str(write(d, "run.nc", "netcdf")), "--out", str(d / "run.nc")]) == 0
    return d


def test_xarray_shows_declared_fields_and_the_changing_thickness_with_units(run):
    ds = xr.open_dataset(run / "run.h5", engine="siku")
    assert ds["grown_volume"].dims == ("time", "element")
    assert ds["grown_volume"].attrs["units"] == "m3"
    assert ds["grown_volume"].attrs["grid"] == "sum"
    assert ds["growth_rate"].attrs["units"] == "m s-1"
    assert ds["thickness"].dims == ("time", "element")
    assert ds["thickness"].attrs["units"] == "m"
    h = ds["thickness"].values
    assert (np.diff(h, axis=0) > 0).all()  # -30 °C: every element thickens at every snapshot
    # the volume grown is the thickness change times the area
    grown = (h[-1] - h[0]) * ds["area"].values
    np.testing.assert_allclose(ds["grown_volume"].values[-1], grown, rtol=1e-12)
    assert ds["mass"].dims == ("time", "element")
    np.testing.assert_allclose(ds["mass"].values, 910.0 * h * ds["area"].values, rtol=1e-15)


def test_the_netcdf_writer_holds_the_same_fields(run):
    from test_output_formats import cf_errors

    nc = xr.open_dataset(run / "run.nc")
    h5 = xr.open_dataset(run / "run.h5", engine="siku")
    for k in ("grown_volume", "growth_rate", "thickness", "mass"):
        assert np.array_equal(nc[k].values, h5[k].values), k
        assert nc[k].attrs["units"] == h5[k].attrs["units"]
    pytest.importorskip("compliance_checker")
    assert cf_errors(run / "run.nc") == []


def test_siku_export_of_a_run_with_processes_passes_the_cf_checker(run):
    pytest.importorskip("compliance_checker")
    from test_output_formats import cf_errors

    out = run / "export.nc"
    assert main(["export", str(run / "run.h5"), "--out", str(out)]) == 0
    assert cf_errors(out) == []
    nc = xr.open_dataset(out)
    h5 = xr.open_dataset(run / "run.h5", engine="siku")
    assert nc["thickness"].attrs["standard_name"] == "sea_ice_thickness"
    assert np.array_equal(nc["thickness"].values, h5["thickness"].values.T)
    assert np.array_equal(nc["grown_volume"].values, h5["grown_volume"].values.T)


def test_siku_grid_grids_declared_fields_as_declared(run):
    out = run / "grid.nc"
    assert main(["grid", str(run / "run.h5"), "--lon", "-0.5", "0.6", "--lat", "79.9",
                 "80.2", "--resolution", "0.1", "--out", str(out)]) == 0
    g = xr.open_dataset(out)
    h5 = xr.open_dataset(run / "run.h5", engine="siku")
    assert g["grown_volume"].attrs["units"] == "m3"
    # a sum: the grid holds all of the volume grown (the pack lies inside the grid)
    for t in range(g.sizes["time"]):
        assert float(g["grown_volume"][t].sum()) == pytest.approx(
            math.fsum(h5["grown_volume"].values[t]), rel=1e-12)
    # a mean: a uniform growth rate is that rate in every cell with ice
    rate = g["growth_rate"].values[-1]
    ice = g["concentration"].values[-1] > 0
    np.testing.assert_allclose(rate[ice], h5["growth_rate"].values[-1].mean(), rtol=1e-9)
    # the gridded thickness is that of each snapshot: the volume per cell grows
    vol = (g["thickness"] * g["cell_area"]).sum(("y", "x")) if "y" in g.dims else \
        (g["thickness"] * g["cell_area"]).sum([d for d in g["thickness"].dims if d != "time"])
    assert (np.diff(vol.values) > 0).all()


def test_restart_with_processes_is_bit_for_bit(tmp_path):
    whole = tmp_path / "whole.h5"
    part = tmp_path / "part.h5"
    scene = write(tmp_path, steps=400)
    assert main(["run", str(scene), "--out", str(whole)]) == 0
    (tmp_path / "short").mkdir()
    short = write(tmp_path / "short", steps=200)  # the first half, then the whole scene
    assert main(["run", str(short), "--out", str(part)]) == 0
    assert main(["run", str(scene), "--out", str(part), "--restart", str(part)]) == 0
    a = xr.open_dataset(whole, engine="siku")
    b = xr.open_dataset(part, engine="siku")
    for k in ("q", "u", "v", "thickness", "grown_volume", "growth_rate", "flags"):
        assert np.array_equal(a[k].values, b[k].values), k
