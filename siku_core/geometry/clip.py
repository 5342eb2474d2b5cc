"""Narrow-phase contact geometry: convex polygon clipping (numba, ``cache=True``).

Over 500 lines for a reason: the clip and its tolerance rules (one point, on a line, touching)
are one algorithm whose cases must agree with each other; split, the rules would be read apart.

docs/explanation/physics.md section 4.1. The partner's vertices are projected into the
element's tangent plane (``project_partner``), the two convex polygons are intersected with
Sutherland–Hodgman clipping (``overlap`` / ``overlap_scratch``), and the overlap area, the
overlap centroid, the points where the two boundaries cross and the contact normal of eq. (10)
come back.

Units and conventions
---------------------
* Coordinates are metres in one common tangent plane (element 1's local frame: ``+x`` and ``+y``
  of the element's quaternion, see ``siku_core.geometry.quat``); areas are m².
* Polygons are ``(n, 2)`` float64 arrays of the vertices of a convex polygon, counter-clockwise,
  without repeating the first vertex. A clockwise polygon is accepted too (its orientation is read
  from its signed area); a non-convex one is not (the result is then that of clipping against the
  half-planes of its edges).
* Contact normal ``n`` (unit vector, eq. 10): perpendicular to ``P1P2`` when the boundaries cross
  at exactly two points ``P1``, ``P2``; otherwise along ``centroid(poly2) - centroid(poly1)``
  (report Fig. 4b), and ``(1, 0)`` when those two centroids coincide (closer than the tolerance).
  In every case ``n`` points from polygon 1 towards polygon 2: ``n · (c2 - c1) >= 0``.
  ``overlap_elements`` (the engine's clip) takes ``c1``, ``c2`` as the two element centres instead
  (the centroids of the elements in their own planes; see its docstring).
* Tolerance: ``tol = REL_TOL * L`` (m) with ``L`` the largest absolute vertex coordinate of the
  two polygons. Points closer than ``tol`` are one point, an edge whose two ends lie within
  ``tol`` of a line of the other polygon lies on that line, and an overlap of area at most
  ``REL_TOL * L**2`` counts as touching (no crossing points, centroid-line normal; the small area
  itself is still returned). Tangent-plane coordinates projected from another element carry an
  absolute round-off of about ``R * 2.2e-16 ≈ 1.4e-9`` m, far below ``tol`` for elements of
  10 m and more.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core.geometry.quat import qmatrix

#: Relative geometric tolerance of the clipping kernels (see the module docstring).
REL_TOL = 1e-9

#: Boundary classes of the edges of the overlap polygon.
_CLS_SHARED = 0  # lies on both boundaries (collinear edges)
_CLS_POLY1 = 1  # piece of polygon 1's boundary only
_CLS_POLY2 = 2  # piece of polygon 2's boundary only


@njit(cache=True, inline="always")
def _area_centroid_n(xy, m):
    """Signed area (m², > 0 counter-clockwise) and centroid of the first ``m`` rows of ``xy``.

    Shoelace formula about the first vertex (less cancellation far from the origin). A polygon
    whose doubled area is below ``1e-13 * extent**2`` has no well-defined area centroid; its
    vertex mean is returned instead. ``m == 0`` gives ``(0, 0, 0)``.
    """
    if m == 0:
        return 0.0, 0.0, 0.0
    x0 = xy[0, 0]
    y0 = xy[0, 1]
    a2 = 0.0
    sx = 0.0
    sy = 0.0
    ext2 = 0.0
    mx = 0.0
    my = 0.0
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        xi = xy[i, 0] - x0
        yi = xy[i, 1] - y0
        xj = xy[j, 0] - x0
        yj = xy[j, 1] - y0
        cr = xi * yj - xj * yi
        a2 += cr
        sx += (xi + xj) * cr
        sy += (yi + yj) * cr
        d2 = xi * xi + yi * yi
        ext2 = max(ext2, d2)
        mx += xi
        my += yi
    if abs(a2) <= 1e-13 * ext2 or a2 == 0.0:
        return 0.5 * a2, x0 + mx / m, y0 + my / m
    return 0.5 * a2, x0 + sx / (3.0 * a2), y0 + sy / (3.0 * a2)


@njit(cache=True)
def _area2_n(xy, m):
    """Doubled signed area of the first ``m`` rows of ``xy``, summed exactly as
    :func:`_area_centroid_n` sums it (so ``0.5 * _area2_n`` is its area, bit for bit)."""
    x0 = xy[0, 0]
    y0 = xy[0, 1]
    a2 = 0.0
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        a2 += (xy[i, 0] - x0) * (xy[j, 1] - y0) - (xy[j, 0] - x0) * (xy[i, 1] - y0)
    return a2


@njit(cache=True)
def polygon_area_centroid(poly):
    """Signed area and centroid of a simple polygon ``poly (n, 2)`` (shoelace formula).

    Returns ``(area, cx, cy)``: ``area`` in m², positive for a counter-clockwise polygon and
    negative for a clockwise one; ``(cx, cy)`` in m. A degenerate polygon (zero area to
    round-off: a segment or a point) gets the mean of its vertices as centroid; an empty one
    ``(0, 0, 0)``.
    """
    return _area_centroid_n(poly, poly.shape[0])


@njit(cache=True)
def overlap_scratch_size(n1, n2):
    """Rows of scratch space ``overlap_scratch`` needs for polygons of ``n1`` and ``n2``
    vertices."""
    return 2 * (n1 + n2) + 8


@njit(cache=True)
def make_overlap_scratch(n1max, n2max):
    """Scratch buffers ``(xy, tag)`` for ``overlap_scratch``, enough for up to ``n1max``/``n2max``
    vertices: ``xy`` float64 ``(2, cap, 2)``, ``tag`` int64 ``(2, cap)``."""
    cap = overlap_scratch_size(n1max, n2max)
    return np.empty((2, cap, 2)), np.empty((2, cap), dtype=np.int64)


@njit(cache=True)
def _on_line2(px, py, qx, qy, ax, ay, ex, ey, tol2):
    """Both points ``p`` and ``q`` lie within ``sqrt(tol2)`` of the line ``a + s e``."""
    e2 = ex * ex + ey * ey
    if e2 == 0.0:
        return False
    c1 = ex * (py - ay) - ey * (px - ax)
    if c1 * c1 > tol2 * e2:
        return False
    c2 = ex * (qy - ay) - ey * (qx - ax)
    return c2 * c2 <= tol2 * e2


@njit(cache=True)
def _edge_on_boundary(px, py, qx, qy, poly, tol2):
    """Segment ``pq`` lies (within the tolerance) on the line of some edge of ``poly``."""
    n = poly.shape[0]
    for k in range(n):
        k1 = k + 1 if k + 1 < n else 0
        ax = poly[k, 0]
        ay = poly[k, 1]
        if _on_line2(px, py, qx, qy, ax, ay, poly[k1, 0] - ax, poly[k1, 1] - ay, tol2):
            return True
    return False


@njit(cache=True, inline="always")
def _unit_or_x(dx, dy, tol):
    """``(dx, dy)`` made a unit vector; ``(1, 0)`` when it is no longer than ``tol``."""
    dn = math.sqrt(dx * dx + dy * dy)
    if dn > tol and dn > 0.0:
        return dx / dn, dy / dn
    return 1.0, 0.0


@njit(cache=True, inline="always")
def _orientation(poly):
    """``+1.0`` or ``-1.0``: the sign ``overlap_scratch`` gives ``poly``'s signed area."""
    return 1.0 if 0.5 * _area2_n(poly, poly.shape[0]) >= 0.0 else -1.0


