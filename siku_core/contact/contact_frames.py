"""Frames and geometry helpers of the contact loops (:mod:`siku_core.contact.contact_forces`).

Element ``i``'s tangent frame and ``j``'s: points of one in the other (:func:`frame_point`, and
through the relative rotation ``M = R_i^T R_j`` of :func:`relative_matrix`: :func:`j_to_i`,
:func:`i_to_j`, :func:`relative_velocity_m`), the rotation matrices of all elements, eq. 9's
stiffness, the per-contact row of generalised forces (``ROW_*``, :func:`pair_contribution`),
the constants of joints and candidate pairs, the contact width of an overlap, joint detection
(:func:`find_shared_edges`) and the CSR index from elements to their contacts
(:func:`element_index`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..geometry.quat import from_tangent, to_tangent
from ..parallel import chunk_bounds


@njit(cache=True, inline="always")
def frame_point(qa, qb, x, y, R):
    """Point ``(x, y)`` [m] of ``qa``'s tangent plane, in ``qb``'s tangent plane [m]."""
    p = from_tangent(qa, x, y, R)
    return to_tangent(qb, p, R)


@njit(cache=True, inline="always")
def eq9_stiffness(hi, Ei, hj, Ej, ri, rj):
    """Effective stiffness of eq. 9, ``K = h1 E1 h2 E2 / (h1 E1 r2 + h2 E2 r1)`` [Pa]."""
    a = hi * Ei
    b = hj * Ej
    den = a * rj + b * ri
    if den <= 0.0:
        return 0.0
    return a * b / den


@njit(cache=True, inline="always")
def _span_across(pi, pj, nx, ny):
    """Width of an overlap without two boundary crossings: the common span of both polygons
    across the normal ``n`` (along ``t = (-ny, nx)``) [m].

    The overlap lies inside both polygons, so its extent along ``t`` lies within both
    polygons' extents: exact for a face-on contact between collinear edges (the overlap strip
    spans the whole shared face) and for one polygon inside the other (its own extent).
    """
    tx, ty = -ny, nx
    lo_i = hi_i = pi[0, 0] * tx + pi[0, 1] * ty
    for v in range(1, pi.shape[0]):
        p = pi[v, 0] * tx + pi[v, 1] * ty
        lo_i = min(lo_i, p)
        hi_i = max(hi_i, p)
    lo_j = hi_j = pj[0, 0] * tx + pj[0, 1] * ty
    for v in range(1, pj.shape[0]):
        p = pj[v, 0] * tx + pj[v, 1] * ty
        lo_j = min(lo_j, p)
        hi_j = max(hi_j, p)
    return min(hi_i, hi_j) - max(lo_i, lo_j)


@njit(cache=True, inline="always")
def overlap_width(pi, pj, a, ncross, p1x, p1y, p2x, p2y, nx, ny):
    """Contact width of a clipped overlap [m]: the chord between the two boundary crossings,
    else the common span across the normal (``_span_across``), else ``sqrt(area)``."""
    if ncross == 2:
        return math.sqrt((p2x - p1x) ** 2 + (p2y - p1y) ** 2)
    width = _span_across(pi, pj, nx, ny)
    if not width > 0.0:
        width = math.sqrt(a)
    return width


@njit(cache=True)
def find_shared_edges(q, offsets, verts, pairs, tol, R):
    """Edges shared by candidate pairs (both polygons CCW, so a shared edge runs opposite ways).

    Edge ``(a, b)`` of ``i`` and edge ``(c, d)`` of ``j`` (projected into ``i``'s frame) match
    when ``|a - d|`` and ``|b - c|`` are both at most ``tol`` times the length of ``i``'s edge.
    Returns per pair: ``found`` (bool), the joint ends in ``i``'s frame (means of the matched
    vertices) ``ends_i (K,2,2)`` and in ``j``'s frame ``ends_j (K,2,2)``.
    """
    npairs = pairs.shape[0]
    found = np.zeros(npairs, dtype=np.bool_)
    ends_i = np.zeros((npairs, 2, 2))
    ends_j = np.zeros((npairs, 2, 2))
    for k in range(npairs):
        i = pairs[k, 0]
        j = pairs[k, 1]
        ni = offsets[i + 1] - offsets[i]
        nj = offsets[j + 1] - offsets[j]
        pj = np.empty((nj, 2))
        for v in range(nj):
            x, y = frame_point(q[j], q[i], verts[offsets[j] + v, 0], verts[offsets[j] + v, 1], R)
            pj[v, 0] = x
            pj[v, 1] = y
        best = np.inf
        for e in range(ni):
            a = verts[offsets[i] + e]
            b = verts[offsets[i] + (e + 1) % ni]
            L = math.hypot(b[0] - a[0], b[1] - a[1])
            for f in range(nj):
                c = pj[f]
                d = pj[(f + 1) % nj]
                e1 = math.hypot(a[0] - d[0], a[1] - d[1])
                e2 = math.hypot(b[0] - c[0], b[1] - c[1])
                mis = max(e1, e2)
                if mis <= tol * L and mis < best:
                    best = mis
                    found[k] = True
                    ends_i[k, 0, 0] = 0.5 * (a[0] + d[0])
                    ends_i[k, 0, 1] = 0.5 * (a[1] + d[1])
                    ends_i[k, 1, 0] = 0.5 * (b[0] + c[0])
                    ends_i[k, 1, 1] = 0.5 * (b[1] + c[1])
        if found[k]:
            for t in range(2):
                x, y = frame_point(q[i], q[j], ends_i[k, t, 0], ends_i[k, t, 1], R)
                ends_j[k, t, 0] = x
                ends_j[k, t, 1] = y
    return found, ends_i, ends_j


# Relative frames: with ``Ri = R(q_i)`` the matrix ``M = Ri^T Rj`` maps directions of ``j``'s
# local frame to ``i``'s, so a point ``(x, y)`` of ``j``'s tangent plane is ``g_xy (R / g_z)``
# with ``g = M (x/R, y/R, 1)`` in ``i``'s plane (the gnomonic normalisation cancels), and
# ``M^T`` goes back. ``M`` and the projection are computed exactly as ``project_partner``
# does, so the narrow phase sees the same partner vertices as the tests' reference loops, bit
# for bit.

#: per-contact contribution layout: generalised force and torque on ``i``, then on ``j``, then
#: the contact point in ``i``'s frame [m] (what the element stress of ``siku_core.contact.stress``
#: needs)
ROW_FIX, ROW_FIY, ROW_TI, ROW_FJX, ROW_FJY, ROW_TJ, ROW_PX, ROW_PY = range(8)
ROW_SIZE = 8


@njit(cache=True, inline="always")
def rotation_row(q, rm, i):
    """``rm[i] = R(q_i)``; returns the element's centre, ``R(q_i) e_z`` (its last column)."""
    w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    rm[i, 0, 0] = 1 - 2 * (y * y + z * z)
    rm[i, 0, 1] = 2 * (x * y - w * z)
    cx = 2 * (x * z + w * y)
    rm[i, 0, 2] = cx
    rm[i, 1, 0] = 2 * (x * y + w * z)
    rm[i, 1, 1] = 1 - 2 * (x * x + z * z)
    cy = 2 * (y * z - w * x)
    rm[i, 1, 2] = cy
    rm[i, 2, 0] = 2 * (x * z - w * y)
    rm[i, 2, 1] = 2 * (y * z + w * x)
    cz = 1 - 2 * (x * x + y * y)
    rm[i, 2, 2] = cz
    return cx, cy, cz


