"""The coherent clip: the overlap of two convex polygons computed from the edges that crossed
last time (temporal coherence), the full clip where they no longer do (numba, ``cache=True``).

Two convex polygons whose boundaries cross at exactly two points ``X`` and ``Y`` overlap in the
polygon ``X, P[a+1] … P[c], Y, Q[d+1] … Q[b]``: the boundary of polygon 1 (``P``) enters
polygon 2 (``Q``) at ``X``, where ``P``'s edge ``a`` crosses ``Q``'s edge ``b``, runs inside
``Q`` through ``P``'s vertices ``a+1 … c`` and leaves it at ``Y`` (``P``'s edge ``c``, ``Q``'s
edge ``d``); ``Q``'s boundary runs inside ``P`` from ``Y`` through ``Q``'s vertices ``d+1 …
b`` back to ``X``. Between two evaluations of a contact the crossing edges ``(a, b, c, d)``
rarely change, so :func:`coherent_overlap` starts from the ones kept per pair (the *hint*),
computes ``X`` and ``Y`` and that polygon, and checks that it is the overlap; it declines
(``ok = False``) otherwise and :func:`overlap_coherent` then runs the full clip
(:func:`~siku_core.geometry.clip.overlap_inline`) and reads the new crossing edges from its
result (:func:`crossing_edges`).

The check (``K = COH_K`` times the clip's tolerance ``tol``): ``P``'s edge ``a`` goes from
outside ``Q``'s line ``b`` to inside it and ``c`` from inside ``d`` to outside (strict signs),
which puts ``X`` and ``Y`` inside ``P``'s edges; ``X`` lies more than ``K tol`` inside every line
of ``Q`` but ``b``, ``Y`` every one but ``d``; every vertex of ``P``'s chain lies more than ``K
tol`` inside every line of ``Q``, every vertex of ``Q``'s chain inside every line of ``P``, and
consecutive chain vertices are more than ``K tol`` apart; where ``Q``'s chain is empty (the
edge ``Y → X`` lies on ``Q``'s line ``b``) ``X`` and ``Y`` also lie that far inside every line
of ``P`` but their own; the area exceeds twice the clip's touching area. Then (exact
arithmetic) ``X`` and ``Y`` are points of both boundaries, ``P``'s boundary from ``X`` to ``Y``
lies in ``Q`` and ``Q``'s from ``Y`` to ``X`` in ``P`` (convexity), and the two arcs, both
counter-clockwise, are the whole boundary of the overlap. None of the clip's tolerance rules
can act: every edge of the polygon has an end more than ``K tol`` from each line of the other
polygon that it does not lie on (so no edge is "shared" and no two neighbours merge), so the
clip's polygon is this one to round-off, its boundary classes change exactly at ``X`` and
``Y``, and ``ncross = 2``. ``tests/contacts/test_coherent_clip.py`` tries every possible hint
of fuzzed pairs: each one the check accepts gives the clip's overlap.

What differs from the full clip: round-off only. The clip computes a crossing on an edge of its
working polygon that earlier passes may already have cut (``X`` from a cut end instead of the
vertex) and sums area and centroid about its own first vertex; here ``X`` and ``Y`` come from
``P``'s vertices and the sums run about ``X``. ``P1, P2`` may come back in the other order (the
normal is the same: it is turned towards ``j``'s centre; the chord is the same).
``tests/geometry/test_coherent.py`` bounds the differences on fuzzed pairs.

Units: metres and m², as :mod:`siku_core.geometry.clip`; the polygons are elements (both
counter-clockwise, ``P`` centred at the origin, ``Q``'s centre at ``(c2x, c2y)``).
"""
from __future__ import annotations

import math

from numba import njit

from siku_core.geometry.clip import REL_TOL, overlap_elements

#: margin of the coherent check, in units of the clip's tolerance (see the module docstring)
COH_K = 4.0
#: the hint of a pair without one
NO_HINT = -1


@njit(cache=True, inline="always")
def pack_hint(a, b, c, d):
    """The four crossing edges ``(a, b, c, d)`` (each below 128) as one int32."""
    return a | (b << 8) | (c << 16) | (d << 24)


@njit(cache=True, inline="always")
def _line(poly, k, n):
    """``(ax, ay, ex, ey)``: start and direction of edge ``k`` of ``poly`` (``n`` vertices)."""
    k1 = k + 1 if k + 1 < n else 0
    ax = poly[k, 0]
    ay = poly[k, 1]
    return ax, ay, poly[k1, 0] - ax, poly[k1, 1] - ay


@njit(cache=True, inline="always")
def _inside_all(poly, n, skip, x, y, kt2):
    """``(x, y)`` lies more than ``sqrt(kt2)`` [m] inside every edge line of CCW ``poly`` but
    edge ``skip`` (``-1``: none)."""
    for k in range(n):
        if k == skip:
            continue
        ax, ay, ex, ey = _line(poly, k, n)
        f = ex * (y - ay) - ey * (x - ax)
        if not (f > 0.0 and f * f > kt2 * (ex * ex + ey * ey)):
            return False
    return True