@njit(cache=True)
def overlap_scratch(poly1, poly2, xy, tag, lazy=False):
    """Intersection of two convex polygons, using caller-provided scratch space (no allocation).

    Same contract and result as ``overlap``; ``xy`` (float64 ``(2, cap, 2)``) and ``tag`` (int64
    ``(2, cap)``) are overwritten, with ``cap >= overlap_scratch_size(len(poly1), len(poly2))``
    (see ``make_overlap_scratch``; a too-small buffer raises ``ValueError``).

    ``lazy``: when the intersection is empty, return zeros for the normal too instead of the
    centroid-line normal, which then costs nothing (the engine's loop uses the normal only of
    overlapping pairs); every other result is the same, bit for bit.

    Algorithm: Sutherland–Hodgman clipping of polygon 1 by the half-planes of polygon 2's edges
    (points on an edge line count as inside). Every edge of the working polygon carries a tag
    saying which boundary it is a piece of (an edge of polygon 1 or a clipping line of polygon
    2). After near-duplicate vertices (closer than ``tol``) are merged, each edge of the overlap
    polygon gets a class: polygon 1's boundary, polygon 2's boundary, or both (it lies on a line
    of the other polygon: collinear edges). The crossing points are the vertices where the class
    changes. Generic crossings of the two boundaries are exactly the vertices where the overlap
    boundary passes from one polygon's boundary to the other's; collinear stretches (class
    "both") make extra class changes, so they never yield ``ncross == 2`` by accident unless the
    boundary of one polygon really enters the interior of the other at two points.
    """
    n1 = poly1.shape[0]
    n2 = poly2.shape[0]
    cap = xy.shape[1]
    if cap < overlap_scratch_size(n1, n2) or tag.shape[1] < cap:
        raise ValueError("overlap_scratch: scratch buffers are too small")
    return _overlap_core(poly1, poly2, xy, tag, lazy, n1, n2, False, 0.0, 0.0, False)


