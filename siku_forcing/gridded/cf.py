"""CF conventions shared by the readers of gridded NetCDF data
(``siku_forcing.gridded.gridded_field``, the winds
and currents; ``siku_io.mesh.icecover``, the initial ice cover): which coordinate of a variable is
latitude, longitude or time, the spellings of m/s, and the check that a classic NetCDF file is
complete.

Coordinate discovery (:func:`find_coordinate`) tries, in this order, over the candidates in the
order given:

1. CF attributes: ``standard_name`` ``latitude`` / ``longitude`` / ``time``, or ``units``
   ``degrees_north`` / ``degrees_east`` in any of the spellings of :data:`LAT_UNITS` /
   :data:`LON_UNITS` (compared lower-case without blanks and underscores); for time also
   ``axis = "T"`` or datetime (or cftime object) values;
2. ``standard_name`` ``grid_latitude`` / ``grid_longitude`` (rotated-pole grids), after the true
   geographic ones so that a file with both gets the geographic coordinate;
3. common names, compared lower-case: :data:`LAT_NAMES`, :data:`LON_NAMES`, :data:`TIME_NAMES`
   (the union of the names the two readers knew: NCEP/NCAR and GRIB conversions ``lat_0``,
   ``g0_lat_0``; ocean and ice models ``nav_lat``, ``tlat``, ``ulat``, ``y_lat``); with
   ``axis_names`` also the bare axis names ``y`` / ``x`` (:data:`AXIS_NAMES`), which only a 1-D
   dimension of a lat/lon grid may use: on a projected grid ``x`` and ``y`` are metres.
"""
from __future__ import annotations

from pathlib import Path
from struct import error as struct_error
from typing import Any

import numpy as np

from siku_core.errors import DataError

#: accepted spellings of metres per second (compared after lower-casing and collapsing blanks)
SPEED_UNITS = frozenset({
    "m/s", "m s-1", "m s**-1", "m s^-1", "m.s-1", "m*s-1", "m*s**-1", "m*s^-1", "ms-1",
    "m s^(-1)", "m s**(-1)", "m/sec", "m sec-1", "meter/second", "meters/second",
    "metre/second", "metres/second", "meter second-1", "meters second-1", "metre second-1",
    "metres second-1", "meter s-1", "meters s-1", "metre s-1", "metres s-1", "meters per second",
    "metres per second",
})
#: units of latitude and longitude, lower-case without blanks and underscores
LAT_UNITS = frozenset({"degreesnorth", "degreenorth", "degreesn", "degreen"})
LON_UNITS = frozenset({"degreeseast", "degreeeast", "degreese", "degreee"})
#: common names of the coordinates (lower-case)
LAT_NAMES = ("lat", "latitude", "nav_lat", "lat_0", "g0_lat_0", "tlat", "ulat", "y_lat")
LON_NAMES = ("lon", "longitude", "nav_lon", "lon_0", "g0_lon_1", "tlon", "ulon", "x_lon")
TIME_NAMES = ("time", "valid_time", "t", "times", "date")
#: bare axis names, for 1-D dimensions of lat/lon grids only (``find_coordinate(axis_names=)``)
AXIS_NAMES = {"lat": ("y",), "lon": ("x",), "time": ()}

_NAMES = {"lat": LAT_NAMES, "lon": LON_NAMES, "time": TIME_NAMES}
_STANDARD = {"lat": "latitude", "lon": "longitude", "time": "time"}
_UNITS = {"lat": LAT_UNITS, "lon": LON_UNITS, "time": frozenset()}


def _attr(var: Any, key: str) -> str:
    return norm_units(var.attrs.get(key, "")) if var is not None else ""


def _is_time(var: Any) -> bool:
    return var is not None and (_attr(var, "axis") == "t" or np.issubdtype(var.dtype, np.datetime64)
                                or var.dtype == object)


def find_coordinate(candidates, role: str, axis_names: bool = False) -> str | None:
    """The name of the ``role`` (``"lat"``, ``"lon"`` or ``"time"``) coordinate among
    ``candidates``, ``(name, variable or None)`` pairs in order (the variable's ``attrs`` and
    ``dtype`` are read), by the rules of the module docstring; ``None`` if none fits."""
    candidates = [(str(name), var) for name, var in candidates]
    for name, var in candidates:
        sn = _attr(var, "standard_name")
        un = _attr(var, "units").replace(" ", "").replace("_", "")
        if sn == _STANDARD[role] or un in _UNITS[role] or (role == "time" and _is_time(var)):
            return name
    if role != "time":
        for name, var in candidates:
            if _attr(var, "standard_name") == "grid_" + _STANDARD[role]:
                return name
    names = _NAMES[role] + (AXIS_NAMES[role] if axis_names else ())
    for name, _ in candidates:
        if name.lower() in names:
            return name
    return None


def norm_units(text: Any) -> str:
    """``text`` lower-cased, with runs of blanks made one blank (to compare unit strings)."""
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


def iso_seconds(t: np.datetime64) -> str:
    """``t`` as ISO 8601 to the second, for messages."""
    return str(np.datetime_as_string(np.datetime64(t, "s"), unit="s"))
