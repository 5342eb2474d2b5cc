"""Initial ice cover from a CF NetCDF file (``[elements.mesh.cover]``, ``siku_io.mesh.icecover``).

The fields are written here: concentration and thickness linear in longitude and latitude, so
bilinear sampling at a cell's seed is exact and every element can be checked against the
formula to round-off."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from siku_core.run.elements import build_elements
from siku_core.errors import SikuError
from siku_core.scene.scene_file import load_scene
from siku_core.state import FREE
from siku_io.mesh.cache import mesh_for_scene

RHO = 910.0  # kg/m3, the default ice density ([materials.ice] density)
LON, LAT = (-160.0, -150.0), (72.0, 75.0)


def conc(lon, lat):  # 0 at the western edge (-160°) rising linearly to 1 at the eastern (-150°)
    return (np.asarray(lon) + 160.0) / 10.0


def thick(lon, lat):  # 1 m at 72N rising 0.5 m per degree of latitude, 0.02 m per degree east
    return 1.0 + 0.5 * (np.asarray(lat) - 72.0) + 0.02 * (np.asarray(lon) + 160.0)


def _write(path, percent=False, categories=False):
    lon = np.arange(-162.0, -147.9, 0.5)
    lat = np.arange(70.0, 77.01, 0.25)
    LO, LA = np.meshgrid(lon, lat)
    c = conc(LO, LA)
    h = thick(LO, LA)
    if categories:  # three categories: fractions 0.2, 0.3, 0.5 of c at 0.5 h, h, 1.5 h
        share = np.array([0.2, 0.3, 0.5])[:, None, None]
        cat = np.array([0.5, 1.0, 1.5])[:, None, None]
        ds = xr.Dataset({
            "aicen": (("ncat", "lat", "lon"), share * c, {"units": "1"}),
            "hicen": (("ncat", "lat", "lon"), cat * h, {"units": "m"}),
        }, coords={"lat": ("lat", lat, {"units": "degrees_north"}),
                   "lon": ("lon", lon, {"units": "degrees_east"})})
    else:
        ds = xr.Dataset({
            "siconc": (("time", "lat", "lon"), (100.0 if percent else 1.0) * c[None],
                       {"units": "%" if percent else "1",
                        "standard_name": "sea_ice_area_fraction"}),
            "sithick": (("time", "lat", "lon"), h[None],
                        {"units": "m", "standard_name": "sea_ice_thickness"}),
        }, coords={"time": ("time", np.array(["2001-04-06"], dtype="datetime64[ns]")),
                   "lat": ("lat", lat, {"units": "degrees_north"}),
                   "lon": ("lon", lon, {"units": "degrees_east"})})
    ds.to_netcdf(path)


def _scene(tmp_path, cover: str):
    text = f"""
