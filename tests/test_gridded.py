"""The gridded field (siku_forcing.gridded.gridded_field): NCEP/NCAR and CF NetCDF files,
interpolation in space
and time, the poles, regional grids, laziness, errors, and one run against the uniform field.

Every file is written here (small grids) with xarray/netCDF4.
"""
from __future__ import annotations

import datetime as dt
import math
import os
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

from siku_core.errors import DataError, SceneError
from siku_core.plugins import get_registry
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_forcing.gridded.gridded_field import Gridded, pole_vector

xr = pytest.importorskip("xarray")
pytest.importorskip("netCDF4")

START = dt.datetime(2001, 1, 1)
START_UTC = START.replace(tzinfo=dt.UTC)  # what a scene's "start = ...Z" gives
NCEP_LAT = np.arange(90.0, -90.1, -2.5)  # 90 -> -90, 73 rows
NCEP_LON = np.arange(0.0, 360.0, 2.5)  # 0 -> 357.5, 144 columns
HOUR = 3600.0


# --------------------------------------------------------------------------- writing files
def write_nc(path, var, data, lat, lon, times=None, *, units="m/s", names=None, packed=False,
             also=None):
    """Write ``data (nt, ny, nx)`` (or ``(ny, nx)`` without ``times``) as ``var``, and the
    variables ``also = {name: data}`` alike in the same file.

    ``names`` maps the roles lat/lon/time to dimension names; ``packed`` stores int16 with the
    NCEP/NCAR scale_factor 0.01 and add_offset 225.45; times in hours since 1800-01-01.
    """
    names = {"lat": "lat", "lon": "lon", "time": "time", **(names or {})}
    dims = ([names["time"]] if times is not None else []) + [names["lat"], names["lon"]]
    coords = {
        names["lat"]: (names["lat"], np.asarray(lat, float),
                       {"units": "degrees_north", "standard_name": "latitude"}),
        names["lon"]: (names["lon"], np.asarray(lon, float),
                       {"units": "degrees_east", "standard_name": "longitude"}),
    }
    if times is not None:
        coords[names["time"]] = (names["time"], np.asarray(times, "datetime64[ns]"))
    attrs = {} if units is None else {"units": units}
    data_vars = {k: (dims, np.asarray(d, float), attrs)
                 for k, d in {var: data, **(also or {})}.items()}
    ds = xr.Dataset(data_vars, coords=coords)
    enc = {}
    if times is not None:
        enc[names["time"]] = {"units": "hours since 1800-01-01 00:00:0.0", "dtype": "float64",
                              "calendar": "standard"}
    for k in data_vars:
        if packed:
            enc[k] = {"dtype": "int16", "scale_factor": np.float32(0.01),
                      "add_offset": np.float32(225.45), "_FillValue": np.int16(32766),
                      "missing_value": np.int16(32766)}
        else:
            enc[k] = {"dtype": "float64", "_FillValue": None}
    ds.to_netcdf(path, engine="netcdf4", encoding=enc)
    return path


def hours(*h):
    return np.datetime64(START) + np.array([int(x * 3600) for x in h]).astype("timedelta64[s]")


class FakeScene:
    def __init__(self, base_dir):
        self.base_dir = base_dir
        self.label = "test.toml"

    def where(self, table):
        return f"{self.label} [{table}]"


class FakeSim:
    """What a field's setup reads from its context (siku_core.context.Context)."""

    def __init__(self, base_dir, start=START, duration=6 * HOUR, dt=600.0):
        self.scene = FakeScene(base_dir)
        self.start = start
        self.dt = dt
        self.n_steps = round(duration / dt)
        self.forcing = []


def field(tmp_path, sim=None, **params):
    f = Gridded({**{k: p.default for k, p in Gridded.params.items()}, **params})
    f.setup(sim or FakeSim(tmp_path))
    return f


def bilinear(lat, lon, c):
    """A field bilinear in (lon, lat) [deg]."""
    return c[0] + c[1] * lon + c[2] * lat + c[3] * lon * lat


CU = (3.0, 0.02, -0.05, 4e-4)
CV = (-1.5, -0.01, 0.03, -2e-4)


def ncep_pair(tmp_path, lat=NCEP_LAT, lon=NCEP_LON, times=None, fu=None, fv=None, **kw):
    """NCEP-layout uwnd/vwnd files; ``fu, fv (t_index, LAT, LON)`` give the data."""
    times = hours(0, 6, 12) if times is None else times
    LON, LAT = np.meshgrid(lon, lat)
    fu = fu or (lambda k, la, lo: bilinear(la, lo, CU) + k)
    fv = fv or (lambda k, la, lo: bilinear(la, lo, CV) - 2 * k)
    u = np.stack([fu(k, LAT, LON) for k in range(len(times))])
    v = np.stack([fv(k, LAT, LON) for k in range(len(times))])
    write_nc(tmp_path / "uwnd.nc", "uwnd", u, lat, lon, times, **kw)
    write_nc(tmp_path / "vwnd.nc", "vwnd", v, lat, lon, times, **kw)
    return u, v


def rad(*a):
    return np.radians(np.asarray(a, dtype=float))


# --------------------------------------------------------------------------- reading
def test_gridded_is_a_registered_field():
    assert get_registry().get("field", "gridded") is Gridded


