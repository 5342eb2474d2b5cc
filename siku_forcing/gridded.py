"""Gridded velocity fields from NetCDF files: NCEP/NCAR reanalysis, ERA5, any CF lat/lon grid.

Scene use (paths relative to the scene file's directory; glob patterns such as
``uwnd.10m.gauss.*.nc`` join several files, e.g. years, along time)::

    # NCEP/NCAR reanalysis: one file per component, variables uwnd / vwnd (the defaults)
    field = { type = "gridded", params = { u_file = "uwnd.10m.2001.nc", v_file = "vwnd.10m.2001.nc" } }
    # any CF lat/lon file holding both components, with a name mapping
    field = { type = "gridded", params = { file = "era5.nc", u = "u10", v = "v10",
                                           lat = "latitude", lon = "longitude", time = "time" } }

Reading
    xarray (netCDF4 engine) with CF decoding: packed ``int16`` data are unpacked with
    ``scale_factor``/``add_offset``, ``_FillValue``/``missing_value`` become NaN, times are decoded
    from their ``units`` (e.g. ``hours since 1800-01-01``) and ``calendar``. xarray is imported
    when a gridded field is set up, never when this module is imported. The coordinate names
    ``lat``, ``lon``, ``time`` are found from CF attributes (``standard_name``, ``units``
    ``degrees_north``/``degrees_east``, datetime values) or common names unless given. Other
    dimensions must have length 1 (a ``level`` of one height). Units must be m/s (``m/s``,
    ``m s-1``, ``m s**-1``, ...). A variable without a time dimension is a steady field (no
    ``[time] start`` needed); otherwise the scene must give ``[time] start`` and the records must
    cover ``[start, start + duration]``.

Laziness and caching
    Setup reads only coordinates. ``sample(t)`` needs the two records bracketing ``t``; they are
    read (one 2-D slab per component, nothing else) when first needed and kept, at most three
    records at a time, so a run that advances through the file reads each record once.
    ``records_read`` lists the record indices read, in order.

Interpolation (numba kernel, vectorised over the points)
    * time: linear between the two bracketing records (the original model held each record);
    * space: bilinear in (longitude, latitude) on the grid, which may be irregular (Gaussian
      latitudes); latitudes in either order, longitudes in -180..180, 0..360 or any rotation;
    * longitude wrap-around: on a global grid (longitudes that close the circle) the cell between
      the last longitude and the first + 360° (e.g. 357.5° → 360°) interpolates between those two
      columns (the original returned zero there);
    * regional grids (not closing in longitude, or not reaching a pole): zero velocity outside,
      and one warning the first time any point is outside.

Poles
    East and north components are ill-defined at a pole: every longitude's east/north frame is a
    different rotation of the one tangent plane there, so a velocity that is smooth across the
    pole has components that change with longitude (a uniform flow ``W`` over the North Pole reads
    ``u = -W_x sin(lon) + W_y cos(lon)``, ``v = -W_x cos(lon) - W_y sin(lon)``). Averaging ``u`` and
    ``v`` along the last row therefore gives nonsense (near zero for a flow straight over the
    pole), and holding the last row makes the field depend on the direction a point approaches
    the pole from. Here, on a grid whose longitudes close the circle and whose last latitude row
    is within one row spacing of the pole (but not on it: a row at ±90° is used as given):

    1. the pole vector ``W = (W_x, W_y, 0)`` (Earth-fixed axes, tangent to the sphere at the pole)
       is the least-squares fit of ``u_j = W·east(lon_j)``, ``v_j = W·north(lat_row, lon_j)`` to
       the last row, i.e. the vector mean of the row transformed consistently. It reproduces a
       flow that is uniform over the pole exactly (``W`` is exact at the pole itself);
    2. a point between the last row and the pole gets, per component,
       ``(1 - s) * row(lon) + s * pole(lon)``, ``s = (lat - lat_row)/(±90° - lat_row)``, where
       ``row(lon)`` is the row interpolated linearly in longitude and ``pole(lon)`` is ``W`` in the
       east/north frame of ``lon`` at the pole. The field is continuous across the last row and at
       the pole gives the same vector ``W`` from every longitude.

    (A point exactly at a pole has no longitude of its own: its components are those of ``W`` in
    the frame of the longitude it is given with, which is the frame its caller maps them with.)

Missing data
    NaN (including decoded fill values) in a record read raises :class:`DataError` naming the
    file, time and position, unless ``fill_nan = "zero"``: then those grid values are zero (land
    points of ocean-current products, for instance), which tapers an interpolated current to
    zero over the last cell before land.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import glob as _glob
import math
import warnings
from struct import error as struct_error
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit

from siku_core import Param, hookimpl
from siku_core.errors import DataError, SceneError
from siku_core.interfaces import Field

#: accepted spellings of metres per second (compared after lower-casing and collapsing blanks)
SPEED_UNITS = frozenset({
    "m/s", "m s-1", "m s**-1", "m s^-1", "m.s-1", "m*s-1", "m*s**-1", "m*s^-1", "ms-1",
    "m s^(-1)", "m s**(-1)", "m/sec", "m sec-1", "meter/second", "meters/second",
    "metre/second", "metres/second", "meter second-1", "meters second-1", "metre second-1",
    "metres second-1", "meter s-1", "meters s-1", "metre s-1", "metres s-1", "meters per second",
    "metres per second",
})
_LAT_UNITS = frozenset({"degrees_north", "degree_north", "degree_n", "degrees_n", "degreen",
                        "degreesn"})
_LON_UNITS = frozenset({"degrees_east", "degree_east", "degree_e", "degrees_e", "degreee",
                        "degreese"})
_LAT_NAMES = ("lat", "latitude", "nav_lat", "lat_0", "g0_lat_0", "y")
_LON_NAMES = ("lon", "longitude", "nav_lon", "lon_0", "g0_lon_1", "x")
_TIME_NAMES = ("time", "valid_time", "t", "times", "date")

#: points this close [rad] outside the grid edge (about 6 mm) count as on it
_EDGE = 1e-9


# --------------------------------------------------------------------------- kernel
@njit(cache=True)
def _locate(a, x):
    """Largest ``i`` in ``[0, len(a) - 2]`` with ``a[i] <= x`` (``a`` ascending).

    Starts from the guess of a regular grid and walks: O(1) on regular and Gaussian grids.
    """
    n = a.shape[0]
    i = int((x - a[0]) / (a[n - 1] - a[0]) * (n - 1))
    if i < 0:
        i = 0
    elif i > n - 2:
        i = n - 2
    while i > 0 and a[i] > x:
        i -= 1
    while i < n - 2 and a[i + 1] <= x:
        i += 1
    return i


@njit(cache=True)
def _interp(lat, lon, ylat, xoff, lon0, periodic, cap_s, cap_n, U0, V0, P0, U1, V1, P1, alpha,
            u, v):
    """Bilinear-in-space, linear-in-time interpolation; returns (points outside, first one).

    ``ylat (ny)`` ascending latitudes [rad]; ``xoff (nx)`` ascending longitude offsets from
    ``lon0`` in ``[0, 2 pi)`` [rad]; ``U0, V0 (ny, nx)`` / ``U1, V1`` the two records, weights
    ``1 - alpha`` and ``alpha``; ``P0, P1 (2, 2)`` pole vectors ``(W_x, W_y)`` south [0], north [1].
    """
    twopi = 2.0 * math.pi
    halfpi = 0.5 * math.pi
    ny = ylat.shape[0]
    nx = xoff.shape[0]
    nout = 0
    first = -1
    for k in range(lat.shape[0]):
        y = lat[k]
        x = lon[k] - lon0
        x = x - twopi * math.floor(x / twopi)
        if x >= twopi:
            x = 0.0
        # ---- longitude cell j0, j1 and weight fx
        inside = True
        j0 = 0
        j1 = 1
        fx = 0.0
        xl = xoff[nx - 1]
        if x > xl and periodic:  # the wrap-around cell: last column -> first column + 2 pi
            j0 = nx - 1
            j1 = 0
            fx = (x - xl) / (twopi - xl)
        else:
            if x > xl:  # regional grid: on its edge or outside
                if x - xl <= _EDGE:
                    x = xl
                elif twopi - x <= _EDGE:
                    x = 0.0
                else:
                    inside = False
            if inside:
                j0 = _locate(xoff, x)
                j1 = j0 + 1
                fx = (x - xoff[j0]) / (xoff[j1] - xoff[j0])
        # ---- latitude: interior cell, polar cap or outside
        cap = 0  # -1 south cap, +1 north cap
        if inside:
            if y < ylat[0]:
                if cap_s:
                    cap = -1
                elif ylat[0] - y <= _EDGE:
                    y = ylat[0]
                else:
                    inside = False
            elif y > ylat[ny - 1]:
                if cap_n:
                    cap = 1
                elif y - ylat[ny - 1] <= _EDGE:
                    y = ylat[ny - 1]
                else:
                    inside = False
        if not inside:
            u[k] = 0.0
            v[k] = 0.0
            if nout == 0:
                first = k
            nout += 1
            continue
        if cap == 0:
            i0 = _locate(ylat, y)
            fy = (y - ylat[i0]) / (ylat[i0 + 1] - ylat[i0])
            w00 = (1.0 - fy) * (1.0 - fx)
            w01 = (1.0 - fy) * fx
            w10 = fy * (1.0 - fx)
            w11 = fy * fx
            a0 = w00 * U0[i0, j0] + w01 * U0[i0, j1] + w10 * U0[i0 + 1, j0] + w11 * U0[i0 + 1, j1]
            b0 = w00 * V0[i0, j0] + w01 * V0[i0, j1] + w10 * V0[i0 + 1, j0] + w11 * V0[i0 + 1, j1]
            a1 = w00 * U1[i0, j0] + w01 * U1[i0, j1] + w10 * U1[i0 + 1, j0] + w11 * U1[i0 + 1, j1]
            b1 = w00 * V1[i0, j0] + w01 * V1[i0, j1] + w10 * V1[i0 + 1, j0] + w11 * V1[i0 + 1, j1]
        else:
            r = 0 if cap < 0 else ny - 1
            side = 0 if cap < 0 else 1
            sp = float(cap)
            s = (y - ylat[r]) / (sp * halfpi - ylat[r])
            s = min(s, 1.0)
            sl = math.sin(lon[k])
            cl = math.cos(lon[k])
            # pole vector W in the east/north frame of this longitude at the pole
            pu0 = -P0[side, 0] * sl + P0[side, 1] * cl
            pv0 = -sp * (P0[side, 0] * cl + P0[side, 1] * sl)
            pu1 = -P1[side, 0] * sl + P1[side, 1] * cl
            pv1 = -sp * (P1[side, 0] * cl + P1[side, 1] * sl)
            a0 = (1.0 - s) * ((1.0 - fx) * U0[r, j0] + fx * U0[r, j1]) + s * pu0
            b0 = (1.0 - s) * ((1.0 - fx) * V0[r, j0] + fx * V0[r, j1]) + s * pv0
            a1 = (1.0 - s) * ((1.0 - fx) * U1[r, j0] + fx * U1[r, j1]) + s * pu1
            b1 = (1.0 - s) * ((1.0 - fx) * V1[r, j0] + fx * V1[r, j1]) + s * pv1
        if alpha == 0.0:
            u[k] = a0
            v[k] = b0
        else:
            u[k] = (1.0 - alpha) * a0 + alpha * a1
            v[k] = (1.0 - alpha) * b0 + alpha * b1
    return nout, first


def pole_vector(u_row: np.ndarray, v_row: np.ndarray, lat_row: float, lon: np.ndarray) -> tuple[
        float, float]:
    """Least-squares pole vector ``(W_x, W_y)`` [m/s] from one latitude row (see module doc).

    ``u_row, v_row`` east and north components on the row at latitude ``lat_row`` and
    longitudes ``lon`` [rad]. Fits ``u = -W_x sin(lon) + W_y cos(lon)`` and
    ``v = -sin(lat_row) (W_x cos(lon) + W_y sin(lon))``: the east/north components of the
    horizontal vector ``W`` tangent at the pole, seen from the row.
    """
    sl, cl, sg = np.sin(lon), np.cos(lon), math.sin(lat_row)
    A = np.concatenate([np.stack([-sl, cl], axis=1), np.stack([-sg * cl, -sg * sl], axis=1)])
    b = np.concatenate([u_row, v_row])
    w = np.linalg.lstsq(A, b, rcond=None)[0]
    return float(w[0]), float(w[1])


# --------------------------------------------------------------------------- helpers
def _norm_units(text: Any) -> str:
    return " ".join(str(text).strip().lower().split())


#: byte sizes of the NetCDF classic types (NC_BYTE .. NC_UINT64)
_NC_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 4, 6: 8, 7: 1, 8: 2, 9: 4, 10: 8, 11: 8}


def classic_size(path: Path) -> tuple[int, int] | None:
    """``(bytes, records)`` a NetCDF classic file (CDF-1, CDF-2 or CDF-5) must have according to
    its header (NetCDF classic format specification), or ``None`` for other files; a header
    that cannot be parsed raises ``ValueError``."""
    import struct

    with open(path, "rb") as fh:
        magic = fh.read(4)
        if magic[:3] != b"CDF" or len(magic) < 4 or magic[3] not in (1, 2, 5):
            return None
        v = magic[3]

        def take(n: int) -> bytes:
            b = fh.read(n)
            if len(b) < n:
                raise ValueError("header cut short")
            return b

        def u32() -> int:
            return struct.unpack(">I", take(4))[0]

        def u64() -> int:
            return struct.unpack(">Q", take(8))[0]

        count = u64 if v == 5 else u32
        offset = u64 if v in (2, 5) else u32

        def name() -> None:
            n = count()
            take(n + (-n) % 4)

        def attributes() -> None:
            tag, n = u32(), count()
            if tag not in (0, 0x0C):
                raise ValueError(f"bad attribute list tag {tag}")
            for _ in range(n):
                name()
                t = u32()
                k = count() * _NC_SIZES.get(t, 1)
                take(k + (-k) % 4)

        numrecs = count()
        if numrecs in (0xFFFFFFFF, 0xFFFFFFFFFFFFFFFF):  # streaming: no record count
            return None
        u32()  # NC_DIMENSION tag (or ABSENT)
        n = count()
        dims = []
        for _ in range(n):
            name()
            dims.append(count())
        attributes()
        u32()  # NC_VARIABLE tag (or ABSENT)
        n = count()
        fixed_end, records = 0, []
        for _ in range(n):
            name()
            ids = [count() for _ in range(count())]
            attributes()
            size = _NC_SIZES.get(u32(), 1)
            vsize = count()
            begin = offset()
            shape = [dims[i] for i in ids]
            if shape and shape[0] == 0:  # a record variable
                per = size * int(np.prod(shape[1:], dtype=np.int64))
                records.append((begin, per, vsize))
            else:
                fixed_end = max(fixed_end, begin + size * int(np.prod(shape, dtype=np.int64)))
        end = fixed_end
        if records and numrecs:
            recsize = records[0][1] if len(records) == 1 else sum(r[2] for r in records)
            end = max(end, max(b + (numrecs - 1) * recsize + per for b, per, _ in records))
        return end, numrecs


def check_complete(path: Path, where: str) -> None:
    """Refuse a NetCDF classic file shorter than its header says (a download or copy cut
    short: the NetCDF library would read the missing records as zeros)."""
    try:
        need = classic_size(path)
    except (ValueError, OSError, struct_error) as exc:
        raise DataError(f"{where}: {path}: not a readable NetCDF file ({exc})") from None
    if need is None:
        return
    size = path.stat().st_size
    if size < need[0]:
        recs = f" ({need[1]} records)" if need[1] else ""
        raise DataError(f"{where}: {path} is cut short: its header describes {need[0]} bytes"
                        f"{recs} but the file has {size} (an interrupted download or copy?)")


def _iso(t: np.datetime64) -> str:
    return str(np.datetime_as_string(np.datetime64(t, "s"), unit="s"))


class _Grid:
    """Longitudes/latitudes of the file and how they map onto the kernel's sorted grid."""

    def __init__(self, lat_deg: np.ndarray, lon_deg: np.ndarray, where: str):
        lat_deg = np.asarray(lat_deg, dtype=np.float64)
        lon_deg = np.asarray(lon_deg, dtype=np.float64)
        if lat_deg.ndim != 1 or lon_deg.ndim != 1:
            raise DataError(f"{where}: latitude and longitude must be 1-D coordinates (a regular "
                            "or Gaussian lat/lon grid); curvilinear grids are not supported")
        if lat_deg.size < 2 or lon_deg.size < 2:
            raise DataError(f"{where}: the grid needs at least 2 latitudes and 2 longitudes, "
                            f"found {lat_deg.size} × {lon_deg.size}")
        if not (np.isfinite(lat_deg).all() and np.isfinite(lon_deg).all()):
            raise DataError(f"{where}: non-finite latitude or longitude coordinate values")
        if lat_deg.min() < -90.0 - 1e-9 or lat_deg.max() > 90.0 + 1e-9:
            raise DataError(f"{where}: latitudes {lat_deg.min():g}..{lat_deg.max():g} are outside "
                            "-90..90 degrees")
        self.lat_order = np.argsort(lat_deg, kind="stable")
        lat_s = np.clip(lat_deg[self.lat_order], -90.0, 90.0)
        if np.any(np.diff(lat_s) <= 0):
            raise DataError(f"{where}: latitudes are not strictly monotonic")
        m = np.mod(lon_deg, 360.0)
        order = np.argsort(m, kind="stable")
        ms = m[order]
        keep = np.concatenate([[True], np.diff(ms) > 1e-9])  # e.g. both 0 and 360 present
        if ms[0] + 360.0 - ms[-1] <= 1e-9:  # e.g. 0 and 359.9999999999
            keep[-1] = False
        order, ms = order[keep], ms[keep]
        if ms.size < 2:
            raise DataError(f"{where}: fewer than 2 distinct longitudes")
        gaps = np.diff(np.concatenate([ms, [ms[0] + 360.0]]))
        self.periodic = bool(gaps.max() < 1.5 * np.median(gaps))
        if not self.periodic:  # regional: start after the largest gap
            order = np.roll(order, -(int(np.argmax(gaps)) + 1))
        self.lon_order = order
        lon0 = float(m[order[0]])
        xoff = np.mod(m[order] - lon0, 360.0)
        self.lon0_deg = lon0
        self.xoff = np.radians(xoff)
        self.lon_abs = np.radians(lon0 + xoff)  # sorted longitudes [rad], for the pole fit
        self.ylat = np.radians(lat_s)
        self.lat_deg = lat_s
        self.lon_deg = lon0 + xoff
        n_gap = 90.0 - lat_s[-1]
        s_gap = lat_s[0] + 90.0
        self.cap_n = self.periodic and 1e-9 < n_gap <= 1.01 * (lat_s[-1] - lat_s[-2])
        self.cap_s = self.periodic and 1e-9 < s_gap <= 1.01 * (lat_s[1] - lat_s[0])

    def reorder(self, a: np.ndarray) -> np.ndarray:
        """A ``(ny, nx)`` slab in file order → the kernel's sorted order, float64."""
        return np.ascontiguousarray(
            np.asarray(a, dtype=np.float64)[np.ix_(self.lat_order, self.lon_order)])

    def describe(self) -> str:
        lon = ("global (wraps around)" if self.periodic else
               f"{self.lon_deg[0]:g}..{self.lon_deg[-1]:g}")
        return f"lat {self.lat_deg[0]:g}..{self.lat_deg[-1]:g}, lon {lon}"


