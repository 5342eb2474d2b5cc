"""Gridded velocity fields from NetCDF files: NCEP/NCAR reanalysis, ERA5, any CF lat/lon grid.

Scene use (paths relative to the scene file's directory; glob patterns such as
``uwnd.10m.gauss.*.nc`` join several files, e.g. years, along time)::

    # NCEP/NCAR reanalysis: one file per component, variables uwnd / vwnd (the defaults)
    field = { type = "gridded", params = { u_file = "uwnd.10m.2001.nc",
                                           v_file = "vwnd.10m.2001.nc" } }
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

Modules
    This one holds the field (:class:`Gridded`: files, records, time bracketing, sampling);
    :mod:`siku_forcing.gridded.gridded_reader` reads a component's files,
    :mod:`siku_forcing.gridded.gridded_kernel`
    interpolates, :mod:`siku_forcing.gridded.cf` holds the CF rules shared with
    ``siku_io.mesh.icecover``.
"""
from __future__ import annotations

import datetime as _dt
import glob as _glob
import math
import warnings
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from siku_core import Param, hookimpl
from siku_core.errors import DataError, SceneError
from siku_core.geometry.quat import latlon_of
from siku_core.interfaces import Field
from siku_core.records import record_type

from .cf import SPEED_UNITS, classic_size, iso_seconds
from .gridded_drag import cached_stress, gridded_stress, gridded_values
from .gridded_kernel import interpolate, pole_vector
from .gridded_reader import ComponentReader, KernelGrid

# the reader, the kernels and the CF rules live in .gridded_reader, .gridded_kernel and .cf;
# names of this module's former contents that callers import from here
__all__ = ["SPEED_UNITS", "GridSample", "Gridded", "classic_size", "pole_vector",
           "siku_register_fields"]

#: the grid and the two records around a time, as the kernels take them
#: (:func:`siku_forcing.gridded.gridded_kernel.interpolate`, ``Gridded._records_at``)
GridSample = record_type("GridSample", __name__, [
    ("ylat", "f", 1, "(ny,) ascending latitudes of the grid [rad]"),
    ("xoff", "f", 1, "(nx,) ascending longitude offsets from lon0, in [0, 2 pi) [rad]"),
    ("lon0", "n", 0, "the grid's first longitude [rad]"),
    ("periodic", "n", 0, "the longitudes go round the globe (the last column wraps to the "
     "first)"),
    ("cap_s", "n", 0, "a pole cap below the southernmost row"),
    ("cap_n", "n", 0, "a pole cap above the northernmost row"),
    ("U0", "f", 2, "(ny, nx) east component of the first record [m/s]"),
    ("V0", "f", 2, "(ny, nx) north component of the first record [m/s]"),
    ("P0", "f", 2, "(2, 2) pole vectors (W_x, W_y) of the first record, south [0] and north "
     "[1] [m/s]"),
    ("U1", "f", 2, "(ny, nx) east component of the second record [m/s]"),
    ("V1", "f", 2, "(ny, nx) north component of the second record [m/s]"),
    ("P1", "f", 2, "(2, 2) pole vectors of the second record [m/s]"),
    ("alpha", "n", 0, "weight of the second record (1 - alpha: the first's) [1]"),
], doc="A gridded field's grid and its two records around a time (:class:`Gridded`).")