@njit(cache=True)
def overlap_elements(poly1, poly2, xy, tag, c2x, c2y, drop_touching=False):
    """Overlap of two *elements*, as the engine's contact loops compute it.

    ``poly1``: element 1's polygon in its own tangent plane (counter-clockwise, centre at the
    origin: ``siku_core.state``); ``poly2``: element 2's polygon projected into that plane
    (counter-clockwise too: the projection keeps the orientation) and ``(c2x, c2y)`` [m]
    element 2's centre projected likewise. Same as ``overlap_scratch(..., lazy=True)`` except
    for the fallback normal (used when the boundaries do not cross at exactly two points): it
    runs along the line between the two element centres, ``(c2x, c2y) - (0, 0)``, instead of
    between the centroids of the two planar polygons. An element's centre is its polygon's
    centroid in its own tangent plane; the centroid of the projected partner differs from the
    projected centre by the projection's distortion, a relative ``(size / R)^2`` (1e-5 for
    20 km elements), so the two normals agree to that. Knowing the centres and the orientation
    saves the two centroid and the orientation computations (about a fifth of a clip). No size
    check of the scratch buffers (see :func:`overlap_inline`).

    ``drop_touching``: a touching overlap (area at most ``REL_TOL * L**2``) comes back as no
    overlap (area 0, centroid and crossing points zero) with ``ncross = -1`` instead of with
    its small area (the scene option ``contact.touching = "ignore"``).
    """
    return _overlap_core(poly1, poly2, xy, tag, True, poly1.shape[0], poly2.shape[0], True,
                         c2x, c2y, drop_touching)


@njit(cache=True, inline="always")
def overlap_inline(poly1, poly2, xy, tag, c2x, c2y, drop_touching=False):
    """:func:`overlap_elements` for the engine's contact loop: two quadrilaterals (packs) are
    clipped by a copy compiled into the loop with the sizes known to the compiler (unrolled,
    no call, no result tuple through memory: about a third faster), other polygons by a call.
    Same arithmetic, so the same results bit for bit. The caller guarantees the scratch size
    (no check here, so no exception can leave a parallel loop)."""
    n1 = poly1.shape[0]
    n2 = poly2.shape[0]
    if n1 == 4 and n2 == 4:
        return _overlap_core(poly1, poly2, xy, tag, True, 4, 4, True, c2x, c2y, drop_touching)
    return overlap_elements(poly1, poly2, xy, tag, c2x, c2y, drop_touching)