class _Component:
    """One velocity component: its files in time order, the variable, dims and record index."""

    def __init__(self, name: str, paths: list[Path], var: str, names: dict[str, str],
                 where: str, xr: Any):
        self.name, self.var, self.where = name, var, where
        self.paths: list[Path] = []
        self.arrays: list[Any] = []  # lazy DataArrays, dims (time, lat, lon) or (lat, lon)
        self.datasets: list[Any] = []
        self.lat = self.lon = None
        times: list[np.ndarray] = []
        self.tdim: str | None = None
        for p in paths:
            check_complete(p, where)
            try:
                ds = xr.open_dataset(p, engine="netcdf4", cache=False, decode_timedelta=False)
            except Exception as exc:  # noqa: BLE001 - any reader failure is a data error
                hint = ""
                if "HDF error" in str(exc):
                    hint = " (an HDF5-based NetCDF-4 file that is cut short or corrupt?)"
                raise DataError(f"{where}: cannot read {p} as NetCDF: {exc}{hint}") from None
            self.datasets.append(ds)
            da, lat, lon, t = self._open_var(ds, p, names)
            if self.lat is None:
                self.lat, self.lon = lat, lon
            elif not (lat.shape == self.lat.shape and np.allclose(lat, self.lat, atol=1e-9)
                      and lon.shape == self.lon.shape and np.allclose(lon, self.lon, atol=1e-9)):
                raise DataError(f"{where}: {p}: grid differs from {self.paths[0]}'s "
                                f"({lat.size} × {lon.size} vs {self.lat.size} × {self.lon.size} "
                                "lat × lon, or different coordinate values)")
            if self.paths and (t is None) != (not times):
                raise DataError(f"{where}: {p}: has {'no' if t is None else 'a'} time dimension "
                                f"unlike {self.paths[0]}")
            self.paths.append(p)
            self.arrays.append(da)
            if t is not None:
                times.append(t)
        if self.tdim is not None:
            if len(paths) > 1:  # several files: put them in time order
                firsts = [t[0] for t in times]
                idx = sorted(range(len(paths)), key=lambda i: firsts[i])
                self.paths = [self.paths[i] for i in idx]
                self.arrays = [self.arrays[i] for i in idx]
                self.datasets = [self.datasets[i] for i in idx]
                times = [times[i] for i in idx]
            self.times = np.concatenate(times)
            self.rec_file = np.concatenate([np.full(t.size, i) for i, t in enumerate(times)])
            self.rec_local = np.concatenate([np.arange(t.size) for t in times])
            bad = np.flatnonzero(np.diff(self.times) <= np.timedelta64(0, "ns"))
            if bad.size:
                k = int(bad[0])
                raise DataError(
                    f"{where}: time records of {self.label()} are not strictly increasing: "
                    f"{_iso(self.times[k])} ({self.paths[self.rec_file[k]]}) is followed by "
                    f"{_iso(self.times[k + 1])} ({self.paths[self.rec_file[k + 1]]})")
        else:
            if len(paths) > 1:
                raise DataError(f"{where}: {len(paths)} files match {self.label()} but "
                                f"'{var}' has no time dimension to join them along")
            self.times = None

    def label(self) -> str:
        return str(self.paths[0]) if len(self.paths) == 1 else \
            f"{self.paths[0]} .. {self.paths[-1]} ({len(self.paths)} files)"

    def _open_var(self, ds: Any, path: Path, names: dict[str, str]):
        where, var = self.where, self.var
        if var not in ds.variables:
            present = ", ".join(sorted(map(str, ds.data_vars))) or "(none)"
            coords = ", ".join(sorted(map(str, ds.coords)))
            raise DataError(f"{where}: {path} has no variable '{var}' (the {self.name} "
                            f"component); variables present: {present}; coordinates: {coords}; "
                            f"set '{self.name} = \"...\"' in the field's params")
        da = ds[var]
        units = da.attrs.get("units", da.encoding.get("units"))
        if units is None or _norm_units(units) not in SPEED_UNITS:
            found = "no units attribute" if units is None else f"units '{units}'"
            raise DataError(f"{where}: {path}: variable '{var}' has {found}; expected a "
                            "velocity in m/s ('m/s', 'm s-1' or 'm s**-1')")
        dims = list(map(str, da.dims))
        lat_d = self._find_dim(ds, da, dims, "lat", names, path)
        lon_d = self._find_dim(ds, da, dims, "lon", names, path)
        t_d = self._find_dim(ds, da, dims, "time", names, path)
        for d in dims:
            if d not in (lat_d, lon_d, t_d):
                if da.sizes[d] != 1:
                    raise DataError(
                        f"{where}: {path}: variable '{var}' has dimension '{d}' of length "
                        f"{da.sizes[d]} besides time/lat/lon; select one level first (e.g. "
                        "ncks -d or xarray .isel) or name the coordinates with lat/lon/time")
                da = da.isel({d: 0})
        if t_d is not None and self.tdim is None:
            self.tdim = t_d
        order = [d for d in (t_d, lat_d, lon_d) if d is not None]
        da = da.transpose(*order)
        for d in (lat_d, lon_d):
            if d not in ds.variables:
                raise DataError(f"{where}: {path}: dimension '{d}' of '{var}' has no coordinate "
                                "variable holding its values in degrees")
        lat = np.asarray(ds[lat_d].values, dtype=np.float64)
        lon = np.asarray(ds[lon_d].values, dtype=np.float64)
        times = None
        if t_d is not None:
            times = self._times(ds, t_d, path)
        return da, lat, lon, times

    def _find_dim(self, ds, da, dims, role, names, path):
        where, var = self.where, self.var
        given = names.get(role, "")
        if given:
            if given in dims:
                return given
            # a coordinate variable of that name along some dimension of the variable
            if given in ds.variables and ds[given].ndim == 1 and str(ds[given].dims[0]) in dims:
                return str(ds[given].dims[0])
            raise DataError(f"{where}: {path}: variable '{var}' has no {role} dimension "
                            f"'{given}'; its dimensions are {', '.join(dims)}; variables "
                            f"present: {', '.join(sorted(map(str, ds.variables)))}")
        for d in dims:
            c = ds[d] if d in ds.variables else None
            attrs = {} if c is None else {k: _norm_units(x) for k, x in c.attrs.items()}
            sn, un = attrs.get("standard_name", ""), attrs.get("units", "").replace(" ", "")
            if role == "lat" and (sn in ("latitude", "grid_latitude") or un in _LAT_UNITS):
                return d
            if role == "lon" and (sn in ("longitude", "grid_longitude") or un in _LON_UNITS):
                return d
            if role == "time" and c is not None and (
                    sn == "time" or attrs.get("axis", "") == "t"
                    or np.issubdtype(c.dtype, np.datetime64) or c.dtype == object):
                return d
        cands = {"lat": _LAT_NAMES, "lon": _LON_NAMES, "time": _TIME_NAMES}[role]
        for d in dims:
            if d.lower() in cands:
                return d
        if role == "time":
            return None
        raise DataError(f"{where}: {path}: cannot tell which dimension of '{var}' "
                        f"({', '.join(dims)}) is {role}itude; set {role} = \"...\" in the field's "
                        "params")

    def _times(self, ds, t_d, path) -> np.ndarray:
        c = ds[t_d]
        vals = c.values
        if np.issubdtype(vals.dtype, np.datetime64):
            return vals.astype("datetime64[ns]")
        if vals.dtype == object and vals.size and hasattr(vals.flat[0], "calendar"):
            cal = str(getattr(vals.flat[0], "calendar", ""))
            if cal in ("standard", "gregorian", "proleptic_gregorian", "julian", ""):
                return np.array([np.datetime64(x.isoformat()) for x in vals.flat],
                                dtype="datetime64[ns]")
            raise DataError(f"{self.where}: {path}: time '{t_d}' uses the calendar '{cal}'; only "
                            "the standard (Gregorian) calendar is supported")
        units = c.attrs.get("units", c.encoding.get("units", "(none)"))
        raise DataError(f"{self.where}: {path}: cannot decode the times of '{t_d}' (units "
                        f"'{units}'); CF time units look like 'hours since 1800-01-01'")

    def read(self, rec: int | None) -> tuple[np.ndarray, Path, int]:
        """The raw ``(ny, nx)`` slab of record ``rec`` (``None``: the steady field)."""
        if rec is None:
            return np.asarray(self.arrays[0].values), self.paths[0], 0
        f, k = int(self.rec_file[rec]), int(self.rec_local[rec])
        return np.asarray(self.arrays[f].isel({self.tdim: k}).values), self.paths[f], k

    def close(self) -> None:
        for ds in self.datasets:
            with contextlib.suppress(Exception):  # closing must not fail a run
                ds.close()
        self.datasets, self.arrays = [], []


