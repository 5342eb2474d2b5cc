"""The CF-NetCDF export read by a trajectory tool siku did not write: cf-xarray's discrete
sampling geometry support finds one trajectory per element, its times are the snapshots', and
its geometry decoder rebuilds each element's outline as a polygon around the element's centre.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from siku_core.run.simulation import Simulation
from siku_core.scene.scene_file import scene_from_text

cf_xarray = pytest.importorskip("cf_xarray")
xr = pytest.importorskip("xarray")
h5py = pytest.importorskip("h5py")

DATA = Path(__file__).resolve().parents[1] / "siku_core" / "data"
NX, NY, DT, EVERY, STEPS = 3, 2, 60.0, 5, 10
SCENE = f"""\
title = "a small pack in the default scene's winds"
[time]
start = 2001-04-06T00:00:00Z
duration = {STEPS * DT}
dt = {DT}
[elements]
thickness = 1.5
[[elements.pack]]
lon = [-152.0, -151.0]
lat = [72.0, 72.3]
nx = {NX}
ny = {NY}
gap = 0.3
[[forcing]]
source = "air_drag"
field.type = "gridded"
field.params.u_file = "{DATA / 'uwnd.anticyclone.nc'}"
field.params.v_file = "{DATA / 'vwnd.anticyclone.nc'}"
[[forcing]]
source = "water_drag"
[[forcing]]
source = "coriolis"
[output]
every = {EVERY * DT}
"""


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    from siku_io.output.netcdf import export

    folder = tmp_path_factory.mktemp("cf")
    out = folder / "pack.h5"
    Simulation(scene_from_text(SCENE, "<cf test>"), out=out, progress=False).run()
    return out, export(out, folder / "pack.nc")


def test_cf_xarray_finds_one_trajectory_per_element_at_the_snapshot_times(exported):
    h5, nc = exported
    with h5py.File(h5, "r") as f:
        steps = f["states/step"][:]
    assert steps.tolist() == list(range(0, STEPS + 1, EVERY))
    with xr.open_dataset(nc) as ds:
        assert ds.attrs["featureType"] == "trajectory"
        (role,) = ds.cf.cf_roles["trajectory_id"]
        assert ds[role].size == NX * NY  # one trajectory per element
        time = ds.cf["time"]
        assert time.dims == (role, "obs") and time.shape == (NX * NY, len(steps))
        start = np.datetime64("2001-04-06T00:00:00", "ns")
        expected = start + (steps * DT * 1e9).astype("timedelta64[ns]")
        for k in range(NX * NY):
            assert np.array_equal(time.values[k], expected)
        (lon_name,), (lat_name,) = ds.cf.coordinates["longitude"], ds.cf.coordinates["latitude"]
        lon, lat = ds[lon_name], ds[lat_name]
        assert lon.shape == lat.shape == time.shape
        assert np.isfinite(lon).all() and np.isfinite(lat).all()


def test_cf_xarray_rebuilds_each_outline_around_its_element(exported):
    """The polygons cf-xarray decodes from the geometry container: one per element, each holding
    its element's first position; their lon/lat centroids within 1e-3 degrees of it (a
    planar centroid in degrees of a 10 km cell differs from the spherical centre by ~(L/R)^2
    of its size)."""
    shapely = pytest.importorskip("shapely")
    _, nc = exported
    with xr.open_dataset(nc) as ds:
        polygons = cf_xarray.cf_to_shapely(ds, container=ds.attrs.get("geometry", "outline"))
        (lon_name,), (lat_name,) = ds.cf.coordinates["longitude"], ds.cf.coordinates["latitude"]
        lon, lat = ds[lon_name].values[:, 0], ds[lat_name].values[:, 0]
    assert polygons.size == NX * NY
    for k, poly in enumerate(polygons.values):
        assert poly.geom_type == "Polygon" and poly.contains(shapely.Point(lon[k], lat[k]))
        c = poly.centroid
        assert abs(c.x - lon[k]) < 1e-3 and abs(c.y - lat[k]) < 1e-3, (k, c, lon[k], lat[k])