@njit(cache=True, inline="always")
def _crossing(P, n1, a, Q, n2, b, enter):
    """Where ``P``'s edge ``a`` crosses ``Q``'s line ``b``, ``(ok, x, y)``; ``ok`` when the edge
    goes from outside the line to inside (``enter``) or from inside to outside, strictly."""
    a1 = a + 1 if a + 1 < n1 else 0
    bx, by, ex, ey = _line(Q, b, n2)
    sx = P[a, 0]
    sy = P[a, 1]
    px = P[a1, 0]
    py = P[a1, 1]
    fs = ex * (sy - by) - ey * (sx - bx)
    fp = ex * (py - by) - ey * (px - bx)
    if enter:
        ok = fs < 0.0 and fp > 0.0
    else:
        ok = fs > 0.0 and fp < 0.0
    if not ok:
        return False, 0.0, 0.0
    t = fs / (fs - fp)
    return True, sx + t * (px - sx), sy + t * (py - sy)


@njit(cache=True, inline="always")
def _chain_ok(P, n1, first, cnt, Q, n2, kt2):
    """``P``'s vertices ``first … first+cnt-1`` (cyclic) each lie more than ``sqrt(kt2)``
    inside every line of ``Q``, and consecutive ones are more than that apart."""
    for i in range(cnt):
        v = first + i
        v = v - n1 if v >= n1 else v
        x = P[v, 0]
        y = P[v, 1]
        if not _inside_all(Q, n2, -1, x, y, kt2):
            return False
        if i > 0:
            u = v - 1 if v > 0 else n1 - 1
            dx = x - P[u, 0]
            dy = y - P[u, 1]
            if not dx * dx + dy * dy > kt2:
                return False
    return True


@njit(cache=True, inline="always")
def _shoelace_add(x0, y0, xi, yi, xj, yj, a2, sx, sy):
    """One edge ``(xi, yi) → (xj, yj)`` of the shoelace sums about ``(x0, y0)``."""
    xi -= x0
    yi -= y0
    xj -= x0
    yj -= y0
    cr = xi * yj - xj * yi
    return a2 + cr, sx + (xi + xj) * cr, sy + (yi + yj) * cr


