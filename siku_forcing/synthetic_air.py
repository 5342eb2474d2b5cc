"""Write a surface air temperature history as an NCEP/NCAR ``air.sig995``-layout NetCDF file.

The ice-life example (``examples/ice_life``) reads its air temperature through the gridded
path from a file made here: a cold snap (``cold`` °C) that thaws to ``warm`` °C, uniform in
space, on a regional 2.5° grid, in kelvin (``units = "degK"``, as the reanalysis writes them),
packed ``int16``. ``python -m siku_forcing.synthetic_air OUT_DIR`` writes
``OUT_DIR/air.cold_snap.nc``; an existing file is never replaced.
"""
from __future__ import annotations

import datetime as _dt
import sys
from pathlib import Path

import numpy as np

#: the example's history: start, hours of cold, hours of warming, hours warm, °C
COLD_SNAP = {"start": _dt.datetime(2001, 4, 6), "cold_hours": 12.0, "warming_hours": 6.0,
             "warm_hours": 30.0, "cold": -40.0, "warm": 1.0}
#: regional grid [deg]
LAT = np.arange(65.0, 80.1, 2.5)
LON = np.arange(185.0, 227.6, 2.5)


def temperature_at(hours: np.ndarray, p: dict = COLD_SNAP) -> np.ndarray:
    """Air temperature [°C] ``hours`` after the start: ``cold``, then linear to ``warm``."""
    ramp = np.clip((hours - p["cold_hours"]) / p["warming_hours"], 0.0, 1.0)
    return p["cold"] + (p["warm"] - p["cold"]) * ramp


def write_air(out_dir: str | Path, p: dict = COLD_SNAP, step_hours: float = 3.0) -> Path:
    """Write ``air.cold_snap.nc`` in ``out_dir``; refuse to replace an existing file."""
    import xarray as xr

    out_dir = Path(out_dir)
    path = out_dir / "air.cold_snap.nc"
    if path.exists():
        raise FileExistsError(f"{path} exists; remove it first or choose another folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    total = p["cold_hours"] + p["warming_hours"] + p["warm_hours"]
    hours = np.arange(0.0, total + 1e-9, step_hours)
    times = np.array([p["start"] + _dt.timedelta(hours=float(h)) for h in hours],
                     dtype="datetime64[ns]")
    T = temperature_at(hours, p)[:, None, None] + np.zeros((1, len(LAT), len(LON)))
    ds = xr.Dataset(
        {"air": (("time", "lat", "lon"), T + 273.15,
                 {"units": "degK", "long_name": "air temperature at sigma level 995"})},
        coords={"time": ("time", times),
                "lat": ("lat", LAT.astype(np.float32), {"units": "degrees_north"}),
                "lon": ("lon", LON.astype(np.float32), {"units": "degrees_east"})},
        attrs={"Conventions": "COARDS", "title": "siku synthetic air temperature: a cold snap "
               "and a thaw", "source": f"siku_forcing.synthetic_air {p}"})
    ds.to_netcdf(path, encoding={
        "air": {"dtype": "int16", "scale_factor": 0.01, "add_offset": 250.0,
                "_FillValue": np.int16(32766)},
        "time": {"units": "hours since 1800-01-01 00:00:0.0", "dtype": "float64"}})
    return path


def main(argv: list[str]) -> int:
    if len(argv) != 1 or argv[0].startswith("-"):
        print("usage: python -m siku_forcing.synthetic_air OUT_DIR  (writes "
              "OUT_DIR/air.cold_snap.nc)", file=sys.stderr)
        return 2
    try:
        print(write_air(argv[0]))
    except FileExistsError as exc:
        print(f"siku: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main(sys.argv[1:]))
