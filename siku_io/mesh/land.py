"""Land under a mesh: a raster of the GLOBE land mask (``global-land-mask``) read in a window, or
the GSHHG shorelines rasterised."""
from __future__ import annotations

import math
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata, util
from pathlib import Path

import numpy as np

from .region import Region

GLM = "global-land-mask"
#: land data a mesh can use: the GLOBE raster, the GSHHG shorelines, or none
LAND_SOURCES = (GLM, "gshhg", "none")
WINDOW_MAX_PIXELS = 16_000_000  # a land window larger than this (bytes) is read thinned


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
    """The GSHHG shorelines (:mod:`siku_io.mesh.gshhg`) rasterised on pixels of an eighth of the
    smallest spacing ``r_min`` [m] over a window, at the coarsest GSHHG level whose points are
    at most ``r_min / 5`` apart."""
    from . import gshhg

    res = gshhg.choose_resolution(r_min)
    fn = gshhg.land_function((window.lon0, window.lon0 + window.width),
                             (window.lat0, window.lat1), res)
    grid = LandGrid.from_function(fn, window, r_min / 8.0, R)
    grid.name = f"GSHHG {res} ({gshhg.PACKAGE} {gshhg.version()})"
    return grid