@njit(cache=True, parallel=True)
def rotation_matrices(q, rm, nch):
    """``rm[i] = R(q_i)`` (as :func:`~siku_core.geometry.quat.qmatrix`, bit for bit)."""
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        for i in range(lo, hi):
            rotation_row(q, rm, i)


@njit(cache=True, parallel=True)
def rotations_within(q, rm, nch, ref, lim2):
    """:func:`rotation_matrices`, and whether every element centre ``R(q_i) e_z`` lies within
    a squared chord ``lim2`` of its ``ref[i]`` (unit vectors, ``(N, 3)``; ``False`` for a NaN):
    the candidate list's check (``contact.skin``) in the same pass over the elements, where
    the centres are at hand, instead of a pass of its own on one thread."""
    n = q.shape[0]
    ok = np.ones(nch, dtype=np.bool_)
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        good = True
        for i in range(lo, hi):
            cx, cy, cz = rotation_row(q, rm, i)
            dx = cx - ref[i, 0]
            dy = cy - ref[i, 1]
            dz = cz - ref[i, 2]
            good &= dx * dx + dy * dy + dz * dz <= lim2
        ok[c] = good
    return ok.all()


@njit(cache=True)
def relative_matrix(rm, i, j):
    """``M = R_i^T R_j`` as nine scalars (row-major), summed as ``project_partner`` does."""
    m00 = rm[i, 0, 0] * rm[j, 0, 0] + rm[i, 1, 0] * rm[j, 1, 0] + rm[i, 2, 0] * rm[j, 2, 0]
    m01 = rm[i, 0, 0] * rm[j, 0, 1] + rm[i, 1, 0] * rm[j, 1, 1] + rm[i, 2, 0] * rm[j, 2, 1]
    m02 = rm[i, 0, 0] * rm[j, 0, 2] + rm[i, 1, 0] * rm[j, 1, 2] + rm[i, 2, 0] * rm[j, 2, 2]
    m10 = rm[i, 0, 1] * rm[j, 0, 0] + rm[i, 1, 1] * rm[j, 1, 0] + rm[i, 2, 1] * rm[j, 2, 0]
    m11 = rm[i, 0, 1] * rm[j, 0, 1] + rm[i, 1, 1] * rm[j, 1, 1] + rm[i, 2, 1] * rm[j, 2, 1]
    m12 = rm[i, 0, 1] * rm[j, 0, 2] + rm[i, 1, 1] * rm[j, 1, 2] + rm[i, 2, 1] * rm[j, 2, 2]
    m20 = rm[i, 0, 2] * rm[j, 0, 0] + rm[i, 1, 2] * rm[j, 1, 0] + rm[i, 2, 2] * rm[j, 2, 0]
    m21 = rm[i, 0, 2] * rm[j, 0, 1] + rm[i, 1, 2] * rm[j, 1, 1] + rm[i, 2, 2] * rm[j, 2, 1]
    m22 = rm[i, 0, 2] * rm[j, 0, 2] + rm[i, 1, 2] * rm[j, 1, 2] + rm[i, 2, 2] * rm[j, 2, 2]
    return m00, m01, m02, m10, m11, m12, m20, m21, m22


