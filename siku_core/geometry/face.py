"""The touching face of two jointed neighbours, without clipping.

Two elements frozen along a shared edge (a joint, ``docs/explanation/contacts.md`` §3) sit
face to face: under the report's rule they also collide, and their overlap is a sliver along the
joint whose depth is round-off (about 2e-9 m on the bench pack, one ulp of the planet radius).
The clip (:func:`~siku_core.geometry.clip.overlap_elements`) calls such an overlap *touching*
(area at most ``REL_TOL L²``) and gives it the centre-line normal, the common span across it as
width and, as contact point, the mean of the sliver's vertices, which round-off decides: on the
bench pack the point of one face contact in twenty lies anywhere along the face, up to half its
length from the middle.

:func:`touching_face` finds the same contact from the two edges of the joint, in about a
third of the clip's time, and puts it at the middle of the face. It accepts a pair only when it
can prove the overlap touching, so that the clip would have called it touching too; every other
pair goes to the clip (a real overlap, a joint turned or sheared apart), except one that the
line of the joint's edge separates (no overlap, no clip).

**Proof.** Let ``P`` be element ``i``'s polygon, ``Q`` element ``j``'s projected into ``i``'s
plane, ``e`` the joint's edge of ``Q`` (``Q``'s interior on its left), ``D`` the deepest
penetration of any vertex of ``P`` across ``e``'s line into ``Q``'s side, and ``s`` the largest
absolute vertex coordinate of ``P`` (its centre is the origin). The overlap ``P ∩ Q`` lies in
``P`` and within ``D`` of the line, so its area is at most ``D diam(P) <= 2 sqrt(2) D s``. The
function accepts only ``D <= REL_TOL s / 4``, so the area is at most ``0.71 REL_TOL s²``, below
the clip's touching tolerance ``REL_TOL big²`` (``big >= s`` is the clip's scale over both
polygons), with room for the clip's own round-off. It also asks that both ends of ``e`` lie
within ``REL_TOL s`` of the line of ``P``'s joint edge: then every point of the two edges'
common stretch is within that distance of both polygons' boundaries, and the touching set of
the contact holds that stretch. With ``D < 0`` every vertex of ``P`` lies strictly outside
``e``'s line, which separates the two: no overlap.

**What is the same and what is not.** The area is the integral of the penetration profile,
linear along the edge, over the common stretch: it differs from the clip's area of the same set
by the end triangles cut by the adjacent edges (order ``D²``) and by round-off of the vertex
coordinates, a few ``eps s L`` for an edge of length ``L`` (fuzzed against the clip in
``tests/contacts/test_touching_face.py``); both areas are below the touching tolerance. The
normal runs along the centre line, as the clip's for a touching overlap (the caller computes
it). Two things differ by design: the contact point is the middle of the common stretch, and
the width is the stretch's length, the face's contact length (the clip's touching rule takes
the common span of the two polygons across the normal: the same for a face square to the centre
line, longer for a face at an angle to it). ``docs/explanation/contacts.md`` §2.5 measures
what that changes.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core.geometry.clip import REL_TOL


@njit(cache=True, inline="always")
def edge_constants(poly1, s):
    """``|u|²``, ``1 / |u|²`` and ``|u|`` of ``poly1``'s edge ``s`` (from vertex ``s`` to
    ``s + 1``, ``u`` in m) as :func:`touching_face` computes them: constants of a rigid
    element, which the engine computes once (:func:`edge_table`)."""
    n1 = poly1.shape[0]
    s1 = s + 1 if s + 1 < n1 else 0
    ux = poly1[s1, 0] - poly1[s, 0]
    uy = poly1[s1, 1] - poly1[s, 1]
    u2 = ux * ux + uy * uy
    return u2, 1.0 / u2 if u2 > 0.0 else 0.0, math.sqrt(u2)


@njit(cache=True)
def edge_table(offsets, verts):
    """:func:`edge_constants` of every edge of every element: ``(n_vertices, 3)``, row
    ``offsets[e] + s`` for edge ``s`` of element ``e``."""
    out = np.empty((verts.shape[0], 3))
    for e in range(offsets.shape[0] - 1):
        poly = verts[offsets[e]:offsets[e + 1]]
        for s in range(poly.shape[0]):
            u2, inv_u2, ul = edge_constants(poly, s)
            out[offsets[e] + s, 0] = u2
            out[offsets[e] + s, 1] = inv_u2
            out[offsets[e] + s, 2] = ul
    return out


@njit(cache=True, inline="always")
def touching_face(poly1, s, bx, by, cx, cy, scale):
    """Overlap of two jointed polygons that only touch along the joint, from the joint's edges.

    ``poly1`` (``n × 2``, counter-clockwise, centre at the origin) as the clip takes it and
    ``s`` its edge of the joint (from vertex ``s`` to ``s + 1``); ``(bx, by)`` and ``(cx, cy)``
    [m]: the ends of the other polygon's edge of the joint, projected into ``poly1``'s plane,
    in that polygon's (counter-clockwise) order, so ``b`` lies near vertex ``s + 1`` and ``c``
    near vertex ``s``; ``scale`` [m]: the largest absolute vertex coordinate of ``poly1``.

    Returns ``(area, px, py, width)``: ``area < 0`` when the overlap is not proven a touching
    face contact (the caller clips the pair); ``area == 0`` when the two do not overlap (every
    vertex of ``poly1`` lies strictly outside the line ``b -> c``, which then separates them,
    or the two faces touch nowhere; the caller treats the pair as apart); otherwise the area
    (m², at most ``REL_TOL scale²``), the contact point, the middle of the two edges' common
    stretch [m], and the stretch's length [m] (module docstring).
    """
    u2, inv_u2, ul = edge_constants(poly1, s)
    return touching_face_u(poly1, s, bx, by, cx, cy, scale, u2, inv_u2, ul)


@njit(cache=True, inline="always")
def touching_face_u(poly1, s, bx, by, cx, cy, scale, u2, inv_u2, ul):
    """:func:`touching_face` with its edge's constants given: ``u2 = |u|²`` [m²], ``inv_u2 =
    1 / |u|²`` [1/m²] and ``ul = |u|`` [m] of ``poly1``'s edge ``s`` (:func:`edge_constants`,
    a row of :func:`edge_table`)."""
    n1 = poly1.shape[0]
    ex = cx - bx
    ey = cy - by
    e2 = ex * ex + ey * ey
    tol = REL_TOL * scale
    if not e2 > 0.0:
        return -1.0, 0.0, 0.0, 0.0
    # the deepest vertex of poly1 across the line b -> c (f = e × (p - b), as the clip)
    s1 = s + 1 if s + 1 < n1 else 0
    deep = -math.inf
    fa = fb = 0.0
    for v in range(n1):
        f = ex * (poly1[v, 1] - by) - ey * (poly1[v, 0] - bx)
        if v == s:
            fa = f
        elif v == s1:
            fb = f
        deep = max(deep, f)
    if deep < 0.0:
        return 0.0, 0.0, 0.0, 0.0  # the line separates the two: no overlap
    if deep * deep > (0.25 * tol) ** 2 * e2:
        return -1.0, 0.0, 0.0, 0.0  # deeper than a quarter tolerance: the clip decides
    # the other edge's ends on the line of poly1's edge (g = u × (q - p))
    px = poly1[s, 0]
    py = poly1[s, 1]
    ux = poly1[s1, 0] - px
    uy = poly1[s1, 1] - py
    if not u2 > 0.0:
        return -1.0, 0.0, 0.0, 0.0
    bx -= px
    by -= py
    cx -= px
    cy -= py
    gb = ux * by - uy * bx
    gc = ux * cy - uy * cx
    lim = tol * tol * u2
    if gb * gb > lim or gc * gc > lim:
        return -1.0, 0.0, 0.0, 0.0  # not face to face within the tolerance
    # the common stretch, as fractions of poly1's edge, and the penetration profile along it
    x0 = max(0.0, (cx * ux + cy * uy) * inv_u2)
    x1 = min(1.0, (bx * ux + by * uy) * inv_u2)
    if not x1 > x0:
        return 0.0, 0.0, 0.0, 0.0
    f0 = fa + (fb - fa) * x0
    f1 = fa + (fb - fa) * x1
    if f0 >= 0.0 and f1 >= 0.0:
        fint = 0.5 * (f0 + f1)
    elif f0 > 0.0:
        fint = 0.5 * f0 * f0 / (f0 - f1)
    elif f1 > 0.0:
        fint = 0.5 * f1 * f1 / (f1 - f0)
    else:
        return 0.0, 0.0, 0.0, 0.0
    width = (x1 - x0) * ul
    # depth f / |e| integrated over the stretch
    area = fint * width / math.sqrt(e2)
    xm = 0.5 * (x0 + x1)
    return area, px + xm * ux, py + xm * uy, width


@njit(cache=True)
def joint_edges(offsets, verts, ji, jj, ends_i, ends_j):
    """The polygon edges a joint is frozen along: ``(K, 2)`` int64, per joint the edge of ``ji``
    (from vertex ``e`` to ``e + 1``) whose ends are nearest the joint's ends ``ends_i`` (in
    ``ji``'s frame, m), and the edge of ``jj`` nearest ``ends_j`` (running the other way: from
    the vertex at ``ends_j[1]`` to the one at ``ends_j[0]``)."""
    nj = ji.shape[0]
    out = np.zeros((nj, 2), dtype=np.int64)
    for n in range(nj):
        for side in range(2):
            el = ji[n] if side == 0 else jj[n]
            ends = ends_i if side == 0 else ends_j
            first = 0 if side == 0 else 1
            o = offsets[el]
            m = offsets[el + 1] - o
            best = math.inf
            for e in range(m):
                e1 = e + 1 if e + 1 < m else 0
                d0 = ((verts[o + e, 0] - ends[n, first, 0]) ** 2
                      + (verts[o + e, 1] - ends[n, first, 1]) ** 2)
                d1 = ((verts[o + e1, 0] - ends[n, 1 - first, 0]) ** 2
                      + (verts[o + e1, 1] - ends[n, 1 - first, 1]) ** 2)
                d = max(d0, d1)
                if d < best:
                    best = d
                    out[n, side] = e
    return out
