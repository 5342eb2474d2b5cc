"""Contacts: frozen joints, collision candidates, and the engine's loops over them.

PHYSICS.md section 4. The engine owns the loops; a contact law supplies small ``@njit``
evaluators of *one* contact (HOOMD's "template evaluator"), passed to the loops as arguments.

Sign conventions (both evaluators)
----------------------------------
Geometry is expressed in element ``i``'s tangent frame. An evaluator returns the force on
element ``j`` (``out[0:2]``, N, in ``i``'s frame) and a couple on ``j`` (``out[2]``, N m, about
the local vertical). The engine applies them to ``j`` and the opposite to ``i``, as a 3D force
at the contact point on the sphere, so each pair's contribution to the angular momentum about
the planet centre cancels exactly.

Collision geometry ``g`` (float64[:], indices ``G_*``): overlap area [m²], overlap centroid
[m], unit normal from ``i`` towards ``j``, contact width [m] (``|P1P2|`` when the boundaries
cross twice, else the common span of both polygons across the normal: the face length for a
face-on contact between collinear edges, the inner polygon's span when one lies inside the
other), effective stiffness ``K`` of eq. 9 [Pa], reduced mass [kg], velocity of ``j`` relative
to ``i`` at the centroid [m/s], both areas [m²].

Joint geometry ``g`` (indices ``J_*``): the end displacements ``s1, s2`` [m] (``j``'s copy minus
``i``'s copy of each joint end), the joint ends ``a, b`` in ``i``'s frame [m], rest length
``L0`` [m], joint length ``w`` [m], ``K`` [Pa], reduced mass [kg], relative velocities at both
ends [m/s], thicknesses [m], Young's moduli [Pa], Poisson's ratio [1], time step [s]. The
evaluator may update its joint's history row ``hist`` and sets ``out[3] = 1`` when the joint
breaks (it then carries no force from that step on).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry.clip import make_overlap_scratch, overlap_scratch, project_partner
from .kernel_cache import specialise
from .geometry.quat import from_tangent, qrotate, qrotate_inv, to_tangent

# collision geometry layout
G_AREA, G_CX, G_CY, G_NX, G_NY, G_WIDTH, G_K, G_MEFF, G_VX, G_VY, G_AREA_I, G_AREA_J = range(12)
G_SIZE = 12
# joint geometry layout
(J_S1X, J_S1Y, J_S2X, J_S2Y, J_AX, J_AY, J_BX, J_BY, J_L0, J_W, J_K, J_MEFF, J_VAX, J_VAY,
 J_VBX, J_VBY, J_HI, J_HJ, J_EI, J_EJ, J_NU, J_DT) = range(22)
J_SIZE = 22


@njit(cache=True, inline="always")
def frame_point(qa, qb, x, y, R):
    """Point ``(x, y)`` [m] of ``qa``'s tangent plane, in ``qb``'s tangent plane [m]."""
    p = from_tangent(qa, x, y, R)
    return to_tangent(qb, p, R)


@njit(cache=True, inline="always")
def frame_vector(qa, qb, vx, vy):
    """Tangent vector of frame ``qa`` expressed in frame ``qb`` (radial part dropped)."""
    v = np.empty(3)
    v[0] = vx
    v[1] = vy
    v[2] = 0.0
    g = qrotate(qa, v)
    b = qrotate_inv(qb, g)
    return b[0], b[1]


@njit(cache=True, inline="always")
def apply_pair(q, i, j, fx, fy, px, py, couple, R, F, T):
    """Apply force ``(fx, fy)`` (``i``'s frame) and couple to ``j``, and the opposite to ``i``.

    The force acts at ``i``-frame point ``(px, py)`` mapped onto the sphere, ``X``; each element
    receives the torque about the planet centre ``R X × f + couple X`` (``j``) or its opposite
    (``i``), split into the model's generalised forces: with ``tau_b`` that torque in the body
    frame, ``Fx = tau_b,y / R``, ``Fy = -tau_b,x / R``, ``T = tau_b,z``.
    """
    X = from_tangent(q[i], px, py, R)
    f3 = np.empty(3)
    f3[0] = fx
    f3[1] = fy
    f3[2] = 0.0
    fg = qrotate(q[i], f3)
    tau = np.empty(3)
    tau[0] = R * (X[1] * fg[2] - X[2] * fg[1]) + couple * X[0]
    tau[1] = R * (X[2] * fg[0] - X[0] * fg[2]) + couple * X[1]
    tau[2] = R * (X[0] * fg[1] - X[1] * fg[0]) + couple * X[2]
    tj = qrotate_inv(q[j], tau)
    F[j, 0] += tj[1] / R
    F[j, 1] -= tj[0] / R
    T[j] += tj[2]
    ti = qrotate_inv(q[i], tau)
    F[i, 0] -= ti[1] / R
    F[i, 1] += ti[0] / R
    T[i] -= ti[2]


@njit(cache=True, inline="always")
def relative_velocity(q, V, w, i, j, px, py, R):
    """Velocity of ``j``'s material point at ``i``-frame ``(px, py)`` minus ``i``'s, in ``i``'s frame."""
    vix = V[i, 0] - w[i] * py
    viy = V[i, 1] + w[i] * px
    xj, yj = frame_point(q[i], q[j], px, py, R)
    vjx_l = V[j, 0] - w[j] * yj
    vjy_l = V[j, 1] + w[j] * xj
    vjx, vjy = frame_vector(q[j], q[i], vjx_l, vjy_l)
    return vjx - vix, vjy - viy


@njit(cache=True, inline="always")
def eq9_stiffness(hi, Ei, hj, Ej, ri, rj):
    """Effective stiffness of eq. 9, ``K = h1 E1 h2 E2 / (h1 E1 r2 + h2 E2 r1)`` [Pa]."""
    a = hi * Ei
    b = hj * Ej
    den = a * rj + b * ri
    if den <= 0.0:
        return 0.0
    return a * b / den


def joint_loop(evaluate, pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
               intact, hist, R, dt, commit, F, T):
    """Evaluate every intact joint; returns the number that broke (only when ``commit``)."""
    fn = specialise(_joint_loop, evaluate)
    if fn is not None:
        return fn(pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width, intact,
                  hist, R, dt, commit, F, T)
    return _joint_loop(evaluate, pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
                       intact, hist, R, dt, commit, F, T)


@njit
def _joint_loop(evaluate, pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
                intact, hist, R, dt, commit, F, T):
    g = np.empty(J_SIZE)
    out = np.zeros(4)
    scratch = np.empty(hist.shape[1])
    broken = 0
    for k in range(ji.shape[0]):
        if not intact[k]:
            continue
        i = ji[k]
        j = jj[k]
        ax, ay = ends_i[k, 0, 0], ends_i[k, 0, 1]
        bx, by = ends_i[k, 1, 0], ends_i[k, 1, 1]
        Ax, Ay = frame_point(q[j], q[i], ends_j[k, 0, 0], ends_j[k, 0, 1], R)
        Bx, By = frame_point(q[j], q[i], ends_j[k, 1, 0], ends_j[k, 1, 1], R)
        mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
        ri = math.hypot(mx, my)
        rj = math.hypot(0.5 * (ends_j[k, 0, 0] + ends_j[k, 1, 0]),
                        0.5 * (ends_j[k, 0, 1] + ends_j[k, 1, 1]))
        g[J_S1X] = Ax - ax
        g[J_S1Y] = Ay - ay
        g[J_S2X] = Bx - bx
        g[J_S2Y] = By - by
        g[J_AX] = ax
        g[J_AY] = ay
        g[J_BX] = bx
        g[J_BY] = by
        g[J_L0] = L0[k]
        g[J_W] = width[k]
        g[J_K] = eq9_stiffness(h[i], E[i], h[j], E[j], ri, rj)
        g[J_MEFF] = 1.0 / (minv[i] + minv[j])
        g[J_VAX], g[J_VAY] = relative_velocity(q, V, w, i, j, ax, ay, R)
        g[J_VBX], g[J_VBY] = relative_velocity(q, V, w, i, j, bx, by, R)
        g[J_HI] = h[i]
        g[J_HJ] = h[j]
        g[J_EI] = E[i]
        g[J_EJ] = E[j]
        g[J_NU] = nu[i]
        g[J_DT] = dt
        out[:] = 0.0
        if commit:
            evaluate(g, pars, hist[k], out)
        else:
            scratch[:] = hist[k]
            evaluate(g, pars, scratch, out)
        if out[3] != 0.0:
            if commit:
                intact[k] = False
                broken += 1
            continue
        apply_pair(q, i, j, out[0], out[1], mx, my, out[2], R, F, T)
    return broken


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


def collision_loop(evaluate, pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T):
    """Clip every candidate pair and apply the collision evaluator where they overlap.

    Returns the number of overlapping pairs.
    """
    nmax = int(np.max(np.diff(offsets))) if len(offsets) > 1 else 3
    fn = specialise(_collision_loop, evaluate)
    if fn is not None:
        return fn(pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T, nmax)
    return _collision_loop(evaluate, pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R,
                           F, T, nmax)


@njit
def _collision_loop(evaluate, pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T,
                    nmax):
    xy, tag = make_overlap_scratch(nmax, nmax)
    proj = np.empty((nmax, 2))
    g = np.empty(G_SIZE)
    out = np.zeros(4)
    n_overlap = 0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        pi = verts[offsets[i]:offsets[i + 1]]
        nj = offsets[j + 1] - offsets[j]
        pj = proj[:nj]
        project_partner(q[i], q[j], verts[offsets[j]:offsets[j + 1]], R, pj)
        a, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_scratch(pi, pj, xy, tag)
        if a <= 0.0:
            continue
        n_overlap += 1
        ri = math.hypot(cx, cy)
        xj, yj = frame_point(q[i], q[j], cx, cy, R)
        rj = math.hypot(xj, yj)
        if ncross == 2:
            width = math.hypot(p2x - p1x, p2y - p1y)
        else:
            width = _span_across(pi, pj, nx, ny)
            if not width > 0.0:
                width = math.sqrt(a)
        g[G_AREA] = a
        g[G_CX] = cx
        g[G_CY] = cy
        g[G_NX] = nx
        g[G_NY] = ny
        g[G_WIDTH] = width
        g[G_K] = eq9_stiffness(h[i], E[i], h[j], E[j], ri, rj)
        g[G_MEFF] = 1.0 / (minv[i] + minv[j])
        g[G_VX], g[G_VY] = relative_velocity(q, V, w, i, j, cx, cy, R)
        g[G_AREA_I] = area[i]
        g[G_AREA_J] = area[j]
        out[:] = 0.0
        evaluate(g, pars, out)
        apply_pair(q, i, j, out[0], out[1], cx, cy, out[2], R, F, T)
    return n_overlap


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