[time]
start = 2001-04-06T00:00:00Z
duration = "1h"
dt = 60
[elements]
thickness = 2.0
[elements.mesh]
lon = [{LON[0]}, {LON[1]}]
lat = [{LAT[0]}, {LAT[1]}]
spacing = 30e3
land = "none"
cache = false
[elements.mesh.cover]
{cover}
"""
    p = tmp_path / "cover.toml"
    p.write_text(text, encoding="utf-8")
    return load_scene(p)


def _mesh(tmp_path):
    sc = _scene(tmp_path, 'file = "c.nc"')
    return mesh_for_scene(sc)[0]


@pytest.mark.parametrize("percent", [False, True])
def test_cells_below_the_threshold_are_open_water_and_thickness_follows_the_field(
        tmp_path, percent):
    _write(tmp_path / "c.nc", percent=percent)
    st = build_elements(_scene(tmp_path, 'file = "c.nc"\nthreshold = 0.3'))
    mesh = _mesh(tmp_path)
    c = conc(mesh.seeds[:, 0], mesh.seeds[:, 1])
    kept = c >= 0.3
    assert 0 < kept.sum() < mesh.n and st.n == kept.sum()
    h = thick(mesh.seeds[kept, 0], mesh.seeds[kept, 1])
    np.testing.assert_allclose(st.thickness, h, rtol=1e-12)
    np.testing.assert_allclose(st.m, RHO * h * st.area, rtol=1e-12)
    # each element keeps its cell's area: the same cells built without a cover
    full = build_elements(_scene(tmp_path, 'file = "c.nc"\nthreshold = 0.0'))
    np.testing.assert_allclose(st.area, full.area[kept], rtol=1e-12)
    assert np.all(st.flags == FREE)


def test_the_ice_area_matches_the_field_within_one_row_of_cells(tmp_path):
    """Total element area against the area of the box where c >= 0.5 (east of -155°): they
    differ by at most the cells along the edge line, one cell (30-40 km) wide."""
    _write(tmp_path / "c.nc")
    st = build_elements(_scene(tmp_path, 'file = "c.nc"\nthreshold = 0.5'))
    R = 6_371_000.0
    band = R * R * np.radians(5.0) * (np.sin(np.radians(LAT[1])) - np.sin(np.radians(LAT[0])))
    edge = R * np.radians(LAT[1] - LAT[0])  # the line c = 0.5 runs north-south
    cell = np.sqrt(np.median(st.area))
    assert abs(st.area.sum() - band) < edge * cell


def test_thickness_categories_give_the_mean_thickness_and_mass(tmp_path):
    """g_k = a_k / sum a_k, thickness sum g_k h_k (the contact laws take their in-plane
    stiffness E h from it), mass rho A sum a_k h_k (the ice only: the concentration times
    rho A sum g_k h_k)."""
    _write(tmp_path / "c.nc", categories=True)
    st = build_elements(_scene(tmp_path, 'file = "c.nc"\nconcentration = "aicen"\n'
                                          'thickness = "hicen"\ncategory = "ncat"'))
    mesh = _mesh(tmp_path)
    c = conc(mesh.seeds[:, 0], mesh.seeds[:, 1])
    kept = c >= 0.15
    h = thick(mesh.seeds[kept, 0], mesh.seeds[kept, 1])
    mean = (0.2 * 0.5 + 0.3 * 1.0 + 0.5 * 1.5) * h  # sum_k g_k h_k
    np.testing.assert_allclose(st.thickness, mean, rtol=1e-12)
    np.testing.assert_allclose(st.m, RHO * c[kept] * mean * st.area, rtol=1e-12)


def test_a_curvilinear_grid_is_sampled_at_the_nearest_point(tmp_path):
    """2-D lat/lon (a polar stereographic product): nearest-point sampling is within the
    field's gradient times half a grid diagonal."""
    x = np.arange(-1200e3, 1200e3, 10e3)
    X, Y = np.meshgrid(x, x + -1600e3)
    rho = np.hypot(X, Y)
    lat = 90.0 - np.degrees(2 * np.arctan(rho / (2 * 6_371_000.0)))
    lon = np.degrees(np.arctan2(X, -Y)) - 155.0
    ds = xr.Dataset({"sic": (("y", "x"), np.ones_like(lat), {"units": "1"}),
                     "sit": (("y", "x"), thick(lon, lat), {"units": "m"})},
                    coords={"TLAT": (("y", "x"), lat, {"units": "degrees_north"}),
                            "TLON": (("y", "x"), lon, {"units": "degrees_east"})})
    ds.to_netcdf(tmp_path / "ps.nc")
    st = build_elements(_scene(tmp_path, 'file = "ps.nc"\nconcentration = "sic"\n'
                                         'thickness = "sit"'))
    mesh = _mesh(tmp_path)
    h = thick(mesh.seeds[:, 0], mesh.seeds[:, 1])
    grad = 0.5 / 111e3  # m per m, the steeper (northward) part
    assert np.max(np.abs(st.thickness - h)) < grad * 10e3 * np.sqrt(2) / 2 * 1.2


def test_cover_errors_name_the_table(tmp_path):
    _write(tmp_path / "c.nc")
    with pytest.raises(SikuError, match=r"cover.*no variable 'ice'.*siconc"):
        build_elements(_scene(tmp_path, 'file = "c.nc"\nconcentration = "ice"'))
    with pytest.raises(SikuError, match=r"cover.*not found"):
        build_elements(_scene(tmp_path, 'file = "missing.nc"'))


def test_a_missing_category_thickness_where_there_is_ice_is_refused(tmp_path):
    """A NaN category thickness under a non-zero fraction is not 0 m of ice: refused in one
    line naming the file, the variable, the cell and the category; a NaN thickness of a
    category without ice (fraction 0) is no ice and accepted."""
    path = tmp_path / "c.nc"
    _write(path, categories=True)
    ds = xr.load_dataset(path)
    h = ds["hicen"].values.copy()
    a = ds["aicen"].values.copy()
    h[1] = np.nan  # the middle category's thickness missing everywhere
    ds["hicen"].values = h
    ds.to_netcdf(tmp_path / "bad.nc")
    cover = 'concentration = "aicen"\nthickness = "hicen"\ncategory = "ncat"'
    with pytest.raises(SikuError, match=r"bad\.nc: 'hicen' is missing .* ice cell \d+ .*"
                                        r"category 1") as ei:
        build_elements(_scene(tmp_path, 'file = "bad.nc"\n' + cover))
    assert "\n" not in str(ei.value)
    a[1] = 0.0  # no ice in that category: its missing thickness means nothing
    ds["aicen"].values = a
    ds.to_netcdf(tmp_path / "none.nc")
    st = build_elements(_scene(tmp_path, 'file = "none.nc"\n' + cover))
    assert np.all(np.isfinite(st.thickness)) and np.all(st.thickness > 0)