# --------------------------------------------------------------------------- the field
class Gridded(Field):
    """A wind or current field read from NetCDF files (NCEP/NCAR reanalysis, ERA5, CF lat/lon).

    ``u_file`` and ``v_file`` (NCEP/NCAR: variables ``uwnd``, ``vwnd``), or one ``file`` with both
    components. Bilinear in space with longitude wrap-around and a pole cap (vector-consistent),
    linear in time, zero outside a regional grid (with one warning). Only the records the run
    needs are read. See :mod:`siku_forcing.gridded.gridded_field`.
    """

    name = "gridded"
    params: ClassVar[dict[str, Param]] = {
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
        "quantity": Param("velocity", "", "what the variables hold: 'velocity' (m/s, checked), "
                          "or 'temperature' (a scalar read as the first component, e.g. by "
                          "the thermodynamics process, which checks its units)", type=str,
                          choices=("velocity", "temperature")),
        "resample": Param(0.0, "s", "drag only: interval at which the field is interpolated at "
                          "the elements' new positions again (between, each element keeps "
                          "its two records' values and only the weight in time changes; "
                          "0: every evaluation, the exact path)", min=0.0),
    }
    #: one of these parameter groups must be given (the conformance suite skips the field
    #: without them: it has no data file to read)
    required_one_of = (("file",), ("u_file", "v_file"))

    #: record indices read, in order (both components of a record count once)
    records_read: list[int]

    # ------------------------------------------------------------------ setup
    def setup(self, ctx) -> None:
        self.close()
        self._ctx = ctx
        self.where = self._where(ctx)
        p = self.p
        if p["file"] and (p["u_file"] or p["v_file"]):
            raise SceneError(f"{self.where}: give either 'file' (both components in one file) or "
                             "'u_file' and 'v_file', not both")
        if not p["file"] and not (p["u_file"] and p["v_file"]):
            raise SceneError(f"{self.where}: the gridded field needs 'file' (both components) or "
                             "'u_file' and 'v_file', e.g. params = { u_file = "
                             "\"uwnd.10m.2001.nc\", v_file = \"vwnd.10m.2001.nc\" }")
        base = Path(getattr(ctx.scene, "base_dir", Path.cwd()))
        key_u, key_v = ("file", "file") if p["file"] else ("u_file", "v_file")
        u_paths = self._paths(base, key_u)
        v_paths = u_paths if key_v == key_u else self._paths(base, key_v)
        try:
            import xarray as xr
        except ImportError as exc:  # pragma: no cover - xarray is a dependency
            raise DataError(f"{self.where}: gridded fields need xarray and netCDF4 "
                            f"(pip install xarray netCDF4): {exc}") from None
        names = {"lat": p["lat"], "lon": p["lon"], "time": p["time"]}
        self.cu = ComponentReader("u", u_paths, p["u"], names, self.where, xr, p["quantity"])
        self.cv = ComponentReader("v", v_paths, p["v"], names, self.where, xr, p["quantity"])
        cu, cv = self.cu, self.cv
        if not (np.array_equal(cu.lat, cv.lat) and np.array_equal(cu.lon, cv.lon)):
            raise DataError(f"{self.where}: the grids of {cu.label()} ('{cu.var}') and "
                            f"{cv.label()} ('{cv.var}') differ")
        self.grid = KernelGrid(cu.lat, cu.lon, f"{self.where}: {cu.label()}")
        if (cu.times is None) != (cv.times is None) or (
                cu.times is not None and not np.array_equal(cu.times, cv.times)):
            raise DataError(f"{self.where}: the time records of {cu.label()} ('{cu.var}') and "
                            f"{cv.label()} ('{cv.var}') differ")
        self.t_rec: np.ndarray | None = None
        if cu.times is not None:
            self.t_rec = self._record_seconds(ctx, cu.times)
        self.records_read = []
        self._cache: dict[Any, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._warned = False
        #: ``resample``: the elements' values of the two records (``gridded_values``), the
        #: records and element count they hold, and the model time they were taken at [s]
        self._held: tuple[np.ndarray, tuple, float] | None = None

    def _where(self, ctx) -> str:
        """The message prefix naming the scene table this field was built from."""
        if self.table:
            return ctx.scene.where(self.table)
        return f"{getattr(ctx.scene, 'label', '<scene>')} (gridded field)"

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

    def _record_seconds(self, ctx, times: np.ndarray) -> np.ndarray:
        cu = self.cu
        rng = f"{iso_seconds(times[0])} .. {iso_seconds(times[-1])}"
        start = ctx.start
        if start is None:
            raise SceneError(
                f"{self.where}: the gridded field's file {cu.label()} has time records "
                f"({rng}); the scene needs [time] start (e.g. start = 2001-01-01T00:00:00) to "
                "place the run among them")
        if start.tzinfo is not None:
            start = start.astimezone(_dt.UTC).replace(tzinfo=None)
        t0 = np.datetime64(start, "ns")
        secs = (times - t0).astype("timedelta64[ns]").astype(np.int64) / 1e9
        total = float(ctx.n_steps) * float(ctx.dt)
        if secs[0] > 1e-6 or secs[-1] < total - 1e-6:
            end = t0 + np.timedelta64(round(total * 1e9), "ns")
            raise DataError(
                f"{self.where}: time records of {cu.label()} ({rng}) do not cover the run "
                f"({iso_seconds(t0)} .. {iso_seconds(end)}); use files for the run's dates "
                "(a glob pattern such as 'uwnd.10m.*.nc' joins years) or move [time] start")
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
                    when = "" if rec is None else f" at {iso_seconds(comp.times[rec])} (record {k})"
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
        self.setup(self._ctx)
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
            raise DataError(f"{self.where}: time {iso_seconds(at)} (t = {t:g} s) is outside "
                            f"the records of {self.cu.label()} ({iso_seconds(self.cu.times[0])} .. "
                            f"{iso_seconds(self.cu.times[-1])})")
        k = int(np.searchsorted(tr, t, side="right")) - 1
        k = min(max(k, 0), tr.size - 1)
        if k == tr.size - 1 or t <= tr[k]:  # on (or a rounding error before) a record
            return k, None, 0.0
        alpha = (t - tr[k]) / (tr[k + 1] - tr[k])
        return k, k + 1, min(alpha, 1.0)

    # ------------------------------------------------------------------ sampling
    def _records_at(self, t):
        """The two records around ``t`` [s] and the weight of the second (the cache keeps the
        three nearest records)."""
        k0, k1, alpha = self.bracket(float(t))
        U0, V0, P0 = self._record(k0)
        U1, V1, P1 = (U0, V0, P0) if k1 is None else self._record(k1)
        if k0 is not None and len(self._cache) > 3:
            for key in sorted(self._cache, key=lambda r: -abs(r - k0))[: len(self._cache) - 3]:
                if key not in (k0, k1):
                    del self._cache[key]
        g = self.grid
        return GridSample(ylat=g.ylat, xoff=g.xoff, lon0=math.radians(g.lon0_deg),
                          periodic=g.periodic, cap_s=g.cap_s, cap_n=g.cap_n, U0=U0, V0=V0, P0=P0,
                          U1=U1, V1=V1, P1=P1, alpha=float(alpha))

    def _warn_outside(self, nout, t, lat, lon) -> None:
        if nout and not self._warned:
            self._warned = True
            warnings.warn(
                f"{self.where}: {nout} point(s) outside the grid of {self.cu.label()} "
                f"({self.grid.describe()}), the first at lat {math.degrees(lat):.4g}, lon "
                f"{math.degrees(lon):.4g} at t = {float(t):g} s: the velocity is zero "
                "there (said once)", stacklevel=3)

    def sample(self, t, lat, lon):
        lat = np.ascontiguousarray(lat, dtype=np.float64)
        lon = np.ascontiguousarray(lon, dtype=np.float64)
        n = lat.shape[0]
        u = np.empty(n)
        v = np.empty(n)
        nout, first = interpolate(lat, lon, self._records_at(t), u, v)
        if nout:
            self._warn_outside(nout, t, lat[first], lon[first])
        return u, v

    def add_drag(self, t, q, V, area, rho, C, theta, subtract_ice, F, nch) -> None:
        """Add the quadratic drag of this field on every element to ``F`` [N] in one pass
        (:func:`siku_forcing.gridded.gridded_drag.gridded_stress`: the same forces as sampling the
        field at the centres, bit for bit); the drag sources call it.

        With ``resample > 0`` [s] the field is interpolated at the elements' positions only
        every ``resample`` seconds of model time (and whenever the pair of records around
        ``t`` changes); in between each element keeps its values of the two records
        (:func:`~siku_forcing.gridded.gridded_drag.gridded_values`) and only their weight in time
        follows ``t`` (:func:`~siku_forcing.gridded.gridded_drag.cached_stress`). The wind an
        element
        feels then lags its drift by at most ``resample`` times its speed: about 30 m at
        0.5 m/s and 60 s, a wind error of about 1e-3 m/s on a 2.5° grid. A restart takes the
        values again at its first step."""
        nout = np.zeros(nch, dtype=np.int64)
        first = np.full(nch, -1, dtype=np.int64)
        every = float(self.p["resample"])
        if every > 0.0:
            k0, k1, alpha = self.bracket(float(t))
            key = (k0, k1, q.shape[0])
            held = self._held
            if held is None or held[1] != key or not (held[2] <= t < held[2] + every):
                ab = np.empty((q.shape[0], 4))
                gridded_values(q, self._records_at(t), ab, nch, nout, first)
                self._held = held = (ab, key, float(t))
            cached_stress(q, V, area, rho, C, theta, subtract_ice, held[0], float(alpha), F, nch)
        else:
            gridded_stress(q, V, area, rho, C, theta, subtract_ice, self._records_at(t), F, nch,
                           nout, first)
        if nout.any():
            k = int(first[np.flatnonzero(nout)[0]])
            lat, lon = latlon_of(q[k:k + 1])
            self._warn_outside(int(nout.sum()), t, float(lat[0]), float(lon[0]))

    def close(self) -> None:
        for comp in (getattr(self, "cu", None), getattr(self, "cv", None)):
            if comp is not None:
                comp.close()


@hookimpl
def siku_register_fields():
    return [Gridded]
