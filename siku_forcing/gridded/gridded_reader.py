"""Reading one velocity component of a gridded field from NetCDF files (xarray): the files in
time order, the variable's lat/lon/time dimensions (CF discovery, :mod:`siku_forcing.gridded.cf`),
its
records; and the file's grid mapped onto the sorted grid of the interpolation kernels. See
:mod:`siku_forcing.gridded.gridded_field`."""
from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import numpy as np

from siku_core.errors import DataError

from .cf import SPEED_UNITS, check_complete, find_coordinate, iso_seconds, norm_units


class KernelGrid:
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


class ComponentReader:
    """One velocity component: its files in time order, the variable, dims and record index."""

    def __init__(self, name: str, paths: list[Path], var: str, names: dict[str, str],
                 where: str, xr: Any, quantity: str = "velocity"):
        self.name, self.var, self.where = name, var, where
        #: what the variable holds: "velocity" (units checked: m/s) or "temperature" (K or
        #: degC, checked by the reader's owner)
        self.quantity = quantity
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
                    f"{iso_seconds(self.times[k])} ({self.paths[self.rec_file[k]]}) is followed by "
                    f"{iso_seconds(self.times[k + 1])} ({self.paths[self.rec_file[k + 1]]})")
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
        if self.quantity == "velocity" and (units is None or norm_units(units) not in
                                            SPEED_UNITS):
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
        found = find_coordinate(((d, ds[d] if d in ds.variables else None) for d in dims),
                                role, axis_names=True)
        if found is not None or role == "time":
            return found
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