@njit(cache=True)
def j_to_i(M, x, y, R, inv_r):
    """Point ``(x, y)`` [m] of ``j``'s tangent plane in ``i``'s (``project_partner``'s
    arithmetic)."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = M
    u = x * inv_r
    v = y * inv_r
    gx = m00 * u + m01 * v + m02
    gy = m10 * u + m11 * v + m12
    gz = m20 * u + m21 * v + m22
    f = R / gz
    return gx * f, gy * f


@njit(cache=True)
def centre_normal(M, R, tol):
    """Unit vector from ``i``'s centre towards ``j``'s in ``i``'s plane, ``(1, 0)`` when the
    centres lie within ``tol`` [m] (``_unit_or_x`` of ``j_to_i(M, 0, 0)``, without its
    divisions: ``j``'s centre projects to ``R (m02, m12) / m22``)."""
    m02 = M[2]
    m12 = M[5]
    dn = math.sqrt(m02 * m02 + m12 * m12)
    if R * dn > tol * M[8] and dn > 0.0:
        inv = 1.0 / dn
        return m02 * inv, m12 * inv
    return 1.0, 0.0


@njit(cache=True)
def i_to_j(M, x, y, R, inv_r):
    """Point ``(x, y)`` [m] of ``i``'s tangent plane in ``j``'s."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = M
    u = x * inv_r
    v = y * inv_r
    gx = m00 * u + m10 * v + m20
    gy = m01 * u + m11 * v + m21
    gz = m02 * u + m12 * v + m22
    f = R / gz
    return gx * f, gy * f


@njit(cache=True)
def relative_velocity_m(M, V, w, i, j, px, py, xj, yj):
    """Velocity of ``j``'s material point at ``i``-frame ``(px, py)`` (``(xj, yj)`` in ``j``'s
    frame) minus ``i``'s, in ``i``'s frame (radial part dropped)."""
    m00, m01, _m02, m10, m11, _m12, _m20, _m21, _m22 = M
    vix = V[i, 0] - w[i] * py
    viy = V[i, 1] + w[i] * px
    vjx_l = V[j, 0] - w[j] * yj
    vjy_l = V[j, 1] + w[j] * xj
    return (m00 * vjx_l + m01 * vjy_l) - vix, (m10 * vjx_l + m11 * vjy_l) - viy


@njit(cache=True)
def pair_contribution(M, fx, fy, px, py, couple, inv_r, R, out, k):
    """Row ``out[k]`` (``ROW_*``): force ``(fx, fy)`` (``i``'s frame) and ``couple`` on ``j`` at
    ``i``-frame point ``(px, py)``, and the opposite on ``i``, as generalised forces; and the
    point itself.

    As :func:`apply_pair`: with ``X`` the contact point (unit vector) and ``f`` the force, the
    torque about the planet centre on ``j`` is ``tau = R X × f + couple X``; in ``i``'s frame
    ``X = (px/R, py/R, 1)/|.|`` and ``f = (fx, fy, 0)``, and ``M^T`` takes ``tau`` to ``j``'s
    frame. ``Fx = tau_y / R``, ``Fy = -tau_x / R``, ``T = tau_z`` (``i`` gets the negatives).
    """
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = M
    u = px * inv_r
    v = py * inv_r
    nrm = 1.0 / math.sqrt(u * u + v * v + 1.0)
    x0 = u * nrm
    x1 = v * nrm
    x2 = nrm
    cr = couple * inv_r
    # s = tau / R in i's frame
    s0 = -x2 * fy + cr * x0
    s1 = x2 * fx + cr * x1
    s2 = x0 * fy - x1 * fx + cr * x2
    out[k, ROW_FIX] = -s1
    out[k, ROW_FIY] = s0
    out[k, ROW_TI] = -R * s2
    t0 = m00 * s0 + m10 * s1 + m20 * s2
    t1 = m01 * s0 + m11 * s1 + m21 * s2
    t2 = m02 * s0 + m12 * s1 + m22 * s2
    out[k, ROW_FJX] = t1
    out[k, ROW_FJY] = -t0
    out[k, ROW_TJ] = R * t2
    out[k, ROW_PX] = px
    out[k, ROW_PY] = py


@njit(cache=True)
def joint_arms(ends_i, ends_j):
    """Per joint: the lever arms of eq. 9 [m], the distances from each element's centre to the
    joint's midpoint in its own frame; they change only where a joint's line does."""
    nj = ends_i.shape[0]
    ri = np.empty(nj)
    rj = np.empty(nj)
    for k in range(nj):
        ri[k] = math.hypot(0.5 * (ends_i[k, 0, 0] + ends_i[k, 1, 0]),
                           0.5 * (ends_i[k, 0, 1] + ends_i[k, 1, 1]))
        rj[k] = math.hypot(0.5 * (ends_j[k, 0, 0] + ends_j[k, 1, 0]),
                           0.5 * (ends_j[k, 0, 1] + ends_j[k, 1, 1]))
    return ri, rj


@njit(cache=True, parallel=True)
def joint_constants(h, E, minv, ji, jj, ri, rj):
    """Per joint: eq. 9 stiffness ``K`` [Pa] (lever arms ``ri``, ``rj`` [m] of
    :func:`joint_arms`) and reduced mass [kg], from the thickness [m], modulus [Pa] and inverse
    masses [1/kg] of its elements: recomputed after a process changed the ice."""
    nj = ji.shape[0]
    K = np.empty(nj)
    meff = np.empty(nj)
    for k in prange(nj):
        i = ji[k]
        j = jj[k]
        K[k] = eq9_stiffness(h[i], E[i], h[j], E[j], ri[k], rj[k])
        meff[k] = 1.0 / (minv[i] + minv[j])
    return K, meff


@njit(cache=True)
def element_index(a, b, n):
    """CSR index from elements to contacts ``k`` with ends ``a[k]``, ``b[k]``: element ``e``'s
    contacts are ``idx[off[e]:off[e+1]]`` in ascending ``k``, ``side`` 0 where ``e`` is the
    contact's ``i`` (``a``), 1 where it is ``j`` (``b``)."""
    m = a.shape[0]
    off = np.zeros(n + 1, dtype=np.int64)
    for k in range(m):
        off[a[k] + 1] += 1
        off[b[k] + 1] += 1
    for e in range(n):
        off[e + 1] += off[e]
    fill = off[:n].copy()
    idx = np.empty(2 * m, dtype=np.int64)
    side = np.empty(2 * m, dtype=np.int8)
    for k in range(m):
        e = a[k]
        idx[fill[e]] = k
        side[fill[e]] = 0
        fill[e] += 1
        e = b[k]
        idx[fill[e]] = k
        side[fill[e]] = 1
        fill[e] += 1
    return off, idx, side
