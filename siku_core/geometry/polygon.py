"""Planar polygon properties and element construction from geographic vertices."""
from __future__ import annotations

import math

import numpy as np

from ..errors import GeometryError
from .quat import from_tangent, q_from_latlon, to_tangent
from .sphere import latlon_to_xyz, xyz_to_latlon


def polygon_area(poly: np.ndarray) -> float:
    """Signed area [m²] of a polygon ``(k, 2)``, positive counter-clockwise: the area of
    :func:`area_centroid_moment`, summed the same way (bit for bit)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float((x * np.roll(y, -1) - np.roll(x, -1) * y).sum())


def area_centroid_moment(poly: np.ndarray) -> tuple[float, np.ndarray, float]:
    """Signed area [m²], centroid [m] and polar second moment about the centroid [m⁴].

    Exact for any simple polygon: the sum over all triangles (origin, v_k, v_k+1), none skipped.
    """
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    a = 0.5 * cr.sum()
    if a == 0.0:
        return 0.0, np.zeros(2), 0.0
    cx = ((x + xn) * cr).sum() / (6 * a)
    cy = ((y + yn) * cr).sum() / (6 * a)
    ixx = (cr * (y * y + y * yn + yn * yn)).sum() / 12.0
    iyy = (cr * (x * x + x * xn + xn * xn)).sum() / 12.0
    j0 = ixx + iyy  # about the origin
    j = j0 - a * (cx * cx + cy * cy)
    return a, np.array([cx, cy]), j


def check_convex(poly: np.ndarray, label: str) -> None:
    """Raise :class:`GeometryError` unless ``poly`` is a convex CCW polygon of positive area."""
    k = len(poly)
    if k < 3:
        raise GeometryError(f"{label}: polygon has {k} vertices; at least 3 are needed")
    e = np.roll(poly, -1, axis=0) - poly
    lengths = np.hypot(e[:, 0], e[:, 1])
    scale = lengths.max()
    if not np.all(np.isfinite(poly)):
        raise GeometryError(f"{label}: polygon has non-finite vertices")
    if lengths.min() <= 1e-9 * scale:
        i = int(np.argmin(lengths))
        raise GeometryError(
            f"{label}: degenerate polygon (vertices {i} and {(i + 1) % k} coincide)")
    cross = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
    tol = 1e-12 * scale * scale
    if np.any(cross < -tol):
        i = int(np.argmin(cross))
        raise GeometryError(
            f"{label}: polygon is not convex (turns clockwise at vertex {(i + 1) % k})")
    a, _, _ = area_centroid_moment(poly)
    if a <= 1e-9 * scale * scale:
        raise GeometryError(f"{label}: degenerate polygon (zero area)")


def _first_crossing(poly: np.ndarray) -> tuple[int, int] | None:
    """The first pair ``(i, j)`` of non-adjacent edges ``i -> i+1``, ``j -> j+1`` of a closed
    polygon that properly cross, or None."""
    k = len(poly)

    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    for i in range(k):
        a, b = poly[i], poly[(i + 1) % k]
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue  # adjacent through the closing vertex
            c, d = poly[j], poly[(j + 1) % k]
            if (orient(a, b, c) * orient(a, b, d) < 0) and (orient(c, d, a) * orient(c, d, b) < 0):
                return i, j
    return None


def element_from_lonlat(lonlat_deg: np.ndarray, radius: float, label: str = "element"):
    """Build one element from polygon vertices given as ``(lon, lat)`` in degrees.

    The element centre is the centroid of the gnomonic projection of the polygon (found by a
    short fixed-point iteration); local +x is east and +y north at that centre. Clockwise input
    is reversed. Returns ``(q, verts_local_m, area_m2, polar_moment_m4)``.
    """
    ll = np.asarray(lonlat_deg, dtype=float)
    if ll.ndim != 2 or ll.shape[1] != 2 or len(ll) < 3:
        raise GeometryError(f"{label}: vertices must be a list of at least 3 [lon, lat] pairs")
    if not np.all(np.isfinite(ll)):
        raise GeometryError(f"{label}: non-finite vertex coordinates")
    if np.any(np.abs(ll[:, 1]) > 90):
        raise GeometryError(f"{label}: latitude outside [-90, 90] degrees")
    lat = np.radians(ll[:, 1])
    lon = np.radians(ll[:, 0])
    pts = np.array([latlon_to_xyz(a, b) for a, b in zip(lat, lon)])
    c = pts.mean(axis=0)
    nc = np.linalg.norm(c)
    if nc < 1e-12:
        raise GeometryError(f"{label}: polygon spans a hemisphere; elements must be small")
    c /= nc
    if np.all(pts @ c > 0.05):  # small enough to look at in the tangent plane of the mean
        la, lo = xyz_to_latlon(c)
        q0 = q_from_latlon(la, lo)
        loc0 = np.array([to_tangent(q0, p, radius) for p in pts])
        crossing = _first_crossing(loc0)
        if crossing is not None:
            i, j = crossing
            raise GeometryError(f"{label}: polygon crosses itself (edge {i}-{(i + 1) % len(pts)} "
                                f"crosses edge {j}-{(j + 1) % len(pts)}); list the vertices in "
                                "order around the outline")
    for _ in range(4):
        la, lo = xyz_to_latlon(c)
        q = q_from_latlon(la, lo)
        if np.any(pts @ c <= 0.05):
            raise GeometryError(f"{label}: polygon is too large for a tangent-plane element")
        loc = np.array([to_tangent(q, p, radius) for p in pts])
        a, cen, _ = area_centroid_moment(loc)
        if a < 0:
            loc = loc[::-1]
            pts = pts[::-1]
            a = -a
        if np.hypot(*cen) < 1e-9 * math.sqrt(abs(a) + 1e-300):
            break
        c = from_tangent(q, cen[0], cen[1], radius)
    la, lo = xyz_to_latlon(c)
    q = q_from_latlon(la, lo)
    loc = np.array([to_tangent(q, p, radius) for p in pts])
    a, cen, _ = area_centroid_moment(loc)
    if a < 0:
        loc = loc[::-1]
    loc = loc - cen
    check_convex(loc, label)
    a, _, j = area_centroid_moment(loc)
    return q, loc, a, j
