"""Landfast contours: lon/lat polygons read from a file and the test of points inside them."""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from siku_core.geometry.sphere import lonlat_to_xyz


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