_FAIL = (False, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@njit(cache=True, inline="always")
def _coherent_core(P, Q, n1, n2, c2x, c2y, h):
    """Body of :func:`coherent_overlap` for polygons of ``n1`` and ``n2`` vertices (inlined so
    that constant sizes unroll, as the clip's core)."""
    if h < 0 or n1 < 3 or n2 < 3:
        return _FAIL
    a = h & 255
    b = (h >> 8) & 255
    c = (h >> 16) & 255
    d = (h >> 24) & 127
    if a >= n1 or c >= n1 or b >= n2 or d >= n2:
        return _FAIL
    big = 0.0
    for i in range(n1):
        big = max(big, abs(P[i, 0]), abs(P[i, 1]))
    for i in range(n2):
        big = max(big, abs(Q[i, 0]), abs(Q[i, 1]))
    tol = REL_TOL * big
    kt2 = (COH_K * tol) ** 2
    cp = c - a if c >= a else c - a + n1  # P's chain: vertices a+1 … c
    cq = b - d if b >= d else b - d + n2  # Q's chain: vertices d+1 … b
    if cp == 0 and cq == 0:
        return _FAIL
    okx, xx, xy_ = _crossing(P, n1, a, Q, n2, b, True)
    oky, yx, yy = _crossing(P, n1, c, Q, n2, d, False)
    if not (okx and oky):
        return _FAIL
    # X and Y in Q (each lies on P's boundary, so in P), clear of Q's other lines
    if not (_inside_all(Q, n2, b, xx, xy_, kt2) and _inside_all(Q, n2, d, yx, yy, kt2)):
        return _FAIL
    if cq == 0:  # the edge Y -> X lies on Q's line b: its ends clear of P's other lines
        if not (_inside_all(P, n1, a, xx, xy_, kt2) and _inside_all(P, n1, c, yx, yy, kt2)):
            return _FAIL
    pa = a + 1 if a + 1 < n1 else 0
    qd = d + 1 if d + 1 < n2 else 0
    if not (_chain_ok(P, n1, pa, cp, Q, n2, kt2) and _chain_ok(Q, n2, qd, cq, P, n1, kt2)):
        return _FAIL
    # ---- area and centroid of X, P[a+1] … P[c], Y, Q[d+1] … Q[b], summed about X
    a2 = 0.0
    sx = 0.0
    sy = 0.0
    qx = xx
    qy = xy_
    for i in range(cp):
        v = pa + i
        v = v - n1 if v >= n1 else v
        a2, sx, sy = _shoelace_add(xx, xy_, qx, qy, P[v, 0], P[v, 1], a2, sx, sy)
        qx = P[v, 0]
        qy = P[v, 1]
    a2, sx, sy = _shoelace_add(xx, xy_, qx, qy, yx, yy, a2, sx, sy)
    qx = yx
    qy = yy
    for i in range(cq):
        v = qd + i
        v = v - n2 if v >= n2 else v
        a2, sx, sy = _shoelace_add(xx, xy_, qx, qy, Q[v, 0], Q[v, 1], a2, sx, sy)
        qx = Q[v, 0]
        qy = Q[v, 1]
    a2, sx, sy = _shoelace_add(xx, xy_, qx, qy, xx, xy_, a2, sx, sy)
    area = 0.5 * a2
    if not area > 2.0 * REL_TOL * big * big:
        return _FAIL
    ux = yx - xx
    uy = yy - xy_
    un = math.sqrt(ux * ux + uy * uy)
    if not un > tol:
        return _FAIL
    nx = -uy / un
    ny = ux / un
    if nx * c2x + ny * c2y < 0.0:
        nx = -nx
        ny = -ny
    return (True, area, xx + sx / (3.0 * a2), xy_ + sy / (3.0 * a2), 2, xx, xy_, yx, yy,
            nx, ny)


@njit(cache=True)
def coherent_overlap(P, Q, c2x, c2y, h):
    """The overlap of elements ``P`` and ``Q`` (as :func:`~siku_core.geometry.clip.
    overlap_elements` takes them) from the crossing edges ``h`` (:func:`pack_hint`):
    ``(ok, area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny)`` [m², m]; ``ok`` False (and
    zeros) where the check of the module docstring fails: the caller clips in full."""
    return _coherent_core(P, Q, P.shape[0], Q.shape[0], c2x, c2y, h)


@njit(cache=True, inline="always")
def _nearest_edge(poly, n, x, y):
    """The edge of ``poly`` whose line passes nearest ``(x, y)``."""
    best = math.inf
    kb = 0
    for k in range(n):
        ax, ay, ex, ey = _line(poly, k, n)
        e2 = ex * ex + ey * ey
        if e2 > 0.0:
            f = ex * (y - ay) - ey * (x - ax)
            r = f * f / e2
            if r < best:
                best = r
                kb = k
    return kb


@njit(cache=True)
def crossing_edges(P, Q, p1x, p1y, p2x, p2y):
    """The hint (:func:`pack_hint`) of the crossings ``P1``, ``P2`` the clip found: at each,
    the edge of ``P`` and of ``Q`` whose lines pass nearest, ordered so that ``P`` enters
    ``Q`` at the first; :data:`NO_HINT` for polygons over 127 vertices. Only a guess that
    :func:`coherent_overlap` checks, so a wrong one costs a full clip and nothing else."""
    n1 = P.shape[0]
    n2 = Q.shape[0]
    if n1 > 127 or n2 > 127:
        return NO_HINT
    e1 = _nearest_edge(P, n1, p1x, p1y)
    f1 = _nearest_edge(Q, n2, p1x, p1y)
    e2 = _nearest_edge(P, n1, p2x, p2y)
    f2 = _nearest_edge(Q, n2, p2x, p2y)
    _, _, ex, ey = _line(P, e1, n1)
    _, _, gx, gy = _line(Q, f1, n2)
    if gx * ey - gy * ex > 0.0:  # P's edge e1 runs into Q's half-plane of edge f1
        return pack_hint(e1, f1, e2, f2)
    return pack_hint(e2, f2, e1, f1)


@njit(cache=True, inline="always")
def overlap_coherent(P, Q, xy, tag, c2x, c2y, drop, hints, k):
    """:func:`~siku_core.geometry.clip.overlap_inline` from pair ``k``'s kept crossing edges
    ``hints[k]`` (int32, :data:`NO_HINT` for none; updated): the coherent overlap where its
    check holds, else the full clip, whose crossings (when there are two and the overlap is
    more than touching) give the next hint. Same results to round-off (module docstring)."""
    n1 = P.shape[0]
    n2 = Q.shape[0]
    if n1 == 4 and n2 == 4:
        r = _coherent_core(P, Q, 4, 4, c2x, c2y, hints[k])
    else:
        r = _coherent_core(P, Q, n1, n2, c2x, c2y, hints[k])
    if r[0]:
        return r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10]
    area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_elements(P, Q, xy, tag, c2x, c2y,
                                                                       drop)
    if ncross == 2:
        hints[k] = crossing_edges(P, Q, p1x, p1y, p2x, p2y)
    else:
        hints[k] = NO_HINT
    return area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny


__all__ = ["COH_K", "NO_HINT", "coherent_overlap", "crossing_edges", "overlap_coherent",
           "pack_hint"]