@njit(cache=True, inline="always")
def _overlap_core(poly1, poly2, xy, tag, lazy, n1, n2, cen, c2x_in, c2y_in, drop):
    """Body of :func:`overlap_scratch` for polygons of ``n1`` and ``n2`` vertices (inlined, so
    that constant sizes compile to unrolled loops; the arithmetic is the same for any). One
    compiled pass on purpose: split into calls it would lose that unrolling and its speed.

    ``cen`` (with ``lazy``): the polygons are elements, both counter-clockwise, polygon 1
    centred at the origin and polygon 2 at ``(c2x_in, c2y_in)``: the fallback normal runs
    between those centres (:func:`overlap_elements`). ``drop``: a touching overlap comes back
    as none (area 0, centroid and crossings zero, ``ncross = -1``)."""
    cap = xy.shape[1]

    # ---- scale, tolerance, centroids of the two polygons
    big = 0.0
    for i in range(n1):
        big = max(big, abs(poly1[i, 0]), abs(poly1[i, 1]))
    for i in range(n2):
        big = max(big, abs(poly2[i, 0]), abs(poly2[i, 1]))
    tol = REL_TOL * big
    tol2 = tol * tol
    area_tol = REL_TOL * big * big

    if lazy:
        if n1 < 3 or n2 < 3 or not (big > 0.0):
            return 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        sgn2 = 1.0 if cen else _orientation(poly2)
        c1x = c1y = c2x = c2y = dx = dy = fnx = fny = 0.0
    else:
        _, c1x, c1y = _area_centroid_n(poly1, n1)
        a2s, c2x, c2y = _area_centroid_n(poly2, n2)
        dx = c2x - c1x
        dy = c2y - c1y
        dn = math.sqrt(dx * dx + dy * dy)
        if dn > tol and dn > 0.0:
            fnx = dx / dn
            fny = dy / dn
        else:
            fnx = 1.0
            fny = 0.0
        if n1 < 3 or n2 < 3 or not (big > 0.0):
            return 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, fnx, fny
        sgn2 = 1.0 if a2s >= 0.0 else -1.0

    # ---- Sutherland–Hodgman: clip polygon 1 by every edge line of polygon 2.
    # tag >= 0: piece of polygon 1's edge tag; tag < 0: piece of polygon 2's edge (-tag - 1).
    cur = 0
    m = n1
    for i in range(n1):
        xy[0, i, 0] = poly1[i, 0]
        xy[0, i, 1] = poly1[i, 1]
        tag[0, i] = i
    for k in range(n2):
        if m == 0:
            break
        k1 = k + 1 if k + 1 < n2 else 0
        ax = poly2[k, 0]
        ay = poly2[k, 1]
        ex = (poly2[k1, 0] - ax) * sgn2
        ey = (poly2[k1, 1] - ay) * sgn2
        if ex == 0.0 and ey == 0.0:
            continue  # repeated vertex: no edge
        allin = True
        for idx in range(m):
            if ex * (xy[cur, idx, 1] - ay) - ey * (xy[cur, idx, 0] - ax) < 0.0:
                allin = False
                break
        if allin:
            continue  # every point inside: the pass would copy the polygon unchanged
        nxt = 1 - cur
        mo = 0
        sx = xy[cur, m - 1, 0]
        sy = xy[cur, m - 1, 1]
        st = tag[cur, m - 1]
        fs = ex * (sy - ay) - ey * (sx - ax)
        for idx in range(m):
            px = xy[cur, idx, 0]
            py = xy[cur, idx, 1]
            pt = tag[cur, idx]
            fp = ex * (py - ay) - ey * (px - ax)
            if fp >= 0.0:
                if fs < 0.0:
                    t = fs / (fs - fp)
                    if mo < cap:
                        xy[nxt, mo, 0] = sx + t * (px - sx)
                        xy[nxt, mo, 1] = sy + t * (py - sy)
                        tag[nxt, mo] = st
                        mo += 1
                if mo < cap:
                    xy[nxt, mo, 0] = px
                    xy[nxt, mo, 1] = py
                    tag[nxt, mo] = pt
                    mo += 1
            elif fs >= 0.0:
                t = fs / (fs - fp)
                if mo < cap:
                    xy[nxt, mo, 0] = sx + t * (px - sx)
                    xy[nxt, mo, 1] = sy + t * (py - sy)
                    tag[nxt, mo] = -(k + 1)
                    mo += 1
            sx = px
            sy = py
            st = pt
            fs = fp
        cur = nxt
        m = mo

    if m == 0:
        return 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, fnx, fny
    if lazy:  # the centroid-line (or centre-line) normal is computed below when needed
        if cen:
            dx = c2x_in
            dy = c2y_in
        else:
            _, c1x, c1y = _area_centroid_n(poly1, n1)
            _, c2x, c2y = _area_centroid_n(poly2, n2)
            dx = c2x - c1x
            dy = c2y - c1y

    half, cx, cy = _area_centroid_n(xy[cur], m)  # area and centroid in one pass
    area = abs(half)
    if area <= area_tol:
        if lazy:
            fnx, fny = _unit_or_x(dx, dy, tol)
        # touching (zero-area overlap): no crossing points; centroid = mean of the vertices
        if drop:  # ncross -1 tells the caller "touching, dropped" from "apart"
            return 0.0, 0.0, 0.0, -1, 0.0, 0.0, 0.0, 0.0, fnx, fny
        sxm = 0.0
        sym = 0.0
        for i in range(m):
            sxm += xy[cur, i, 0]
            sym += xy[cur, i, 1]
        return area, sxm / m, sym / m, 0, 0.0, 0.0, 0.0, 0.0, fnx, fny

    # ---- merge vertices closer than tol (the dropped zero-length edge's tag is dropped too),
    # into the other buffer; without any such pair (the rule) the polygon stays where it is
    merge = False
    qx = xy[cur, m - 1, 0]
    qy = xy[cur, m - 1, 1]
    for i in range(m):
        px = xy[cur, i, 0]
        py = xy[cur, i, 1]
        ddx = px - qx
        ddy = py - qy
        if ddx * ddx + ddy * ddy <= tol2:
            merge = True
            break
        qx = px
        qy = py
    cl = cur
    mc = m
    if merge:
        cl = 1 - cur
        mc = 0
        for i in range(m):
            px = xy[cur, i, 0]
            py = xy[cur, i, 1]
            if mc > 0:
                ddx = px - xy[cl, mc - 1, 0]
                ddy = py - xy[cl, mc - 1, 1]
                if ddx * ddx + ddy * ddy <= tol2:
                    tag[cl, mc - 1] = tag[cur, i]
                    continue
            xy[cl, mc, 0] = px
            xy[cl, mc, 1] = py
            tag[cl, mc] = tag[cur, i]
            mc += 1
        while mc > 1:
            ddx = xy[cl, mc - 1, 0] - xy[cl, 0, 0]
            ddy = xy[cl, mc - 1, 1] - xy[cl, 0, 1]
            if ddx * ddx + ddy * ddy <= tol2:
                mc -= 1
            else:
                break

    ncross = 0
    p1x = 0.0
    p1y = 0.0
    p2x = 0.0
    p2y = 0.0
    if mc >= 3:
        # ---- boundary class of every edge, into the free row tag[1 - cl]
        for i in range(mc):
            j = i + 1 if i + 1 < mc else 0
            px = xy[cl, i, 0]
            py = xy[cl, i, 1]
            qx = xy[cl, j, 0]
            qy = xy[cl, j, 1]
            if tag[cl, i] >= 0:
                if _edge_on_boundary(px, py, qx, qy, poly2, tol2):
                    tag[1 - cl, i] = _CLS_SHARED
                else:
                    tag[1 - cl, i] = _CLS_POLY1
            else:
                if _edge_on_boundary(px, py, qx, qy, poly1, tol2):
                    tag[1 - cl, i] = _CLS_SHARED
                else:
                    tag[1 - cl, i] = _CLS_POLY2
        # ---- crossing points: vertices where the class changes
        prev = tag[1 - cl, mc - 1]
        for i in range(mc):
            c = tag[1 - cl, i]
            if c != prev:
                if ncross == 0:
                    p1x = xy[cl, i, 0]
                    p1y = xy[cl, i, 1]
                elif ncross == 1:
                    p2x = xy[cl, i, 0]
                    p2y = xy[cl, i, 1]
                ncross += 1
            prev = c

    nx = 0.0
    ny = 0.0
    if ncross == 2:
        ux = p2x - p1x
        uy = p2y - p1y
        un = math.sqrt(ux * ux + uy * uy)
        if un > tol:
            nx = -uy / un
            ny = ux / un
            if nx * dx + ny * dy < 0.0:
                nx = -nx
                ny = -ny
        else:
            ncross = 1  # the two crossings coincide within tol: one point, no chord
    if ncross != 2:
        if lazy:
            nx, ny = _unit_or_x(dx, dy, tol)
        else:
            nx = fnx
            ny = fny
        p1x = 0.0
        p1y = 0.0
        p2x = 0.0
        p2y = 0.0
    return area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny


