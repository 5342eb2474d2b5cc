"""The six lead-formation case studies of the Siku report ("Case studies", Figs. 12-19):
their dates, and stand-in winds of the NCEP/NCAR layout for trying a case without the data.

``python examples/case_studies/cases.py CASE [FOLDER]`` writes ``uwnd.sig995.YEAR.nc`` and
``vwnd.sig995.YEAR.nc`` into ``FOLDER`` (default: ``ncep`` beside this file): the names,
grid (2.5°, latitude 90 → -90, longitude 0 → 357.5), packing (int16, scale 0.01, offset
225.45) and time axis (hours since 1800-01-01, every 6 h) of the reanalysis files, holding an
analytic pressure system of the kind the report describes for that case. They are a stand-in
to check a setup and to see what a case run looks like; the case itself needs the reanalysis
files (docs/howto/case_studies.md). Files that exist are never replaced.
"""
from __future__ import annotations

import datetime as _dt
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: case -> (scene file, start, hours, report figures, stand-in system for cases.py)
CASES: dict[str, dict] = {
    "1994-02-17": {"start": _dt.datetime(1994, 2, 16), "hours": 48, "figures": "12",
                   "weather": "anticyclone moving across the Beaufort Sea from NW to SE",
                   "system": {"kind": "anticyclone", "lat": 78.0, "lon": -175.0, "vmax": 15.0,
                              "rmax": 700e3, "move_east": 5.0, "move_north": -2.0}},
    "2000-02-08": {"start": _dt.datetime(2000, 2, 8), "hours": 48, "figures": "11, 13, 14",
                   "weather": "anticyclone zonally aligned with Point Barrow (parabolic arch)",
                   "system": {"kind": "anticyclone", "lat": 77.0, "lon": -157.0,
                              "vmax": 15.0, "rmax": 700e3, "move_east": 2.0}},
    "2000-03-06": {"start": _dt.datetime(2000, 3, 6), "hours": 48, "figures": "15, 16",
                   "weather": "anticyclone centred above Point Barrow (arch)",
                   "system": {"kind": "anticyclone", "lat": 75.0, "lon": -157.0,
                              "vmax": 14.0, "rmax": 600e3}},
    "2001-04-06": {"start": _dt.datetime(2001, 4, 6), "hours": 24, "figures": "17",
                   "weather": "anticyclone traversing west to east (tangent lead)",
                   "system": {"kind": "anticyclone", "lat": 77.0, "lon": -165.0, "vmax": 16.0,
                              "rmax": 700e3, "move_east": 4.0}},
    "1996-03-17": {"start": _dt.datetime(1996, 3, 17), "hours": 24, "figures": "18",
                   "weather": "cyclone with counter-clockwise winds (inverse arch)",
                   "system": {"kind": "cyclone", "lat": 74.0, "lon": -160.0, "vmax": 18.0,
                              "rmax": 500e3, "move_east": 3.0}},
    "2003-04-02": {"start": _dt.datetime(2003, 4, 2), "hours": 24, "figures": "19",
                   "weather": "anticyclone above the eastern Beaufort Sea (clockwise pack)",
                   "system": {"kind": "anticyclone", "lat": 74.0, "lon": -140.0, "vmax": 14.0,
                              "rmax": 800e3}},
}


def scene_path(case: str) -> Path:
    return HERE / f"beaufort_{case}.toml"


def wind_files(case: str, folder: Path | None = None) -> tuple[Path, Path]:
    """The reanalysis files a case reads (``uwnd.sig995.YEAR.nc``, ``vwnd...``)."""
    folder = HERE / "ncep" if folder is None else Path(folder)
    year = CASES[case]["start"].year
    return folder / f"uwnd.sig995.{year}.nc", folder / f"vwnd.sig995.{year}.nc"


def write_standin(case: str, folder: Path | None = None) -> tuple[Path, Path]:
    """Stand-in winds for ``case`` in the reanalysis layout, from 6 h before its start to 6 h
    after its end; refuses to replace existing files."""
    from siku_forcing.synthetic import write_ncep_pair

    c = CASES[case]
    u, v = wind_files(case, folder)
    for p in (u, v):
        if p.exists():
            raise FileExistsError(f"{p} exists (reanalysis data?); not replaced")
    start = c["start"] - _dt.timedelta(hours=6)
    written = write_ncep_pair(u.parent, c["system"], start, c["hours"] + 12.0,
                              stem=f"sig995.{c['start'].year}")
    return written


if __name__ == "__main__":  # pragma: no cover
    if len(sys.argv) < 2 or sys.argv[1] not in CASES:
        print(f"usage: python cases.py CASE [FOLDER]; CASE one of {', '.join(CASES)}",
              file=sys.stderr)
        sys.exit(2)
    for p in write_standin(sys.argv[1], Path(sys.argv[2]) if len(sys.argv) > 2 else None):
        print(p)