def test_ncep_packed_int16_reads_back_to_physical_values(tmp_path):
    rng = np.random.default_rng(3)
    u = rng.uniform(-30, 30, (3, NCEP_LAT.size, NCEP_LON.size))
    v = rng.uniform(-30, 30, (3, NCEP_LAT.size, NCEP_LON.size))
    write_nc(tmp_path / "uwnd.10m.2001.nc", "uwnd", u, NCEP_LAT, NCEP_LON, hours(0, 6, 12),
             packed=True)
    write_nc(tmp_path / "vwnd.10m.2001.nc", "vwnd", v, NCEP_LAT, NCEP_LON, hours(0, 6, 12),
             packed=True)
    import netCDF4

    with netCDF4.Dataset(tmp_path / "uwnd.10m.2001.nc") as nc:  # really packed on disk
        var = nc["uwnd"]
        var.set_auto_maskandscale(False)
        assert var.dtype == np.int16 and var.scale_factor.dtype == np.float32
        assert nc["time"].units.startswith("hours since 1800-01-01")
    f = field(tmp_path, u_file="uwnd.10m.2001.nc", v_file="vwnd.10m.2001.nc")
    LON, LAT = np.meshgrid(NCEP_LON, NCEP_LAT)
    for k in range(3):
        su, sv = f.sample(k * 6 * HOUR, np.radians(LAT.ravel()), np.radians(LON.ravel()))
        tol = 0.01 / 2 + 1e-4  # half the packing step (+ float32 rounding of the unpacking)
        assert np.abs(su - u[k].ravel()).max() <= tol
        assert np.abs(sv - v[k].ravel()).max() <= tol


def test_units_variants_are_accepted(tmp_path):
    for units in ("m/s", "m s-1", "m s**-1", "M S-1"):
        ncep_pair(tmp_path, units=units)
        f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
        f.close()