@njit(cache=True, inline="always")
def _line_separates(a, k, b, m2):
    """No vertex of ``b`` lies strictly inside the line of CCW polygon ``a``'s edge ``k`` by more
    than ``sqrt(m2)`` [m] (``f = e × (p - a) > 0`` is inside, as the clipping computes it;
    ``m2 = 0``: no vertex strictly inside at all)."""
    n = a.shape[0]
    k1 = k + 1 if k + 1 < n else 0
    ax = a[k, 0]
    ay = a[k, 1]
    ex = a[k1, 0] - ax
    ey = a[k1, 1] - ay
    lim = m2 * (ex * ex + ey * ey)
    # the deepest vertex decides (f > 0 and f² > lim grow together): no early exit, no branch
    # to mispredict
    fmax = 0.0
    for v in range(b.shape[0]):
        f = ex * (b[v, 1] - ay) - ey * (b[v, 0] - ax)
        fmax = f if f > fmax else fmax
    return not (fmax > 0.0 and (lim == 0.0 or fmax * fmax > lim))


@njit(cache=True, inline="always")
def separating_edge(poly1, poly2, margin, hint):
    """Index of an edge line of either convex CCW polygon that has every vertex of the other
    outside it, on it or at most ``margin`` [m] inside; ``-1`` when there is none.

    Edges ``0 … n1-1`` are ``poly1``'s (edge ``k`` from vertex ``k`` to ``k+1``), ``n1 …
    n1+n2-1`` are ``poly2``'s. Edge ``hint`` is tried first: the edge that separated a pair at
    the last step almost always still does, so a pair that stays apart costs one line (about
    ``n2`` evaluations) instead of a search. Whether an edge is found does not depend on
    ``hint``; only which one and how fast.
    """
    n1 = poly1.shape[0]
    n2 = poly2.shape[0]
    if n1 < 3 or n2 < 3:
        return -1
    m2 = margin * margin
    if 0 <= hint < n1:
        if _line_separates(poly1, hint, poly2, m2):
            return hint
    elif n1 <= hint < n1 + n2:
        if _line_separates(poly2, hint - n1, poly1, m2):
            return hint
    for k in range(n1):
        if k != hint and _line_separates(poly1, k, poly2, m2):
            return k
    for k in range(n2):
        if k + n1 != hint and _line_separates(poly2, k, poly1, m2):
            return k + n1
    return -1