# --------------------------------------------------------------------------- the field
class Gridded(Field):
    """A wind or current field read from NetCDF files (NCEP/NCAR reanalysis, ERA5, CF lat/lon).

    ``u_file`` and ``v_file`` (NCEP/NCAR: variables ``uwnd``, ``vwnd``), or one ``file`` with both
    components. Bilinear in space with longitude wrap-around and a pole cap (vector-consistent),
    linear in time, zero outside a regional grid (with one warning). Only the records the run
    needs are read. See :mod:`siku_forcing.gridded`.
    """

    name = "gridded"
    params = {
        "file": Param("", "", "NetCDF file holding both components (relative to the scene; "
                      "glob patterns join files along time)", type=str),
        "u_file": Param("", "", "NetCDF file of the eastward component (with v_file)", type=str),
        "v_file": Param("", "", "NetCDF file of the northward component (with u_file)", type=str),
        "u": Param("uwnd", "", "name of the eastward-velocity variable", type=str),
        "v": Param("vwnd", "", "name of the northward-velocity variable", type=str),
        "lat": Param("", "", "latitude dimension name (empty: from CF attributes)", type=str),
        "lon": Param("", "", "longitude dimension name (empty: from CF attributes)", type=str),
        "time": Param("", "", "time dimension name (empty: from CF attributes)", type=str),
        "fill_nan": Param("error", "", "NaN in the data: 'error', or 'zero' to use 0 m/s there",
                          type=str, choices=("error", "zero")),
    }
    #: one of these parameter groups must be given (the conformance suite skips the field
    #: without them: it has no data file to read)
    required_one_of = (("file",), ("u_file", "v_file"))

    #: record indices read, in order (both components of a record count once)
    records_read: list[int]

    # ------------------------------------------------------------------ setup
    def setup(self, sim) -> None:
        self.close()
        self._sim = sim
        self.where = self._where(sim)
        p = self.p
        if p["file"] and (p["u_file"] or p["v_file"]):
            raise SceneError(f"{self.where}: give either 'file' (both components in one file) or "
                             "'u_file' and 'v_file', not both")
        if not p["file"] and not (p["u_file"] and p["v_file"]):
            raise SceneError(f"{self.where}: the gridded field needs 'file' (both components) or "
                             "'u_file' and 'v_file', e.g. params = { u_file = "
                             "\"uwnd.10m.2001.nc\", v_file = \"vwnd.10m.2001.nc\" }")
        base = Path(getattr(sim.scene, "base_dir", Path.cwd()))
        key_u, key_v = ("file", "file") if p["file"] else ("u_file", "v_file")
        u_paths = self._paths(base, key_u)
        v_paths = u_paths if key_v == key_u else self._paths(base, key_v)
        try:
            import xarray as xr
        except ImportError as exc:  # pragma: no cover - xarray is a dependency
            raise DataError(f"{self.where}: gridded fields need xarray and netCDF4 "
                            f"(pip install xarray netCDF4): {exc}") from None
        names = {"lat": p["lat"], "lon": p["lon"], "time": p["time"]}
        self.cu = _Component("u", u_paths, p["u"], names, self.where, xr)
        self.cv = _Component("v", v_paths, p["v"], names, self.where, xr)
        cu, cv = self.cu, self.cv
        if not (np.array_equal(cu.lat, cv.lat) and np.array_equal(cu.lon, cv.lon)):
            raise DataError(f"{self.where}: the grids of {cu.label()} ('{cu.var}') and "
                            f"{cv.label()} ('{cv.var}') differ")
        self.grid = _Grid(cu.lat, cu.lon, f"{self.where}: {cu.label()}")
        if (cu.times is None) != (cv.times is None) or (
                cu.times is not None and not np.array_equal(cu.times, cv.times)):
            raise DataError(f"{self.where}: the time records of {cu.label()} ('{cu.var}') and "
                            f"{cv.label()} ('{cv.var}') differ")
        self.t_rec: np.ndarray | None = None
        if cu.times is not None:
            self.t_rec = self._record_seconds(sim, cu.times)
        self.records_read = []
        self._cache: dict[Any, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._warned = False

    def _where(self, sim) -> str:
        scene = sim.scene
        for k, src in enumerate(getattr(sim, "forcing", [])):
            if getattr(src, "field", None) is self:
                return scene.where(f"forcing[{k}].field")
        return f"{getattr(scene, 'label', '<scene>')} (gridded field)"

    def _paths(self, base: Path, key: str) -> list[Path]:
        text = str(self.p[key])
        pat = Path(text).expanduser()
        pat = pat if pat.is_absolute() else base / pat
        if any(ch in text for ch in "*?["):
            found = sorted(Path(x) for x in _glob.glob(str(pat)))
            if not found:
                raise DataError(f"{self.where}: no file matches {key} = '{text}' ({pat})")
            return found
        if not pat.is_file():
            raise DataError(f"{self.where}: data file not found: {pat} ({key} = '{text}', "
                            f"relative paths are resolved against {base})")
        return [pat]

    def _record_seconds(self, sim, times: np.ndarray) -> np.ndarray:
        cu = self.cu
        rng = f"{_iso(times[0])} .. {_iso(times[-1])}"
        start = getattr(sim, "start", None)
        if start is None:
            raise SceneError(
                f"{self.where}: the gridded field's file {cu.label()} has time records "
                f"({rng}); the scene needs [time] start (e.g. start = 2001-01-01T00:00:00) to "
                "place the run among them")
        if start.tzinfo is not None:
            start = start.astimezone(_dt.UTC).replace(tzinfo=None)
        t0 = np.datetime64(start, "ns")
        secs = (times - t0).astype("timedelta64[ns]").astype(np.int64) / 1e9
        total = float(sim.n_steps) * float(sim.dt)
        if secs[0] > 1e-6 or secs[-1] < total - 1e-6:
            end = t0 + np.timedelta64(round(total * 1e9), "ns")
            raise DataError(
                f"{self.where}: time records of {cu.label()} ({rng}) do not cover the run "
                f"({_iso(t0)} .. {_iso(end)}); use files for the run's dates (a glob pattern "
                "such as 'uwnd.10m.*.nc' joins years) or move [time] start")
        return secs.astype(np.float64)

    # ------------------------------------------------------------------ records
    def _record(self, rec: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        hit = self._cache.get(rec)
        if hit is not None:
            return hit
        if not self.cu.arrays:  # closed after a run: reopen
            self._reopen()
        g = self.grid
        out = []
        for comp in (self.cu, self.cv):
            raw, path, k = comp.read(rec)
            a = g.reorder(raw)
            bad = np.isnan(a)
            if bad.any():
                if self.p["fill_nan"] == "zero":
                    a[bad] = 0.0
                else:
                    i, j = np.argwhere(bad)[0]
                    when = "" if rec is None else f" at {_iso(comp.times[rec])} (record {k})"
                    raise DataError(
                        f"{self.where}: {path}: variable '{comp.var}' has {int(bad.sum())} "
                        f"NaN or missing value(s){when}, the first at lat {g.lat_deg[i]:g}, "
                        f"lon {g.lon_deg[j]:g}; set fill_nan = \"zero\" to use 0 m/s there")
            out.append(a)
        U, V = out
        P = np.zeros((2, 2))
        if g.cap_s:
            P[0] = pole_vector(U[0], V[0], float(g.ylat[0]), g.lon_abs)
        if g.cap_n:
            P[1] = pole_vector(U[-1], V[-1], float(g.ylat[-1]), g.lon_abs)
        self.records_read.append(-1 if rec is None else int(rec))
        self._cache[rec] = (U, V, P)
        return U, V, P

    def _reopen(self) -> None:
        """Reopen the files after :meth:`close` (a field sampled again after a run ended)."""
        keep = self._cache, self.records_read, self._warned
        self.setup(self._sim)
        self._cache, self.records_read, self._warned = keep

    def bracket(self, t: float) -> tuple[int | None, int | None, float]:
        """The records bracketing ``t`` [s] and the weight of the second (``None``: ``t`` is on
        the first record, or the field is steady, and only that one is needed)."""
        tr = self.t_rec
        if tr is None:
            return None, None, 0.0
        tol = 1e-6
        if t < tr[0] - tol or t > tr[-1] + tol:
            t0 = self.cu.times[0]
            at = t0 + np.timedelta64(round((t - tr[0]) * 1e9), "ns")
            raise DataError(f"{self.where}: time {_iso(at)} (t = {t:g} s) is outside the records "
                            f"of {self.cu.label()} ({_iso(self.cu.times[0])} .. "
                            f"{_iso(self.cu.times[-1])})")
        k = int(np.searchsorted(tr, t, side="right")) - 1
        k = min(max(k, 0), tr.size - 1)
        if k == tr.size - 1 or t <= tr[k]:  # on (or a rounding error before) a record
            return k, None, 0.0
        alpha = (t - tr[k]) / (tr[k + 1] - tr[k])
        return k, k + 1, min(alpha, 1.0)

    # ------------------------------------------------------------------ sampling
    def sample(self, t, lat, lon):
        lat = np.ascontiguousarray(lat, dtype=np.float64)
        lon = np.ascontiguousarray(lon, dtype=np.float64)
        k0, k1, alpha = self.bracket(float(t))
        U0, V0, P0 = self._record(k0)
        U1, V1, P1 = (U0, V0, P0) if k1 is None else self._record(k1)
        if k0 is not None and len(self._cache) > 3:
            for key in sorted(self._cache, key=lambda r: -abs(r - k0))[: len(self._cache) - 3]:
                if key not in (k0, k1):
                    del self._cache[key]
        g = self.grid
        n = lat.shape[0]
        u = np.empty(n)
        v = np.empty(n)
        nout, first = _interp(lat, lon, g.ylat, g.xoff, math.radians(g.lon0_deg), g.periodic,
                              g.cap_s, g.cap_n, U0, V0, P0, U1, V1, P1, float(alpha), u, v)
        if nout and not self._warned:
            self._warned = True
            warnings.warn(
                f"{self.where}: {nout} point(s) outside the grid of {self.cu.label()} "
                f"({g.describe()}), the first at lat {math.degrees(lat[first]):.4g}, lon "
                f"{math.degrees(lon[first]):.4g} at t = {float(t):g} s: the velocity is zero "
                "there (said once)", stacklevel=2)
        return u, v

    def close(self) -> None:
        for comp in (getattr(self, "cu", None), getattr(self, "cv", None)):
            if comp is not None:
                comp.close()


@hookimpl
def siku_register_fields():
    return [Gridded]
