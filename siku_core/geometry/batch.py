"""Many elements at once: :func:`~siku_core.geometry.polygon.element_from_lonlat` compiled.

A scene of a million elements cannot build them one Python call at a time (about 0.2 ms
each). :func:`elements_from_lonlat` builds every polygon with the same number of vertices in
one compiled pass, step for step the algorithm of ``element_from_lonlat`` (centre by the
fixed-point iteration on the gnomonic centroid, local frame east/north, clockwise input
reversed, the same checks); where a polygon fails a check, or the compiled pass cannot
decide, ``element_from_lonlat`` itself is called for it, so every fault keeps its one-line
message. The two agree to round-off (the sums are ordered alike but not always bit for bit:
``tests/test_element_sources.py`` bounds the difference).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import GeometryError
from .polygon import element_from_lonlat
from .quat import from_tangent, q_from_latlon, to_tangent
from .sphere import latlon_to_xyz, xyz_to_latlon

OK, FALLBACK = 0, 1


@njit(cache=True)
def _area_centroid_moment(loc, k):
    """``polygon.area_centroid_moment`` of the first ``k`` rows of ``loc``."""
    a2 = 0.0
    sx = 0.0
    sy = 0.0
    ixx = 0.0
    iyy = 0.0
    for v in range(k):
        u = v + 1 if v + 1 < k else 0
        x, y, xn, yn = loc[v, 0], loc[v, 1], loc[u, 0], loc[u, 1]
        cr = x * yn - xn * y
        a2 += cr
        sx += (x + xn) * cr
        sy += (y + yn) * cr
        ixx += cr * (y * y + y * yn + yn * yn)
        iyy += cr * (x * x + x * xn + xn * xn)
    a = 0.5 * a2
    if a == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    cx = sx / (6 * a)
    cy = sy / (6 * a)
    j = ixx / 12.0 + iyy / 12.0 - a * (cx * cx + cy * cy)
    return a, cx, cy, j


@njit(cache=True)
def _crosses(loc, k):
    """Some two non-adjacent edges of the closed polygon properly cross."""
    for i in range(k):
        ax, ay = loc[i, 0], loc[i, 1]
        bx, by = loc[(i + 1) % k, 0], loc[(i + 1) % k, 1]
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue
            cx, cy = loc[j, 0], loc[j, 1]
            dx, dy = loc[(j + 1) % k, 0], loc[(j + 1) % k, 1]
            o1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
            o2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
            o3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
            o4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
            if o1 * o2 < 0 and o3 * o4 < 0:
                return True
    return False


@njit(cache=True)
def _convex(loc, k):
    """``polygon.check_convex`` passes (the caller re-runs it for the message if not)."""
    if k < 3:
        return False
    scale = 0.0
    lmin = np.inf
    for v in range(k):
        u = v + 1 if v + 1 < k else 0
        if not (math.isfinite(loc[v, 0]) and math.isfinite(loc[v, 1])):
            return False
        ln = math.hypot(loc[u, 0] - loc[v, 0], loc[u, 1] - loc[v, 1])
        scale = max(scale, ln)
        lmin = min(lmin, ln)
    if lmin <= 1e-9 * scale:
        return False
    tol = 1e-12 * scale * scale
    for v in range(k):
        u = v + 1 if v + 1 < k else 0
        w = u + 1 if u + 1 < k else 0
        ex, ey = loc[u, 0] - loc[v, 0], loc[u, 1] - loc[v, 1]
        fx, fy = loc[w, 0] - loc[u, 0], loc[w, 1] - loc[u, 1]
        if ex * fy - ey * fx < -tol:
            return False
    a, _, _, _ = _area_centroid_moment(loc, k)
    return a > 1e-9 * scale * scale


@njit(cache=True)
def _tangent_all(q, pts, k, R, loc):
    for v in range(k):
        x, y = to_tangent(q, pts[v], R)
        loc[v, 0] = x
        loc[v, 1] = y


@njit(cache=True)
def _reverse(a, k):
    for v in range(k // 2):
        for c in range(a.shape[1]):
            t = a[v, c]
            a[v, c] = a[k - 1 - v, c]
            a[k - 1 - v, c] = t


@njit(cache=True)
def _build(lat_deg, lon_deg, R, q_out, loc_out, area_out, j_out, status):
    n, k = lat_deg.shape
    pts = np.empty((k, 3))
    loc = np.empty((k, 2))
    for e in range(n):
        status[e] = FALLBACK
        bad = False
        for v in range(k):
            la, lo = lat_deg[e, v], lon_deg[e, v]
            if not (math.isfinite(la) and math.isfinite(lo)) or abs(la) > 90:
                bad = True
            p = latlon_to_xyz(math.radians(la), math.radians(lo))
            pts[v, 0] = p[0]
            pts[v, 1] = p[1]
            pts[v, 2] = p[2]
        if bad or k < 3:
            continue
        c = np.zeros(3)
        for v in range(k):
            c += pts[v]
        c /= k
        nc = math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
        if nc < 1e-12:
            continue
        c /= nc
        small = True
        for v in range(k):
            if pts[v, 0] * c[0] + pts[v, 1] * c[1] + pts[v, 2] * c[2] <= 0.05:
                small = False
        if not small:
            continue  # too large for a tangent-plane element: the fallback says so
        la, lo = xyz_to_latlon(c)
        _tangent_all(q_from_latlon(la, lo), pts, k, R, loc)
        if _crosses(loc, k):
            continue
        far = False
        for _ in range(4):
            la, lo = xyz_to_latlon(c)
            q = q_from_latlon(la, lo)
            far = False
            for v in range(k):
                if pts[v, 0] * c[0] + pts[v, 1] * c[1] + pts[v, 2] * c[2] <= 0.05:
                    far = True
            if far:
                break
            _tangent_all(q, pts, k, R, loc)
            a, cx, cy, _ = _area_centroid_moment(loc, k)
            if a < 0:
                _reverse(loc, k)
                _reverse(pts, k)
                a = -a
            if math.hypot(cx, cy) < 1e-9 * math.sqrt(abs(a) + 1e-300):
                break
            c = from_tangent(q, cx, cy, R)
        if far:
            continue
        la, lo = xyz_to_latlon(c)
        q = q_from_latlon(la, lo)
        _tangent_all(q, pts, k, R, loc)
        a, cx, cy, _ = _area_centroid_moment(loc, k)
        if a < 0:
            _reverse(loc, k)
        for v in range(k):
            loc[v, 0] -= cx
            loc[v, 1] -= cy
        if not _convex(loc, k):
            continue
        a, _, _, j = _area_centroid_moment(loc, k)
        for t in range(4):
            q_out[e, t] = q[t]
        for v in range(k):
            loc_out[e, v, 0] = loc[v, 0]
            loc_out[e, v, 1] = loc[v, 1]
        area_out[e] = a
        j_out[e] = j
        status[e] = OK


def elements_from_lonlat(polys: list, radius: float, labels: list) -> list:
    """``[(q, verts_local, area, polar_moment), ...]`` of polygons given as ``(lon, lat)``
    arrays in degrees, as :func:`~siku_core.geometry.polygon.element_from_lonlat` returns them.
    A faulty polygon raises its :class:`GeometryError`, prefixed ``element i:`` and naming
    ``labels[i]``."""
    out: list = [None] * len(polys)
    by_k: dict[int, list[int]] = {}
    for i, p in enumerate(polys):
        a = np.asarray(p, dtype=float)
        if a.ndim == 2 and a.shape[1] == 2 and len(a) >= 3:
            by_k.setdefault(len(a), []).append(i)
        else:
            out[i] = _one(a, radius, labels, i)
    for k, idx in by_k.items():
        ll = np.array([np.asarray(polys[i], dtype=float) for i in idx]).reshape(len(idx), k, 2)
        m = len(idx)
        q = np.empty((m, 4))
        loc = np.empty((m, k, 2))
        area = np.empty(m)
        jm = np.empty(m)
        status = np.empty(m, dtype=np.int64)
        _build(np.ascontiguousarray(ll[:, :, 1]), np.ascontiguousarray(ll[:, :, 0]),
               float(radius), q, loc, area, jm, status)
        for r, i in enumerate(idx):
            if status[r] == OK:
                out[i] = (q[r], loc[r], float(area[r]), float(jm[r]))
            else:  # the one-element path: its result, or its message
                out[i] = _one(ll[r], radius, labels, i)
    return out


def _one(lonlat, radius: float, labels: list, i: int):
    try:
        return element_from_lonlat(lonlat, radius, labels[i])
    except GeometryError as exc:
        raise GeometryError(f"element {i}: {exc}") from None