@njit(cache=True)
def apart(poly1, poly2):
    """``True`` when an edge line of either convex CCW polygon has every vertex of the other on
    its outer side or on the line (``f(p) = e × (p - a) <= 0``, as the clipping computes it):
    the polygons are apart or only touch, their overlap has no area (separating axis theorem).
    ``False`` for polygons whose interiors overlap.

    Exact on the given coordinates (no margin): polygons that touch along an edge or at a
    corner, as jointed neighbours of a pack do at rest, are apart here, where the clipping
    returns an empty intersection or a sliver of the size of the round-off of the coordinates.
    Cost: one pass over the edges of each polygon, each stopping at the first vertex inside
    (about ``n1 + n2`` evaluations for overlapping polygons).
    """
    return separating_edge(poly1, poly2, 0.0, -1) >= 0


@njit(cache=True)
def apart_within(poly1, poly2, margin):
    """:func:`apart` with a margin: an edge line of either polygon has every vertex of the other
    outside it, on it or at most ``margin`` [m] inside.

    With ``margin <= REL_TOL * s / 3`` and ``s`` at most the largest absolute vertex coordinate
    of the two polygons (the clip's ``L``), polygons found apart overlap by less than the clip's
    touching area ``REL_TOL * L**2``: their overlap lies in a strip of width ``margin`` along
    the separating line inside one polygon, whose chord is at most its diameter ``2 sqrt(2) L``,
    so the area is at most ``2 sqrt(2) / 3 REL_TOL L**2 < REL_TOL L**2``.
    """
    return separating_edge(poly1, poly2, margin, -1) >= 0


