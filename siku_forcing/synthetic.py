"""Write analytic wind fields as NCEP/NCAR-reanalysis-layout NetCDF files.

The shipped default scene reads its wind through the gridded path from files made here: a
moving anticyclone sampled on the reanalysis grid (2.5°, latitude 90→-90, longitude 0→357.5),
packed ``int16`` with the reanalysis ``scale_factor``/``add_offset``, time in hours since
1800-01-01. ``python -m siku_forcing.synthetic OUT_DIR`` regenerates the default files.
"""
from __future__ import annotations

import datetime as _dt
import math
import sys
from pathlib import Path

import numpy as np

from .fields import Cyclone

#: NCEP/NCAR reanalysis packing of uwnd/vwnd
SCALE, OFFSET, FILL = 0.01, 225.45, 32766
NCEP_LAT = np.arange(90.0, -90.1, -2.5)
NCEP_LON = np.arange(0.0, 360.0, 2.5)

#: the anticyclone of the default scene (a Beaufort High drifting east)
DEFAULT_ANTICYCLONE = {"kind": "anticyclone", "lat": 77.0, "lon": -165.0, "vmax": 16.0,
                       "rmax": 700e3, "inflow_angle": 20.0, "move_east": 4.0, "move_north": 0.0}
DEFAULT_START = _dt.datetime(2001, 4, 6)


def _systems(params: dict | list[dict], radius: float) -> list:
    """``(field, t0 [h] or None, life [h] or None)`` of each pressure system of ``params``."""
    out = []
    for p in params if isinstance(params, list) else [params]:
        p = dict(p)
        t0, life = p.pop("t0_hours", None), p.pop("life_hours", None)
        field = Cyclone({**{k: q.default for k, q in Cyclone.params.items()}, **p})
        field.radius = radius
        out.append((field, t0, life))
    return out


def _sample(systems, t_hours: float, lat, lon):
    """The summed wind [m/s] of ``systems`` at ``t_hours`` after the start: a system with a
    life (``t0_hours``, ``life_hours``) is born at ``t0``, moves from its place then, and
    blows with the weight ``sin²(pi (t - t0) / life)`` during its life, 0 outside it."""
    u = np.zeros(lat.shape)
    v = np.zeros(lat.shape)
    for field, t0, life in systems:
        if t0 is None:
            w, ts = 1.0, t_hours
        else:
            tau = (t_hours - t0) / life
            w, ts = (math.sin(math.pi * tau) ** 2 if 0.0 < tau < 1.0 else 0.0), t_hours - t0
        if w > 0.0:
            uu, vv = field.sample(max(ts, 0.0) * 3600.0, lat, lon)
            u += w * uu
            v += w * vv
    return u, v


def write_ncep_pair(out_dir: str | Path, params: dict | list[dict], start: _dt.datetime,
                    hours: float, step_hours: float = 6.0, radius: float = 6_371_000.0,
                    stem: str = "anticyclone") -> tuple[Path, Path]:
    """Write ``uwnd.STEM.nc`` and ``vwnd.STEM.nc`` sampling a :class:`Cyclone` field, or the
    sum of several (a list; each may have ``t0_hours`` and ``life_hours``: :func:`_sample`).

    Records every ``step_hours`` from ``start`` to ``start + hours`` (inclusive).
    """
    import xarray as xr

    systems = _systems(params, radius)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    n = int(math.floor(hours / step_hours + 1e-9)) + 1
    times = [start + _dt.timedelta(hours=k * step_hours) for k in range(n)]
    LON, LAT = np.meshgrid(np.radians(NCEP_LON), np.radians(NCEP_LAT))
    u = np.empty((n, len(NCEP_LAT), len(NCEP_LON)))
    v = np.empty_like(u)
    for k in range(n):
        uu, vv = _sample(systems, k * step_hours, LAT.ravel(), LON.ravel())
        u[k] = uu.reshape(LAT.shape)
        v[k] = vv.reshape(LAT.shape)
    coords = {
        "time": ("time", np.array(times, dtype="datetime64[ns]")),
        "lat": ("lat", NCEP_LAT.astype(np.float32),
                {"units": "degrees_north", "long_name": "Latitude"}),
        "lon": ("lon", NCEP_LON.astype(np.float32),
                {"units": "degrees_east", "long_name": "Longitude"}),
    }
    paths = []
    for name, data, long in (("uwnd", u, "u-wind"), ("vwnd", v, "v-wind")):
        ds = xr.Dataset(
            {name: (("time", "lat", "lon"), data,
                    {"units": "m/s", "long_name": f"{long} at 10 m (analytic anticyclone)"})},
            coords=coords,
            attrs={"Conventions": "COARDS", "title": "siku synthetic NCEP-layout wind",
                   "source": f"siku_forcing.synthetic Cyclone {params}"},
        )
        path = out_dir / f"{name}.{stem}.nc"
        ds.to_netcdf(path, encoding={
            name: {"dtype": "int16", "scale_factor": SCALE, "add_offset": OFFSET,
                   "_FillValue": np.int16(FILL)},
            "time": {"units": "hours since 1800-01-01 00:00:0.0", "dtype": "float64"},
        })
        paths.append(path)
    return paths[0], paths[1]


def main(argv: list[str] | None = None) -> int:
    """``python -m siku_forcing.synthetic [OUT_DIR]``: the default scene's wind files."""
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m siku_forcing.synthetic",
        description="Write the default scene's wind files (uwnd.anticyclone.nc, "
                    "vwnd.anticyclone.nc: an anticyclone drifting east, NCEP/NCAR layout).")
    ap.add_argument("out_dir", nargs="?", default=".", help="folder to write them in "
                    "(default: the working directory)")
    args = ap.parse_args(argv)
    for p in write_ncep_pair(Path(args.out_dir), DEFAULT_ANTICYCLONE, DEFAULT_START, 48.0):
        print(p)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
