"""The serial reference loops over contacts (the engine's previous implementation), kept for
the tests that compare the engine's parallel loops with them: each contact is evaluated with
quaternion rotations and added straight into ``F, T``, in the order the engine's gather sums
them.

The module is a template of :mod:`siku_core.contact.kernel_cache`, like
:mod:`siku_core.contact.contact_loops`:
its loops call the evaluator as the global ``evaluate`` of its binding, and :func:`joint_loop`
and :func:`collision_loop` run them in its instance for the evaluator they are given.
"""
import math
import sys

import numpy as np
from numba import njit

from siku_core.contact.contact_frames import overlap_width, eq9_stiffness, frame_point
from siku_core.contact_law import (
    G_AREA,
    G_AREA_I,
    G_AREA_J,
    G_HI,
    G_HJ,
    G_CX,
    G_CY,
    G_K,
    G_MEFF,
    G_NX,
    G_NY,
    G_DTM,
    G_SIZE,
    G_VX,
    G_VY,
    G_WIDTH,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_DT,
    J_DTM,
    J_EI,
    J_EJ,
    J_HI,
    J_HJ,
    J_K,
    J_L0,
    J_MEFF,
    J_NU,
    J_S1X,
    J_S1Y,
    J_S2X,
    J_S2Y,
    J_SIZE,
    J_VAX,
    J_VAY,
    J_VBX,
    J_VBY,
    J_W,
)
from siku_core.geometry.clip import (
    REL_TOL,
    _unit_or_x,
    apart,
    make_overlap_scratch,
    overlap_elements,
    project_partner,
)
from siku_core.geometry.face import touching_face
from siku_core.geometry.quat import from_tangent, qrotate, qrotate_inv
from siku_core.contact.kernel_cache import instantiate

# ------------------------------------------------------------------------------ the binding
evaluate = globals().get("evaluate")
NRT = globals().get("NRT", True)
CACHE = globals().get("CACHE", False)


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
    """Velocity of ``j``'s material point at ``i``-frame ``(px, py)`` minus ``i``'s, in
    ``i``'s frame."""
    vix = V[i, 0] - w[i] * py
    viy = V[i, 1] + w[i] * px
    xj, yj = frame_point(q[i], q[j], px, py, R)
    vjx_l = V[j, 0] - w[j] * yj
    vjy_l = V[j, 1] + w[j] * xj
    vjx, vjy = frame_vector(q[j], q[i], vjx_l, vjy_l)
    return vjx - vix, vjy - viy


def joint_loop(evaluate, pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
               intact, hist, R, dt, commit, F, T):
    """Evaluate every intact joint; returns the number that broke (only when ``commit``)."""
    loops = instantiate(sys.modules[__name__], evaluate)
    return loops._joint_loop(pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
                             intact, hist, R, dt, commit, F, T)


@njit(cache=CACHE)
def _joint_loop(pars, q, V, w, minv, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
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
        g[J_DTM] = 0.0  # the dampers as written (the engine's bound cuts none in these cases)
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


def collision_loop(evaluate, pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T,
                   face=None, scale=None):
    """Clip every candidate pair that :func:`~siku_core.geometry.clip.apart` does not find apart
    and apply the collision evaluator where they overlap (``face``, ``scale``: as
    :func:`collision_forces` takes them).

    Returns the number of overlapping pairs.
    """
    nmax = int(np.max(np.diff(offsets))) if len(offsets) > 1 else 3
    if face is None:
        face = np.full((pairs.shape[0], 2), -1, dtype=np.int16)
    if scale is None:
        scale = np.zeros(offsets.shape[0] - 1)
    loops = instantiate(sys.modules[__name__], evaluate)
    return loops._collision_loop(pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T,
                                 nmax, face, scale)


@njit(cache=CACHE)
def _collision_loop(pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T,
                    nmax, face, scale):
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
        c2x, c2y = frame_point(q[j], q[i], 0.0, 0.0, R)
        a = -1.0
        fi = face[k, 0]
        if fi >= 0:  # jointed: a touching face from the joint's edges (geometry.face)
            fj = face[k, 1]
            fj1 = fj + 1 if fj + 1 < nj else 0
            a, cx, cy, width = touching_face(pi, fi, pj[fj, 0], pj[fj, 1], pj[fj1, 0],
                                             pj[fj1, 1], scale[i])
            if a == 0.0:
                continue
            nx, ny = _unit_or_x(c2x, c2y, REL_TOL * scale[i])
        if a < 0.0:
            if apart(pi, pj):
                continue
            a, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_elements(pi, pj, xy, tag,
                                                                             c2x, c2y)
            if a <= 0.0:
                continue
            width = overlap_width(pi, pj, a, ncross, p1x, p1y, p2x, p2y, nx, ny)
        n_overlap += 1
        ri = math.sqrt(cx * cx + cy * cy)
        xj, yj = frame_point(q[i], q[j], cx, cy, R)
        rj = math.sqrt(xj * xj + yj * yj)
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
        g[G_HI] = h[i]
        g[G_HJ] = h[j]
        g[G_DTM] = 0.0
        out[:] = 0.0
        evaluate(g, pars, out)
        apply_pair(q, i, j, out[0], out[1], cx, cy, out[2], R, F, T)
    return n_overlap