@njit(cache=True)
def overlap(poly1, poly2):
    """Intersection of two convex polygons in one plane: overlap geometry of one contact.

    Parameters
    ----------
    poly1, poly2 : float64 ``(n1, 2)``, ``(n2, 2)``
        Convex counter-clockwise polygons, metres, in one common tangent plane (normally element
        1's, with ``poly2`` from ``project_partner``). Up to 64 vertices each is the tested range;
        any size works.

    Returns
    -------
    area : float
        Area of the intersection polygon, m² (>= 0; 0 when disjoint).
    cx, cy : float
        Centroid of the intersection polygon, m. For a zero-area (touching) overlap, the mean of
        its vertices (a point where the polygons touch); ``(0, 0)`` when disjoint.
    ncross : int
        Number of points where the two boundaries cross (0 when disjoint, touching or one inside
        the other without shared boundary; 2 in the generic partial overlap; more for e.g. a
        star of David (6) or a square over its 45°-rotated copy (8)). Collinear (shared) edges
        count their end points as class changes (see ``overlap_scratch``).
    p1x, p1y, p2x, p2y : float
        The two crossing points ``P1``, ``P2`` (m) when ``ncross == 2``; zeros otherwise.
    nx, ny : float
        Unit contact normal (eq. 10), pointing from polygon 1 towards polygon 2
        (``n · (c2 - c1) >= 0`` with ``c1``, ``c2`` the polygons' centroids). Perpendicular to
        ``P1P2`` when ``ncross == 2``; otherwise along ``c2 - c1`` (report Fig. 4b), or ``(1, 0)``
        when the centroids coincide. Always finite.

    Allocates two small scratch arrays per call; ``overlap_scratch`` takes them from the caller.
    """
    xy, tag = make_overlap_scratch(poly1.shape[0], poly2.shape[0])
    return overlap_scratch(poly1, poly2, xy, tag)


@njit(cache=True)
def project_partner(q1, q2, verts2, radius, out):
    """Write element 2's vertices into element 1's tangent-plane coordinates (gnomonic).

    ``verts2 (n, 2)``: element 2's local vertices in metres (its own tangent plane); ``q1``,
    ``q2``: the elements' unit quaternions (scalar first, local → global); ``radius``: planet
    radius in metres; ``out (n, 2)``: receives the same points in element 1's tangent plane, m.

    Equal to ``to_tangent(q1, from_tangent(q2, x, y, radius), radius)`` for every vertex (the
    normalisation of the unit vector cancels in the gnomonic ratio), computed with the one matrix
    ``R(q1)^T R(q2)`` for all vertices. Meaningful only while element 2's vertices lie in element
    1's visible hemisphere (always so for contact partners); returns ``out``.
    """
    r1 = qmatrix(q1)
    r2 = qmatrix(q2)
    m = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            m[a, b] = r1[0, a] * r2[0, b] + r1[1, a] * r2[1, b] + r1[2, a] * r2[2, b]
    inv_r = 1.0 / radius
    for i in range(verts2.shape[0]):
        u = verts2[i, 0] * inv_r
        v = verts2[i, 1] * inv_r
        gx = m[0, 0] * u + m[0, 1] * v + m[0, 2]
        gy = m[1, 0] * u + m[1, 1] * v + m[1, 2]
        gz = m[2, 0] * u + m[2, 1] * v + m[2, 2]
        f = radius / gz
        out[i, 0] = gx * f
        out[i, 1] = gy * f
    return out