# --------------------------------------------------------------------------- space
def test_bilinear_field_is_interpolated_exactly(tmp_path):
    ncep_pair(tmp_path)
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    rng = np.random.default_rng(1)
    lat = rng.uniform(-90, 90, 2000)
    lon = rng.uniform(0, 357.5, 2000)  # not the wrap cell
    u, v = f.sample(0.0, np.radians(lat), np.radians(lon))
    np.testing.assert_allclose(u, bilinear(lat, lon, CU), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(v, bilinear(lat, lon, CV), rtol=1e-12, atol=1e-12)
    # the same points given as longitudes -360..0 and 360..720
    for shift in (-360.0, 360.0):
        u2, v2 = f.sample(0.0, np.radians(lat), np.radians(lon + shift))
        np.testing.assert_allclose(u2, u, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(v2, v, rtol=1e-12, atol=1e-12)


def test_wrap_around_between_357_5_and_360(tmp_path):
    """The original code returned zero here; now linear between the 357.5° and 0° columns."""
    ncep_pair(tmp_path)
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    lat = np.array([0.0, 41.3, -77.0, 70.0, 70.0, 70.0])
    lon = np.array([358.75, 357.5 + 0.3 * 2.5, 359.9, -1.25, 360.0, 0.0])
    u, v = f.sample(0.0, np.radians(lat), np.radians(lon))
    x = np.mod(lon - 357.5, 360.0) / 2.5  # 0 at 357.5, 1 at 360
    x[np.isclose(x, 1.0)] = 1.0
    for got, c in ((u, CU), (v, CV)):
        want = (1 - x) * bilinear(lat, 357.5, c) + x * bilinear(lat, 0.0, c)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    assert np.all(np.abs(u[:4]) > 1.0)  # inside the wrap cell: not zero


def test_antimeridian_on_a_minus180_180_grid(tmp_path):
    lon = np.arange(-180.0, 180.0, 2.5)
    lat = np.arange(-60.0, 60.1, 5.0)  # ascending
    LON, LAT = np.meshgrid(lon, lat)
    u = bilinear(LAT, LON, CU)[None]
    v = bilinear(LAT, LON, CV)[None]
    write_nc(tmp_path / "a.nc", "u10", u, lat, lon, hours(0), units="m s**-1")
    write_nc(tmp_path / "b.nc", "v10", v, lat, lon, hours(0), units="m s**-1")
    f = field(tmp_path, FakeSim(tmp_path, duration=0.0, dt=1.0), u_file="a.nc", v_file="b.nc",
              u="u10", v="v10")
    qlat = np.array([10.0, 10.0, -33.0, 12.5, 0.0, 0.0])
    qlon = np.array([-179.0, 181.0, -180.0, 180.0, 178.75, -181.25])
    su, sv = f.sample(0.0, np.radians(qlat), np.radians(qlon))
    q = np.mod(qlon + 180.0, 360.0) - 180.0  # -180..180
    # -180..177.5 is the grid; 177.5..180 is the wrap cell (180 == -180)
    x = np.clip((q - 177.5) / 2.5, 0, 1)
    inner = q < 177.5
    for got, c in ((su, CU), (sv, CV)):
        want = np.where(inner, bilinear(qlat, q, c),
                        (1 - x) * bilinear(qlat, 177.5, c) + x * bilinear(qlat, -180.0, c))
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # 180 and -180 are the same meridian
    assert su[2] == pytest.approx(bilinear(-33.0, -180.0, CU), rel=1e-12)
    assert su[3] == pytest.approx(bilinear(12.5, -180.0, CU), rel=1e-12)


def test_era5_style_file_ascending_latitudes_and_name_mapping(tmp_path):
    lat = np.arange(-90.0, 90.1, 3.0)  # ascending, with both poles
    lon = np.arange(-180.0, 180.0, 3.0)
    LON, LAT = np.meshgrid(lon, lat)
    names = {"lat": "latitude", "lon": "longitude", "time": "valid_time"}
    t = hours(0, 1, 2, 3, 4, 5, 6)
    u = np.stack([bilinear(LAT, LON, CU) + 0.1 * k for k in range(t.size)])
    v = np.stack([bilinear(LAT, LON, CV) for k in range(t.size)])
    write_nc(tmp_path / "era5.nc", "u10", u, lat, lon, t, units="m s**-1", names=names,
             also={"v10": v})
    rng = np.random.default_rng(2)
    qlat = rng.uniform(-90, 90, 500)
    qlon = rng.uniform(-180, 177, 500)
    for mapping in ({"lat": "latitude", "lon": "longitude", "time": "valid_time"}, {}):
        f = field(tmp_path, file="era5.nc", u="u10", v="v10", **mapping)
        su, sv = f.sample(2.5 * HOUR, np.radians(qlat), np.radians(qlon))
        np.testing.assert_allclose(su, bilinear(qlat, qlon, CU) + 0.25, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(sv, bilinear(qlat, qlon, CV), rtol=1e-12, atol=1e-12)
        f.close()


def test_gaussian_latitudes(tmp_path):
    x, _ = np.polynomial.legendre.leggauss(24)
    lat = np.degrees(np.arcsin(x))[::-1]  # Gaussian latitudes, north to south (NCEP gauss)
    lon = np.arange(0.0, 360.0, 7.5)
    ncep_pair(tmp_path, lat=lat, lon=lon, times=hours(0, 6))
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    rng = np.random.default_rng(4)
    qlat = rng.uniform(lat.min(), lat.max(), 1000)
    qlon = rng.uniform(0, lon.max(), 1000)
    su, sv = f.sample(0.0, np.radians(qlat), np.radians(qlon))
    np.testing.assert_allclose(su, bilinear(qlat, qlon, CU), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sv, bilinear(qlat, qlon, CV), rtol=1e-12, atol=1e-12)
    assert f.grid.cap_n and f.grid.cap_s  # 85.0° last row: polar caps beyond it


# --------------------------------------------------------------------------- poles
def to_xyz(lat, lon, u, v):
    """3-D vectors of east/north components at (lat, lon) [rad]."""
    e = np.stack([-np.sin(lon), np.cos(lon), np.zeros_like(lon)], axis=-1)
    n = np.stack([-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon), np.cos(lat)], axis=-1)
    return u[..., None] * e + v[..., None] * n


POLE_LAT = np.arange(-87.5, 87.6, 2.5)  # no pole rows: 2.5° gap to each pole
POLE_LON = np.arange(0.0, 360.0, 10.0)


def test_uniform_flow_over_the_pole_is_exact_at_the_pole(tmp_path):
    """A flow W uniform over the pole (tangent there) is recovered exactly at the pole."""
    W = {1: (4.0, -3.0), -1: (-2.0, 5.0)}  # north, south (W_x, W_y)

    def comp(which):
        def f(k, la, lo):
            la, lo = np.radians(la), np.radians(lo)
            a, b = np.where(la > 0, W[1][0], W[-1][0]), np.where(la > 0, W[1][1], W[-1][1])
            if which == "u":
                return -a * np.sin(lo) + b * np.cos(lo)
            return -np.sin(la) * (a * np.cos(lo) + b * np.sin(lo))
        return f

    ncep_pair(tmp_path, lat=POLE_LAT, lon=POLE_LON, times=hours(0, 6), fu=comp("u"),
              fv=comp("v"))
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    assert f.grid.cap_n and f.grid.cap_s
    qlon = np.array([0.0, 13.0, 95.0, 200.0, 359.0, -45.0])
    for sign in (1, -1):
        qlat = np.full(qlon.size, 90.0 * sign)
        u, v = f.sample(0.0, np.radians(qlat), np.radians(qlon))
        xyz = to_xyz(np.radians(qlat), np.radians(qlon), u, v)
        np.testing.assert_allclose(xyz, np.tile([*W[sign], 0.0], (qlon.size, 1)), rtol=0,
                                   atol=1e-12)


def test_pole_cap_blends_the_row_and_the_pole_vector(tmp_path):
    """Documented treatment: per component (1 - s) row(lon) + s W(lon), continuous at the row,
    one vector at the pole from every longitude (random data)."""
    rng = np.random.default_rng(5)
    shape = (POLE_LAT.size, POLE_LON.size)
    u = rng.normal(size=(2, *shape)) * 5
    v = rng.normal(size=(2, *shape)) * 5
    write_nc(tmp_path / "uwnd.nc", "uwnd", u, POLE_LAT, POLE_LON, hours(0, 6))
    write_nc(tmp_path / "vwnd.nc", "vwnd", v, POLE_LAT, POLE_LON, hours(0, 6))
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    qlon = np.array([0.0, 10.0, 15.0, 123.4, 355.0])
    # at the pole: the same 3-D vector from every longitude, the least-squares pole vector
    un, vn = f.sample(0.0, np.radians(np.full(5, 90.0)), np.radians(qlon))
    xyz = to_xyz(np.radians(np.full(5, 90.0)), np.radians(qlon), un, vn)
    Wx, Wy = pole_vector(u[0, -1], v[0, -1], math.radians(87.5), np.radians(POLE_LON))
    np.testing.assert_allclose(xyz, np.tile([Wx, Wy, 0.0], (5, 1)), atol=1e-12)
    # the least-squares fit by hand (regular longitudes: closed form)
    lam, sg = np.radians(POLE_LON), math.sin(math.radians(87.5))
    norm = lam.size * (1 + sg * sg) / 2
    assert Wx == pytest.approx(np.sum(-u[0, -1] * np.sin(lam) - sg * v[0, -1] * np.cos(lam)) / norm,
                               rel=1e-12)
    assert Wy == pytest.approx(np.sum(u[0, -1] * np.cos(lam) - sg * v[0, -1] * np.sin(lam)) / norm,
                               rel=1e-12)
    # continuity at the last row, and the blend in between
    for qlat in (87.5, 88.0, 89.3):
        s = (qlat - 87.5) / 2.5
        su, sv = f.sample(0.0, np.radians(np.full(5, qlat)), np.radians(qlon))
        j = np.floor(qlon / 10.0).astype(int)
        fx = qlon / 10.0 - j
        row_u = (1 - fx) * u[0, -1, j] + fx * u[0, -1, (j + 1) % 36]
        row_v = (1 - fx) * v[0, -1, j] + fx * v[0, -1, (j + 1) % 36]
        lm = np.radians(qlon)
        pu = -Wx * np.sin(lm) + Wy * np.cos(lm)
        pv = -(Wx * np.cos(lm) + Wy * np.sin(lm))
        np.testing.assert_allclose(su, (1 - s) * row_u + s * pu, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(sv, (1 - s) * row_v + s * pv, rtol=1e-12, atol=1e-12)
    # south pole: one vector too
    us, vs = f.sample(0.0, np.radians(np.full(5, -90.0)), np.radians(qlon))
    xyz = to_xyz(np.radians(np.full(5, -90.0)), np.radians(qlon), us, vs)
    np.testing.assert_allclose(xyz, np.tile(xyz[0], (5, 1)), atol=1e-12)


def test_zonal_flow_vanishes_at_the_pole(tmp_path):
    """Solid rotation about the axis, u = c cos(lat): its pole vector is zero."""
    ncep_pair(tmp_path, lat=POLE_LAT, lon=POLE_LON, times=hours(0, 6),
              fu=lambda k, la, lo: 10 * np.cos(np.radians(la)), fv=lambda k, la, lo: 0 * la)
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    qlat = np.array([88.0, 89.0, 90.0, -88.75])
    u, v = f.sample(0.0, np.radians(qlat), np.radians([30.0, 200.0, 10.0, 5.0]))
    s = (np.abs(qlat) - 87.5) / 2.5
    np.testing.assert_allclose(u, (1 - s) * 10 * math.cos(math.radians(87.5)), atol=1e-12)
    np.testing.assert_allclose(v, 0.0, atol=1e-12)


# --------------------------------------------------------------------------- time and laziness
def test_linear_in_time_and_reads_only_the_bracketing_records(tmp_path):
    times = hours(*range(0, 48, 6))  # 8 records
    ncep_pair(tmp_path, times=times,
              fu=lambda k, la, lo: bilinear(la, lo, CU) * (1 + 0.5 * k),
              fv=lambda k, la, lo: bilinear(la, lo, CV) - 3.0 * k)
    f = field(tmp_path, FakeSim(tmp_path, duration=18 * HOUR), u_file="uwnd.nc",
              v_file="vwnd.nc")
    qlat, qlon = np.array([10.0, -44.4, 71.3]), np.array([5.0, 222.2, 301.0])
    ts = np.arange(0.0, 18 * HOUR + 1, 1000.0)
    for t in ts:
        u, v = f.sample(t, np.radians(qlat), np.radians(qlon))
        k = t / (6 * HOUR)  # fractional record index: the fields are linear in it
        np.testing.assert_allclose(u, bilinear(qlat, qlon, CU) * (1 + 0.5 * k), rtol=1e-12)
        np.testing.assert_allclose(v, bilinear(qlat, qlon, CV) - 3.0 * k, rtol=1e-12,
                                   atol=1e-12)
    assert f.records_read == [0, 1, 2, 3]  # each record once, none beyond the run's
    # going back re-reads (at most three records are kept: 1, 2, 3 by now)
    f.sample(0.0, np.radians(qlat), np.radians(qlon))
    assert f.records_read == [0, 1, 2, 3, 0]


def test_a_long_file_is_not_loaded_whole(tmp_path, monkeypatch):
    """Every read from the NetCDF file is one record of one variable (checked at xarray's
    netCDF4 array wrapper, below the field's own bookkeeping)."""
    from xarray.backends import netCDF4_

    lat, lon = np.arange(90.0, -90.1, -10.0), np.arange(0.0, 360.0, 10.0)
    times = hours(*range(0, 2000 * 6, 6))  # 2000 six-hourly records
    ncep_pair(tmp_path, lat=lat, lon=lon, times=times)
    reads = []
    orig = netCDF4_.NetCDF4ArrayWrapper._getitem

    def spy(self, key):
        out = orig(self, key)
        reads.append(np.shape(out))
        return out

    monkeypatch.setattr(netCDF4_.NetCDF4ArrayWrapper, "_getitem", spy)
    f = field(tmp_path, FakeSim(tmp_path, duration=30 * HOUR), u_file="uwnd.nc",
              v_file="vwnd.nc")
    reads.clear()  # coordinates were read by setup
    for t in np.arange(0.0, 30 * HOUR + 1, 1800.0):
        f.sample(t, rad(80.0), rad(20.0))
    data_reads = [s for s in reads if np.prod(s) > max(lat.size, lon.size)]
    assert data_reads and all(np.prod(s) == lat.size * lon.size for s in data_reads)
    assert len(data_reads) == 2 * 6  # u and v of records 0..5 (0 h .. 30 h)
    assert f.records_read == [0, 1, 2, 3, 4, 5]


def test_glob_pattern_joins_files_along_time(tmp_path):
    for year, t in ((2000, hours(-12, -6)), (2001, hours(0, 6, 12))):
        LON, LAT = np.meshgrid(NCEP_LON, NCEP_LAT)
        k0 = (t - np.datetime64(START)) / np.timedelta64(6, "h")
        u = np.stack([bilinear(LAT, LON, CU) + k for k in k0])
        write_nc(tmp_path / f"uwnd.10m.{year}.nc", "uwnd", u, NCEP_LAT, NCEP_LON, t)
        write_nc(tmp_path / f"vwnd.10m.{year}.nc", "vwnd", u * 0, NCEP_LAT, NCEP_LON, t)
    sim = FakeSim(tmp_path, start=dt.datetime(2000, 12, 31, 15), duration=12 * HOUR)
    f = field(tmp_path, sim, u_file="uwnd.10m.*.nc", v_file="vwnd.10m.*.nc")
    for t_h in (0.0, 2.0, 3.0, 7.5, 12.0):  # 15:00 (k = -1.5) .. 03:00 (k = 0.5)
        u, _ = f.sample(t_h * HOUR, rad(50.0), rad(100.0))
        assert u[0] == pytest.approx(bilinear(50.0, 100.0, CU) + (t_h - 9.0) / 6.0, rel=1e-12)


def test_steady_file_without_time_needs_no_start(tmp_path):
    LON, LAT = np.meshgrid(NCEP_LON, NCEP_LAT)
    write_nc(tmp_path / "cur.nc", "uo", bilinear(LAT, LON, CU), NCEP_LAT, NCEP_LON)
    write_nc(tmp_path / "cvr.nc", "vo", bilinear(LAT, LON, CV), NCEP_LAT, NCEP_LON)
    f = field(tmp_path, FakeSim(tmp_path, start=None), u_file="cur.nc", v_file="cvr.nc",
              u="uo", v="vo")
    for t in (0.0, 1e7):
        u, v = f.sample(t, rad(12.0), rad(34.0))
        assert u[0] == pytest.approx(bilinear(12.0, 34.0, CU), rel=1e-12)
        assert v[0] == pytest.approx(bilinear(12.0, 34.0, CV), rel=1e-12)


# --------------------------------------------------------------------------- regional grids
def test_regional_grid_is_zero_outside_with_one_warning(tmp_path):
    lat = np.arange(80.0, 59.9, -2.5)
    lon = np.arange(170.0, 210.1, 2.5)
    lon = np.where(lon > 180, lon - 360, lon)  # crosses the antimeridian, stored -180..180
    LON, LAT = np.meshgrid(np.mod(lon, 360), lat)  # the analytic field in 0..360 longitudes
    write_nc(tmp_path / "u.nc", "u", bilinear(LAT, LON, CU)[None].repeat(2, 0), lat, lon,
             hours(0, 12))
    write_nc(tmp_path / "v.nc", "v", bilinear(LAT, LON, CV)[None].repeat(2, 0), lat, lon,
             hours(0, 12))
    f = field(tmp_path, u_file="u.nc", v_file="v.nc", u="u", v="v")
    assert not f.grid.periodic and not f.grid.cap_n
    qlat = np.array([70.0, 61.0, 79.0, 65.0])
    qlon = np.array([179.0, -179.0, 170.0, 210.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        u, v = f.sample(0.0, np.radians(qlat), np.radians(qlon))  # all inside: no warning
    np.testing.assert_allclose(u, bilinear(qlat, np.mod(qlon, 360), CU), rtol=1e-12)
    outside_lat = np.array([70.0, 85.0, 55.0, 70.0, 90.0])
    outside_lon = np.array([165.0, 180.0, 180.0, -140.0, 0.0])
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        u, v = f.sample(0.0, np.radians(outside_lat), np.radians(outside_lon))
        u2, v2 = f.sample(3600.0, np.radians(outside_lat), np.radians(outside_lon))
        f.sample(7200.0, np.radians(qlat), np.radians(qlon))
    assert len(rec) == 1, [str(w.message) for w in rec]
    assert re.search(r"5 point\(s\) outside the grid .*lat 60\.\.80, lon 170\.\.210\), the "
                     r"first at lat 70, lon 165 at t = 0 s: the velocity is zero there "
                     r"\(said once\)", str(rec[0].message))
    assert not np.any(u) and not np.any(v) and not np.any(u2) and not np.any(v2)


# --------------------------------------------------------------------------- errors
def test_missing_file(tmp_path):
    with pytest.raises(DataError, match=r"data file not found: .*nope\.nc \(u_file = 'nope\.nc'"):
        field(tmp_path, u_file="nope.nc", v_file="vwnd.nc")
    with pytest.raises(DataError, match=r"no file matches file = 'x\*\.nc'"):
        field(tmp_path, file="x*.nc")


def test_a_scene_field_names_its_table_in_messages(tmp_path):
    """A field built from a scene names the file and its table ([forcing[1].field]): the
    engine tells each component the table it was built from (``Component.table``)."""
    text = scene_text([(-150.0, 75.0)], start=START_UTC, dt=60.0, duration="1h",
                      forcing=[{"source": "coriolis"},
                               {"source": "air_drag", "field": {
                                   "type": "gridded",
                                   "params": {"u_file": "nope.nc", "v_file": "nope.nc"}}}])
    path = tmp_path / "named.toml"
    path.write_text(text)
    with pytest.raises(DataError, match=r"named\.toml \[forcing\[1\]\.field\]: data file not "
                                        r"found: .*nope\.nc"):
        Simulation(path, out=False, progress=False)


def test_missing_variable_lists_the_variables_present(tmp_path):
    ncep_pair(tmp_path)
    with pytest.raises(DataError, match=r"uwnd\.nc has no variable 'u10' \(the u component\); "
                                        r"variables present: uwnd; coordinates: lat, lon, time"):
        field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc", u="u10")


def test_wrong_units(tmp_path):
    ncep_pair(tmp_path, units="knots")
    with pytest.raises(DataError, match=r"uwnd\.nc: variable 'uwnd' has units 'knots'; expected"):
        field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    ncep_pair(tmp_path, units=None)
    with pytest.raises(DataError, match=r"variable 'uwnd' has no units attribute"):
        field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")


def test_time_range_not_covering_the_run(tmp_path):
    ncep_pair(tmp_path)  # 00 h .. 12 h
    sim = FakeSim(tmp_path, start=dt.datetime(2001, 1, 1, 9), duration=6 * HOUR)
    with pytest.raises(DataError, match=r"time records of .*uwnd\.nc \(2001-01-01T00:00:00 \.\. "
                                        r"2001-01-01T12:00:00\) do not cover the run "
                                        r"\(2001-01-01T09:00:00 \.\. 2001-01-01T15:00:00\)"):
        field(tmp_path, sim, u_file="uwnd.nc", v_file="vwnd.nc")
    sim = FakeSim(tmp_path, start=dt.datetime(2000, 12, 31, 23), duration=HOUR)
    with pytest.raises(DataError, match=r"do not cover the run \(2000-12-31T23:00:00 \.\. "):
        field(tmp_path, sim, u_file="uwnd.nc", v_file="vwnd.nc")


def test_a_scene_without_start_is_an_error(tmp_path):
    ncep_pair(tmp_path)
    with pytest.raises(SceneError, match=r"has time records \(2001-01-01T00:00:00 \.\. "
                                         r"2001-01-01T12:00:00\); the scene needs \[time\] start"):
        field(tmp_path, FakeSim(tmp_path, start=None), u_file="uwnd.nc", v_file="vwnd.nc")


def test_nan_in_the_data(tmp_path):
    u, _ = ncep_pair(tmp_path, packed=True)
    u[1, 10, 20] = np.nan  # lat 65, lon 50, at 06:00 (a _FillValue on disk)
    write_nc(tmp_path / "uwnd.nc", "uwnd", u, NCEP_LAT, NCEP_LON, hours(0, 6, 12), packed=True)
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    f.sample(0.0, rad(0.0), rad(0.0))  # on record 0: only record 0 is read
    with pytest.raises(DataError, match=r"uwnd\.nc: variable 'uwnd' has 1 NaN or missing "
                                        r"value\(s\) at 2001-01-01T06:00:00 \(record 1\), the "
                                        r"first at lat 65, lon 50; set fill_nan"):
        f.sample(7 * HOUR, rad(0.0), rad(0.0))
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc", fill_nan="zero")
    got, _ = f.sample(6 * HOUR, rad(65.0, 65.0), rad(50.0, 52.5))
    assert got[0] == 0.0 and got[1] == pytest.approx(u[1, 10, 21], abs=0.006)


def test_file_and_u_file_are_exclusive_and_one_is_needed(tmp_path):
    with pytest.raises(SceneError, match="either 'file' .* or 'u_file' and 'v_file', not both"):
        field(tmp_path, file="a.nc", u_file="b.nc")
    with pytest.raises(SceneError, match="needs 'file' .* or 'u_file' and 'v_file'"):
        field(tmp_path, u_file="b.nc")


def test_importing_the_module_does_not_import_xarray():
    code = ("import sys, siku_forcing.gridded.gridded_field, siku_core.plugins as p; "
            "p.get_registry(); print('xarray' in sys.modules, 'netCDF4' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "SIKU_DISABLE_PLUGIN_AUTOLOAD": "1"}, check=True)
    assert r.stdout.split() == ["False", "False"]


def test_conformance_suite_with_a_steady_gaussian_file(tmp_path):
    """siku's conformance checks (poles, antimeridian) on a gridded field: the built-in suite
    skips it (no data file), so it runs here on a steady file (no [time] start needed)."""
    from siku_core.testing import conformance

    x, _ = np.polynomial.legendre.leggauss(16)
    lat = np.degrees(np.arcsin(x))
    lon = np.arange(0.0, 360.0, 15.0)
    LON, LAT = np.meshgrid(np.radians(lon), np.radians(lat))
    write_nc(tmp_path / "cur.nc", "uo", 0.3 * np.cos(LAT) * np.sin(2 * LON), lat, lon,
             units="m s-1", also={"vo": 0.2 * np.cos(LON)})
    params = {"file": str(tmp_path / "cur.nc"), "u": "uo", "v": "vo"}
    conformance.check_field_finite("gridded", params)
    for case in conformance.forcing_cases(sources=["air_drag", "water_drag"], fields=["gridded"],
                                          field_params={"gridded": params}):
        if case.field is None:
            continue
        assert not case.missing
        conformance.check_forcing_finite(case)
        conformance.check_forcing_zero_field(case)
        conformance.check_forcing_only_adds(case)


# --------------------------------------------------------------------------- end to end
def test_run_with_a_uniform_gridded_field_drifts_as_with_the_uniform_field(tmp_path):
    U, V = 7.0, -3.0
    times = hours(0, 6, 12)
    lat, lon = np.arange(90.0, -90.1, -5.0), np.arange(0.0, 360.0, 5.0)
    ones = np.ones((times.size, lat.size, lon.size))
    write_nc(tmp_path / "uwnd.nc", "uwnd", U * ones, lat, lon, times)
    write_nc(tmp_path / "vwnd.nc", "vwnd", V * ones, lat, lon, times)

    def run(fld):
        text = scene_text([(-150.0, 75.0)], start=START_UTC, dt=60.0, duration="6h",
                          forcing=[{"source": "air_drag", "field": fld},
                                   {"source": "water_drag"}, {"source": "coriolis"}])
        path = tmp_path / f"scene_{fld['type']}.toml"
        path.write_text(text)
        sim = Simulation(path, out=False, progress=False)
        sim.run()
        return sim

    a = run({"type": "uniform", "params": {"u": U, "v": V}})
    b = run({"type": "gridded", "params": {"u_file": "uwnd.nc", "v_file": "vwnd.nc"}})
    assert b.step_index == a.step_index == 360
    np.testing.assert_allclose(b.state.q, a.state.q, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b.state.V, a.state.V, rtol=1e-12, atol=1e-15)
    assert np.linalg.norm(a.state.V) > 0.05  # it did drift
    fld = b.forcing[0].field
    assert fld.records_read == [0, 1]  # a 6 h run: the records of 00 h and 06 h
    # the run closed the files; sampling a record not cached reopens them
    u, v = fld.sample(9 * HOUR, rad(75.0), rad(-150.0))
    assert (u[0], v[0]) == pytest.approx((U, V), rel=1e-12)
    assert fld.records_read == [0, 1, 2]


@pytest.mark.parametrize("fmt", ["NETCDF3_CLASSIC", "NETCDF3_64BIT", "NETCDF4"])
def test_a_file_cut_short_is_refused_by_name(tmp_path, fmt):
    """A NetCDF-3 file cut short opens in the NetCDF library, which reads the missing records as
    zeros: its header's size is checked. A NetCDF-4 (HDF5) file cut short fails to open."""
    times = hours(0, 6, 12, 18)
    LON, LAT = np.meshgrid(NCEP_LON, NCEP_LAT)
    u = np.stack([bilinear(LAT, LON, CU) + k for k in range(times.size)])
    for var in ("uwnd", "vwnd"):
        ds = xr.Dataset({var: (("time", "lat", "lon"), u, {"units": "m/s"})},
                        coords={"time": times,
                                "lat": ("lat", NCEP_LAT, {"units": "degrees_north"}),
                                "lon": ("lon", NCEP_LON, {"units": "degrees_east"})})
        ds.to_netcdf(tmp_path / f"{var}.nc", format=fmt, engine="netcdf4",
                     unlimited_dims=["time"])
    f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")  # whole files read fine
    got, _ = f.sample(18 * HOUR, rad(65.0), rad(50.0))
    assert got[0] == pytest.approx(u[3, 10, 20])
    f.close()  # (HDF5 would reuse the open file instead of reading the cut one)
    full = (tmp_path / "uwnd.nc").read_bytes()
    (tmp_path / "uwnd.nc").write_bytes(full[: int(0.7 * len(full))])
    if fmt.startswith("NETCDF3"):
        match = (rf"uwnd\.nc is cut short: its header describes {len(full)} bytes \(4 records\) "
                 rf"but the file has {int(0.7 * len(full))}")
    else:
        match = r"cannot read .*uwnd\.nc as NetCDF: .*cut short or corrupt"
    with pytest.raises(DataError, match=match):
        field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")


# --------------------------------------------------------------------------- drag in one pass
@pytest.mark.parametrize("grid", ["global", "regional"])
def test_drag_in_one_pass_is_sampling_then_drag_bit_for_bit(tmp_path, grid):
    """``Gridded.add_drag`` (centres, interpolation and stress fused per element, on chunks)
    adds the same forces, bit for bit, as sampling the field at the centres and applying the
    drag kernel to the samples, on any number of chunks: everywhere on the globe (pole caps,
    the wrap-around column), between two records, and outside a regional grid (zero field,
    the same count of outside points)."""
    from siku_core.geometry.quat import latlon_of, q_from_latlon
    from siku_forcing.drag import _stress

    if grid == "global":
        ncep_pair(tmp_path)
        f = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    else:
        lat, lon = np.arange(80.0, 59.9, -2.5), np.arange(170.0, 210.1, 2.5)
        LON, LAT = np.meshgrid(lon, lat)
        for name, c in (("u", CU), ("v", CV)):
            write_nc(tmp_path / f"{name}.nc", name, bilinear(LAT, LON, c)[None].repeat(2, 0),
                     lat, lon, hours(0, 12))
        f = field(tmp_path, u_file="u.nc", v_file="v.nc", u="u", v="v")
    rng = np.random.default_rng(7)
    n = 3000
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    lat[:4] = [90.0, -90.0, 89.99, -89.0]
    lon = rng.uniform(-180, 180, n)
    q = np.array([q_from_latlon(math.radians(a), math.radians(b)) for a, b in zip(lat, lon)])
    V = rng.normal(0, 0.3, (n, 2))
    area = rng.uniform(1e6, 1e8, n)
    for t in (0.0, 5000.0):
        lat_r, lon_r = latlon_of(q)
        with warnings.catch_warnings(record=True) as rec_s:
            warnings.simplefilter("always")
            u, v = f.sample(t, lat_r, lon_r)
        expected = np.zeros((n, 2))
        _stress(q, V, u, v, area, 1.3, 0.0016, math.radians(20.0), 1.0, expected, 1)
        for nch in (1, 5):
            f._warned = False
            got = np.zeros((n, 2))
            with warnings.catch_warnings(record=True) as rec_f:
                warnings.simplefilter("always")
                f.add_drag(t, q, V, area, 1.3, 0.0016, math.radians(20.0), 1.0, got, nch)
            np.testing.assert_array_equal(got, expected)
            assert [str(w.message) for w in rec_f] == [str(w.message) for w in rec_s]
        f._warned = False
    if grid == "regional":
        assert rec_s, "the regional case must put points outside the grid"


def test_resampled_drag_holds_each_elements_records_between_resamples(tmp_path):
    """``resample``: the drag at a later time of the same interval is the exact drag of the
    field at the positions of the last resample, weighed in time at the later time, in the
    elements' present frames (bit for bit); a new interval, a new pair of records or a step
    back in time takes the field at the present positions again (the exact path's forces)."""
    from siku_core.geometry.quat import latlon_of, q_from_latlon
    from siku_forcing.drag import _stress

    ncep_pair(tmp_path)
    exact = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc")
    held = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc", resample=600.0)
    rng = np.random.default_rng(3)
    n = 500
    lat0 = rng.uniform(60.0, 80.0, n)
    lon0 = rng.uniform(-180.0, 180.0, n)
    q0 = np.array([q_from_latlon(math.radians(a), math.radians(b)) for a, b in zip(lat0, lon0)])
    q1 = np.array([q_from_latlon(math.radians(a + 0.3), math.radians(b - 0.5))
                   for a, b in zip(lat0, lon0)])  # moved 30-40 km: a different wind
    V = rng.normal(0, 0.3, (n, 2))
    area = rng.uniform(1e6, 1e8, n)
    args = (area, 1.3, 0.0016, math.radians(20.0), 1.0)

    def drag(f, t, q, nch=1):
        out = np.zeros((n, 2))
        f.add_drag(t, q, V, *args, out, nch)
        return out

    def held_drag(t, q_then, q_now):
        u, v = exact.sample(t, *latlon_of(q_then))
        out = np.zeros((n, 2))
        _stress(q_now, V, u, v, *args, out, 1)
        return out

    t0 = 1000.0
    np.testing.assert_array_equal(drag(held, t0, q0), drag(exact, t0, q0))
    for t in (t0 + 300.0, t0 + 599.0):  # same interval: the records held at q0, weighed at t
        for nch in (1, 3):
            got = drag(held, t, q1, nch)
            np.testing.assert_array_equal(got, held_drag(t, q0, q1))
            assert not np.array_equal(got, drag(exact, t, q1))
    # a new interval resamples at q1; a step back in time resamples too
    np.testing.assert_array_equal(drag(held, t0 + 600.0, q1), drag(exact, t0 + 600.0, q1))
    np.testing.assert_array_equal(drag(held, t0 + 100.0, q0), drag(exact, t0 + 100.0, q0))
    # a new pair of records (6 h) inside the interval resamples at once
    held2 = field(tmp_path, u_file="uwnd.nc", v_file="vwnd.nc", resample=3600.0)
    drag(held2, 6 * HOUR - 100.0, q0)
    np.testing.assert_array_equal(drag(held2, 6 * HOUR + 100.0, q1),
                                  drag(exact, 6 * HOUR + 100.0, q1))
