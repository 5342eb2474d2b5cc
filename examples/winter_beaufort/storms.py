"""Synthetic winter weather for ``winter_beaufort.toml``: a weak Beaufort High all along and six
storms (cyclones and anticyclones of 12-20 m/s) that cross the Beaufort Sea over 16 days, one
every two to three days, each growing and dying over its life as ``sin²`` (synoptic
variability, not one anticyclone).

``python examples/winter_beaufort/storms.py [FOLDER]`` writes ``uwnd.winter.nc`` and
``vwnd.winter.nc`` (the NCEP/NCAR reanalysis layout: 2.5° grid, packed int16, every 6 h) into
``FOLDER`` (default: beside this file); files that exist are never replaced.
"""
from __future__ import annotations

import datetime as _dt
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
START = _dt.datetime(2001, 1, 14, 18)  # 6 h before the scene's start
HOURS = 17 * 24.0

#: the Beaufort High (always) and six storms: t0_hours after START, life_hours
SYSTEMS = [
    {"kind": "anticyclone", "lat": 77.0, "lon": -150.0, "vmax": 6.0, "rmax": 900e3},
    {"kind": "cyclone", "lat": 72.0, "lon": -175.0, "vmax": 18.0, "rmax": 500e3,
     "move_east": 8.0, "move_north": 1.0, "t0_hours": 6.0, "life_hours": 60.0},
    {"kind": "anticyclone", "lat": 78.0, "lon": -170.0, "vmax": 14.0, "rmax": 700e3,
     "move_east": 5.0, "move_north": -2.0, "t0_hours": 54.0, "life_hours": 72.0},
    {"kind": "cyclone", "lat": 70.0, "lon": -140.0, "vmax": 20.0, "rmax": 450e3,
     "move_east": -6.0, "move_north": 3.0, "t0_hours": 114.0, "life_hours": 54.0},
    {"kind": "cyclone", "lat": 74.0, "lon": -180.0, "vmax": 16.0, "rmax": 550e3,
     "move_east": 9.0, "t0_hours": 168.0, "life_hours": 60.0},
    {"kind": "anticyclone", "lat": 76.0, "lon": -160.0, "vmax": 12.0, "rmax": 800e3,
     "move_east": 3.0, "t0_hours": 222.0, "life_hours": 84.0},
    {"kind": "cyclone", "lat": 71.0, "lon": -165.0, "vmax": 19.0, "rmax": 500e3,
     "move_east": 7.0, "move_north": 2.0, "t0_hours": 300.0, "life_hours": 60.0},
]


def write(folder: Path | None = None) -> tuple[Path, Path]:
    """Write the winter's wind files into ``folder``; refuses to replace existing files."""
    from siku_forcing.synthetic import write_ncep_pair

    folder = HERE if folder is None else Path(folder)
    for name in ("uwnd.winter.nc", "vwnd.winter.nc"):
        if (folder / name).exists():
            raise FileExistsError(f"{folder / name} exists; not replaced")
    return write_ncep_pair(folder, SYSTEMS, START, HOURS, stem="winter")


if __name__ == "__main__":  # pragma: no cover
    for p in write(Path(sys.argv[1]) if len(sys.argv) > 1 else None):
        print(p)
