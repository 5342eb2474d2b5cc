"""Contacts: frozen joints, collision candidates, and the engine's loops over them.

docs/explanation/physics.md section 4. The engine owns the loops; a contact law supplies small ``@njit``
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
evaluator may update its joint's history row ``hist`` and sets ``out[3]`` to a break mode
(``BREAK_*``) when the joint breaks (it then carries no force from that step on). The layouts
with units are :data:`COLLISION_LAYOUT`, :data:`JOINT_LAYOUT` and :data:`OUT_LAYOUT` (tables in
``docs/howto/contact_laws.md``); ``out`` is zeroed before every call.

The engine's loops (the "fast path" below: ``joint_forces``, ``collision_forces``,
``gather_forces``) run in parallel over contacts and elements and give the same result on any
number of threads; ``joint_loop`` and ``collision_loop`` are the serial reference loops (the
previous implementation, kept for tests), which add each contact straight into ``F, T``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .geometry.clip import (
    REL_TOL,
    _unit_or_x,
    apart,
    make_overlap_scratch,
    overlap_elements,
    overlap_inline,
    project_partner,
    separating_edge,
)
from .geometry.face import edge_table, touching_face, touching_face_u
from .geometry.quat import from_tangent, qrotate, qrotate_inv, to_tangent
from .kernel_cache import specialise
from .parallel import chunk_bounds, claim, tasks

# collision geometry layout
G_AREA, G_CX, G_CY, G_NX, G_NY, G_WIDTH, G_K, G_MEFF, G_VX, G_VY, G_AREA_I, G_AREA_J = range(12)
G_SIZE = 12

#: overlapping pairs per block of the collision loop (its geometry first, then the evaluations:
#: ``_collision_block``); a block's row: the pair, the overlap (area, point, normal, width) and
#: the relative rotation ``M`` of :func:`relative_matrix`
CBLOCK = 32
B_K, B_AREA, B_CX, B_CY, B_NX, B_NY, B_WIDTH, B_M = range(8)
B_SIZE = B_M + 9
# joint geometry layout
(J_S1X, J_S1Y, J_S2X, J_S2Y, J_AX, J_AY, J_BX, J_BY, J_L0, J_W, J_K, J_MEFF, J_VAX, J_VAY,
 J_VBX, J_VBY, J_HI, J_HJ, J_EI, J_EJ, J_NU, J_DT) = range(22)
J_SIZE = 22

#: the collision geometry vector ``g``: ``(index constant, unit, meaning)`` per entry, in order
#: (rendered for the docs by :func:`layout_table`)
COLLISION_LAYOUT = (
    ("G_AREA", "m²", "overlap area `A`"),
    ("G_CX", "m", "overlap centroid, x (where the force acts)"),
    ("G_CY", "m", "overlap centroid, y"),
    ("G_NX", "1", "unit normal from `i` towards `j`, x"),
    ("G_NY", "1", "unit normal from `i` towards `j`, y"),
    ("G_WIDTH", "m", "contact width: `|P1P2|` when the boundaries cross twice, else the common "
                     "span of both polygons across the normal"),
    ("G_K", "Pa", "effective stiffness `K` of eq. 9 (0 for coincident centres)"),
    ("G_MEFF", "kg", "reduced mass `1/(1/m_i + 1/m_j)` (a static or steady element counts as "
                     "infinitely heavy)"),
    ("G_VX", "m/s", "velocity of `j` relative to `i` at the centroid, x"),
    ("G_VY", "m/s", "velocity of `j` relative to `i` at the centroid, y"),
    ("G_AREA_I", "m²", "area of `i`"),
    ("G_AREA_J", "m²", "area of `j`"),
)
#: the joint geometry vector ``g``: ``(index constant, unit, meaning)`` per entry, in order
JOINT_LAYOUT = (
    ("J_S1X", "m", "displacement of the joint's first end, `s1` (`j`'s copy minus `i`'s), x"),
    ("J_S1Y", "m", "`s1`, y"),
    ("J_S2X", "m", "displacement of the second end, `s2`, x"),
    ("J_S2Y", "m", "`s2`, y"),
    ("J_AX", "m", "first end `a` of `i`'s copy of the joint, x"),
    ("J_AY", "m", "`a`, y"),
    ("J_BX", "m", "second end `b`, x (`a → b` runs counter-clockwise round `i`)"),
    ("J_BY", "m", "`b`, y"),
    ("J_L0", "m", "rest distance of the two centres (great circle)"),
    ("J_W", "m", "joint length `w = |b - a|` (0 for coincident ends)"),
    ("J_K", "Pa", "effective stiffness `K` of eq. 9: traction per unit length and displacement"),
    ("J_MEFF", "kg", "reduced mass"),
    ("J_VAX", "m/s", "velocity of `j` relative to `i` at end `a`, x"),
    ("J_VAY", "m/s", "same, y"),
    ("J_VBX", "m/s", "velocity of `j` relative to `i` at end `b`, x"),
    ("J_VBY", "m/s", "same, y"),
    ("J_HI", "m", "thickness of `i`"),
    ("J_HJ", "m", "thickness of `j`"),
    ("J_EI", "Pa", "Young's modulus of `i`"),
    ("J_EJ", "Pa", "Young's modulus of `j`"),
    ("J_NU", "1", "Poisson's ratio (of `i`'s material)"),
    ("J_DT", "s", "time step"),
)
#: what an evaluator writes to ``out`` (zeroed by the engine before every call)
OUT_LAYOUT = (
    ("out[0]", "N", "force on `j`, x (`i`'s frame); `i` gets the opposite"),
    ("out[1]", "N", "force on `j`, y"),
    ("out[2]", "N m", "couple on `j` about the local vertical, counter-clockwise positive; `i` "
                      "gets the opposite"),
    ("out[3]", "1", "joint evaluators: 0 while the joint holds, else its break mode "
                    "(`BREAK_*`); the joint then carries no force from this step on"),
)


def layout_table(layout: tuple) -> str:
    """A layout as a Markdown table: index, name, unit, meaning."""
    if all(name.startswith("out[") for name, _, _ in layout):
        rows = ["| entry | unit | meaning |", "|---|---|---|"]
        rows += [f"| `{name}` | {unit} | {meaning} |" for name, unit, meaning in layout]
    else:
        rows = ["| index | name | unit | meaning |", "|---|---|---|---|"]
        rows += [f"| {k} | `{name}` | {unit} | {meaning} |"
                 for k, (name, unit, meaning) in enumerate(layout)]
    return "\n".join(rows)


# break modes: what a joint evaluator writes to ``out[3]`` when its joint breaks (any non-zero
# value breaks it; the engine records the value with the break, see ``BREAK_MODES``)
BREAK_STRAIN = 1.0  #: a strain or displacement threshold without a direction (the spring law)
BREAK_TENSION = 2.0  #: normal (opening) stress above the tensile strength
BREAK_SHEAR = 3.0  #: shear stress above the shear strength
BREAK_COMPRESSION = 4.0  #: normal (closing) stress above the compressive strength
BREAK_EXTERNAL = 5.0  #: broken by a component outside the law, without a more precise mode
BREAK_FLEXURE = 6.0  #: flexural (bending) strain above the critical strain (wave-induced)
#: names of the break modes by code (code 0: intact), as written in output files
BREAK_MODES = {0: "intact", 1: "strain", 2: "tension", 3: "shear", 4: "compression",
               5: "external", 6: "flexure"}


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


@njit(cache=True, inline="always")
def _width(pi, pj, a, ncross, p1x, p1y, p2x, p2y, nx, ny):
    """Contact width of a clipped overlap [m]: the chord between the two boundary crossings,
    else the common span across the normal (``_span_across``), else ``sqrt(area)``."""
    if ncross == 2:
        return math.sqrt((p2x - p1x) ** 2 + (p2y - p1y) ** 2)
    width = _span_across(pi, pj, nx, ny)
    if not width > 0.0:
        width = math.sqrt(a)
    return width


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
    fn = specialise(_collision_loop, evaluate)
    if fn is not None:
        return fn(pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T, nmax, face,
                  scale)
    return _collision_loop(evaluate, pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R,
                           F, T, nmax, face, scale)


@njit
def _collision_loop(evaluate, pars, q, V, w, minv, h, E, area, offsets, verts, pairs, R, F, T,
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
            width = _width(pi, pj, a, ncross, p1x, p1y, p2x, p2y, nx, ny)
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


# ====================================================================== the engine's fast path
#
# One force evaluation of the contact phase (``ContactModel.add``) runs, all compiled:
#
# 1. ``rotation_matrices``: ``R(q)`` of every element, once (the loops below never rotate by a
#    quaternion and never allocate per contact);
# 2. ``_joint_forces``: every intact joint (parallel over joints);
# 3. ``_collision_forces``: every candidate pair: a jointed pair first along its joint (a
#    touching face or a gap found from the joint's edges, ``geometry.face``), then the
#    separating-axis test (``separating_edge``:
#    an edge line of either polygon separates or touches them, the edge that did so last time
#    tried first; with ``contact.touching = "ignore"`` within a margin that settles overlaps the
#    clip would call touching), else the clip and, when the polygons overlap, the law (parallel
#    over pairs). Pairs that overlapped at the last evaluation go straight to the clip;
# 4. ``gather_forces``: each element adds its own contacts' contributions, joints then pairs,
#    each in ascending contact index (parallel over elements).
#
# The chunk functions that run steps 2–3 allocate nothing (each task's buffers come from the
# parallel loop). Their specialised copies (:func:`~siku_core.kernel_cache.specialise`) are
# compiled without numba's reference counting (``_nrt=False``) together with the law's
# evaluator, where the evaluator allows it (it allocates nothing either): with it, every array
# view and every call that passes an array costs a pair of atomic increments and decrements,
# which numba's pruning leaves in loops with branches like these (about half of the joint
# loop's time and a third of the collision loop's, measured on the 10 000-element pack). An
# evaluator that allocates keeps reference counting, in its loop too, and works unchanged.
#
# Steps 2–3 write one row of six numbers per contact (the generalised force and torque on ``i``
# and on ``j``, ``C_*``) and a flag saying whether the contact carries force; no two tasks write
# the same place, so there are no races, and step 4 sums every element's contributions in the
# same order whatever the number of threads: results are bit-identical for any thread count,
# and equal (to round-off in the rotations) to the serial reference loops above, which add
# contacts to ``F, T`` in exactly that order.
#
# Relative frames: with ``Ri = R(q_i)`` the matrix ``M = Ri^T Rj`` maps directions of ``j``'s
# local frame to ``i``'s, so a point ``(x, y)`` of ``j``'s tangent plane is ``g_xy (R / g_z)``
# with ``g = M (x/R, y/R, 1)`` in ``i``'s plane (the gnomonic normalisation cancels), and
# ``M^T`` goes back. ``M`` and the projection are computed exactly as ``project_partner``
# does, so the narrow phase sees the same partner vertices as the reference loops, bit for bit.

#: per-contact contribution layout: generalised force and torque on ``i``, then on ``j``, then
#: the contact point in ``i``'s frame [m] (what the element stress of ``siku_core.stress`` needs)
C_FIX, C_FIY, C_TI, C_FJX, C_FJY, C_TJ, C_PX, C_PY = range(8)
C_SIZE = 8


@njit(cache=True, inline="always")
def _rotation_row(q, rm, i):
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
            _rotation_row(q, rm, i)


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
            cx, cy, cz = _rotation_row(q, rm, i)
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
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = M
    vix = V[i, 0] - w[i] * py
    viy = V[i, 1] + w[i] * px
    vjx_l = V[j, 0] - w[j] * yj
    vjy_l = V[j, 1] + w[j] * xj
    return (m00 * vjx_l + m01 * vjy_l) - vix, (m10 * vjx_l + m11 * vjy_l) - viy


@njit(cache=True)
def pair_contribution(M, fx, fy, px, py, couple, inv_r, R, out, k):
    """Row ``out[k]`` (``C_*``): force ``(fx, fy)`` (``i``'s frame) and ``couple`` on ``j`` at
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
    out[k, C_FIX] = -s1
    out[k, C_FIY] = s0
    out[k, C_TI] = -R * s2
    t0 = m00 * s0 + m10 * s1 + m20 * s2
    t1 = m01 * s0 + m11 * s1 + m21 * s2
    t2 = m02 * s0 + m12 * s1 + m22 * s2
    out[k, C_FJX] = t1
    out[k, C_FJY] = -t0
    out[k, C_TJ] = R * t2
    out[k, C_PX] = px
    out[k, C_PY] = py


@njit(cache=True)
def joint_constants(h, E, minv, ji, jj, ends_i, ends_j):
    """Per joint: eq. 9 stiffness ``K`` [Pa] (lever arms: the joint midpoint in both frames)
    and reduced mass [kg], which never change during a run."""
    nj = ji.shape[0]
    K = np.empty(nj)
    meff = np.empty(nj)
    for k in range(nj):
        i = ji[k]
        j = jj[k]
        mx = 0.5 * (ends_i[k, 0, 0] + ends_i[k, 1, 0])
        my = 0.5 * (ends_i[k, 0, 1] + ends_i[k, 1, 1])
        ri = math.hypot(mx, my)
        rj = math.hypot(0.5 * (ends_j[k, 0, 0] + ends_j[k, 1, 0]),
                        0.5 * (ends_j[k, 0, 1] + ends_j[k, 1, 1]))
        K[k] = eq9_stiffness(h[i], E[i], h[j], E[j], ri, rj)
        meff[k] = 1.0 / (minv[i] + minv[j])
    return K, meff


def joint_forces(evaluate, pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width, jK,
                 jmeff, intact, bmode, hist, R, dt, commit, out, on, nch):
    """Evaluate every intact joint into ``out[k]`` (``C_*``) and ``on[k]``; returns the number
    that broke (only when ``commit``; their break mode, the evaluator's ``out[3]``, goes to
    ``bmode[k]``)."""
    fn = specialise(_joint_forces, evaluate, JOINT_HELPERS)
    nt = tasks(nch)
    if fn is not None:
        return fn(pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width, jK, jmeff,
                  intact, bmode, hist, R, dt, commit, out, on, nch, nt)
    return _joint_forces(evaluate, pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width,
                         jK, jmeff, intact, bmode, hist, R, dt, commit, out, on, nch, nt)


# The parallel loops are thin: each task calls a (serially compiled) chunk function. Numba's
# parallel compilation of a large loop body takes twice as long as compiling it serially.
@njit(parallel=True)
def _joint_forces(evaluate, pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width, jK,
                  jmeff, intact, bmode, hist, R, dt, commit, out, on, nch, nt):
    counts = np.zeros(nch, dtype=np.int64)
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        g = np.empty(J_SIZE)
        res = np.empty(4)
        scratch = np.empty(hist.shape[1])
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, ji.shape[0])
            counts[c] = _joint_chunk(evaluate, pars, rm, V, w, h, E, nu, ji, jj, ends_i,
                                     ends_j, L0, width, jK, jmeff, intact, bmode, hist, R, dt,
                                     commit, out, on, lo, hi, g, res, scratch)
    return counts.sum()


@njit
def _joint_chunk(evaluate, pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width, jK,
                 jmeff, intact, bmode, hist, R, dt, commit, out, on, lo, hi, g, res, scratch):
    """Joints ``lo <= k < hi`` of :func:`joint_forces`; returns how many broke. ``g``,
    ``res``, ``scratch``: the task's buffers (geometry, result, history row)."""
    nh = hist.shape[1]
    inv_r = 1.0 / R
    nb = 0
    for k in range(lo, hi):
        on[k] = 0
        if not intact[k]:
            continue
        i = ji[k]
        j = jj[k]
        M = relative_matrix(rm, i, j)
        ax, ay = ends_i[k, 0, 0], ends_i[k, 0, 1]
        bx, by = ends_i[k, 1, 0], ends_i[k, 1, 1]
        Ax, Ay = j_to_i(M, ends_j[k, 0, 0], ends_j[k, 0, 1], R, inv_r)
        Bx, By = j_to_i(M, ends_j[k, 1, 0], ends_j[k, 1, 1], R, inv_r)
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
        g[J_K] = jK[k]
        g[J_MEFF] = jmeff[k]
        # the material points at the ends: i's copy at a (b), j's copy at A (B)
        xa, ya = i_to_j(M, ax, ay, R, inv_r)
        xb, yb = i_to_j(M, bx, by, R, inv_r)
        g[J_VAX], g[J_VAY] = relative_velocity_m(M, V, w, i, j, ax, ay, xa, ya)
        g[J_VBX], g[J_VBY] = relative_velocity_m(M, V, w, i, j, bx, by, xb, yb)
        g[J_HI] = h[i]
        g[J_HJ] = h[j]
        g[J_EI] = E[i]
        g[J_EJ] = E[j]
        g[J_NU] = nu[i]
        g[J_DT] = dt
        res[0] = 0.0
        res[1] = 0.0
        res[2] = 0.0
        res[3] = 0.0
        for a in range(nh):
            scratch[a] = hist[k, a]
        evaluate(g, pars, scratch, res)
        if commit:
            for a in range(nh):
                hist[k, a] = scratch[a]
        if res[3] != 0.0:
            if commit:
                intact[k] = False
                bmode[k] = res[3]
                nb += 1
            continue
        pair_contribution(M, res[0], res[1], 0.5 * (ax + bx), 0.5 * (ay + by), res[2], inv_r,
                          R, out, k)
        on[k] = 1
    return nb


def pair_masses(minv, pairs):
    """Reduced mass ``1 / (1/m_i + 1/m_j)`` [kg] of every pair ``(i, j)`` of ``pairs``, from the
    elements' inverse masses ``minv`` [1/kg] (zero for a static or steady element): a constant
    of the candidate list, as :func:`joint_constants` is of the joints (the same division, so
    the same value bit for bit as computed per contact)."""
    with np.errstate(divide="ignore"):  # two held elements are never candidates
        return 1.0 / (minv[pairs[:, 0]] + minv[pairs[:, 1]])


def collision_forces(evaluate, pars, rm, V, w, meff, h, E, area, offsets, verts, pairs, R,
                     nmax, pretest, out, on, nch, margin=None, hint=None, drop=False, face=None,
                     scale=None, edges=None):
    """Clip every candidate pair (unless, with ``pretest``, the separating-axis test
    :func:`~siku_core.geometry.clip.separating_edge` finds an edge line that separates or touches
    them) and evaluate the overlapping ones into ``out[k]`` with ``on[k] = 1`` (``0`` for the
    others, ``2`` for a touching overlap dropped under ``drop``: no force either); returns the
    number of overlapping pairs. A pair with ``on[k] = 1`` or ``2`` from the last evaluation
    skips the test (it almost always still overlaps or touches; the clip finds no area where
    the test would have found the pair apart, and no more than the touching area where the
    test with the margin would have).

    ``meff`` (per pair, kg): the pair's reduced mass (:func:`pair_masses`); ``margin`` (per
    element ``i``, m; zeros by default): the test's margin; ``hint`` (per pair, int16,
    updated): the edge that separated the pair last, tried first; ``drop``: touching
    overlaps (area at most the clip's tolerance) carry no force (``contact.touching =
    "ignore"``, with ``margin = REL_TOL L_i / 3``, so that the test settles such pairs);
    ``face`` (per pair, int16 ``(K, 2)``, ``-1`` for none): the edges of ``i`` and ``j`` the
    pair is jointed along, whose touching overlap :func:`~siku_core.geometry.face.touching_face`
    finds without the clip; ``scale`` (per element, m): its largest absolute vertex coordinate;
    ``edges`` (per vertex row): :func:`~siku_core.geometry.face.edge_table` of ``offsets,
    verts``, the constants of the edge a jointed pair touches along (built here when not given).
    """
    if margin is None:
        margin = np.zeros(offsets.shape[0] - 1)
    if hint is None:
        hint = np.zeros(pairs.shape[0], dtype=np.int16)
    if face is None:
        face = np.full((pairs.shape[0], 2), -1, dtype=np.int16)
    if scale is None:
        scale = np.zeros(offsets.shape[0] - 1)
    if edges is None:
        edges = edge_table(offsets, verts)
    fn = specialise(_collision_forces, evaluate, COLLISION_HELPERS)
    nt = tasks(nch)
    if fn is not None:
        return fn(pars, rm, V, w, meff, h, E, area, offsets, verts, pairs, R, nmax,
                  pretest, out, on, nch, nt, margin, hint, drop, face, scale, edges)
    return _collision_forces(evaluate, pars, rm, V, w, meff, h, E, area, offsets, verts,
                             pairs, R, nmax, pretest, out, on, nch, nt, margin, hint, drop, face,
                             scale, edges)


@njit(parallel=True)
def _collision_forces(evaluate, pars, rm, V, w, meff, h, E, area, offsets, verts, pairs, R,
                      nmax, pretest, out, on, nch, nt, margin, hint, drop, face, scale, edges):
    counts = np.zeros(nch, dtype=np.int64)
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        xy, tag = make_overlap_scratch(nmax, nmax)
        proj = np.empty((nmax, 2))
        g = np.empty(G_SIZE)
        res = np.empty(4)
        blk = np.empty(CBLOCK * B_SIZE)
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, pairs.shape[0])
            counts[c] = _collision_chunk(evaluate, pars, rm, V, w, meff, h, E, area, offsets,
                                         verts, pairs, R, pretest, out, on, lo, hi, xy, tag,
                                         proj, g, res, margin, hint, drop, face, scale, blk,
                                         edges)
    return counts.sum()


@njit
def _collision_block(evaluate, pars, V, w, meff, h, E, area, pairs, R, out, on, g, res, blk, nb):
    """Evaluate the ``nb`` overlapping pairs of one block of :func:`_collision_chunk` (rows of
    ``blk``, ``B_*``) into ``out`` and ``on``. Apart from the geometry that finds them, a
    contact's evaluation is a chain of dependent square roots and divisions (lever arms,
    stiffness, damping); evaluated in a loop of their own, the chains of consecutive contacts
    overlap in the processor instead of waiting for the next pair's clip."""
    inv_r = 1.0 / R
    for n in range(nb):
        b = n * B_SIZE
        k = int(blk[b + B_K])
        a = blk[b + B_AREA]
        cx = blk[b + B_CX]
        cy = blk[b + B_CY]
        M = (blk[b + B_M], blk[b + B_M + 1], blk[b + B_M + 2], blk[b + B_M + 3],
             blk[b + B_M + 4], blk[b + B_M + 5], blk[b + B_M + 6], blk[b + B_M + 7],
             blk[b + B_M + 8])
        i = pairs[k, 0]
        j = pairs[k, 1]
        ri = math.sqrt(cx * cx + cy * cy)
        xj, yj = i_to_j(M, cx, cy, R, inv_r)
        rj = math.sqrt(xj * xj + yj * yj)
        g[G_AREA] = a
        g[G_CX] = cx
        g[G_CY] = cy
        g[G_NX] = blk[b + B_NX]
        g[G_NY] = blk[b + B_NY]
        g[G_WIDTH] = blk[b + B_WIDTH]
        g[G_K] = eq9_stiffness(h[i], E[i], h[j], E[j], ri, rj)
        g[G_MEFF] = meff[k]
        g[G_VX], g[G_VY] = relative_velocity_m(M, V, w, i, j, cx, cy, xj, yj)
        g[G_AREA_I] = area[i]
        g[G_AREA_J] = area[j]
        res[0] = 0.0
        res[1] = 0.0
        res[2] = 0.0
        res[3] = 0.0
        evaluate(g, pars, res)
        pair_contribution(M, res[0], res[1], cx, cy, res[2], inv_r, R, out, k)
        on[k] = 1


@njit
def _collision_chunk(evaluate, pars, rm, V, w, meff, h, E, area, offsets, verts, pairs, R,
                     pretest, out, on, lo, hi, xy, tag, proj, g, res, margin, hint, drop, face,
                     scale, blk, edges):
    """Pairs ``lo <= k < hi`` of :func:`collision_forces`; returns how many overlap. ``xy``,
    ``tag``, ``proj``, ``g``, ``res``, ``blk``: the task's buffers (clipping, partner vertices,
    geometry, result, a block of overlaps waiting for :func:`_collision_block`)."""
    inv_r = 1.0 / R
    no = 0
    nb = 0
    for k in range(lo, hi):
        # a pair that overlapped at the last evaluation almost always still does, and one the
        # clip found touching (``on = 2``, ``drop`` only) mostly still touches: straight to the
        # clip (which finds no area for any pair ``apart`` would have settled, and at most the
        # touching area for any the test with the margin would have settled)
        test = pretest and on[k] == 0
        on[k] = 0
        i = pairs[k, 0]
        j = pairs[k, 1]
        M = relative_matrix(rm, i, j)
        oj = offsets[j]
        nj = offsets[j + 1] - oj
        pi = verts[offsets[i]:offsets[i + 1]]
        a = -1.0
        fi = face[k, 0]
        fj = fj1 = -1
        if fi >= 0:
            # jointed: the ends of j's edge of the joint first; a touching face (the rule for
            # jointed neighbours) needs nothing else (geometry.face)
            fj = face[k, 1]
            fj1 = fj + 1 if fj + 1 < nj else 0
            bx, by = j_to_i(M, verts[oj + fj, 0], verts[oj + fj, 1], R, inv_r)
            ex, ey = j_to_i(M, verts[oj + fj1, 0], verts[oj + fj1, 1], R, inv_r)
            eu = offsets[i] + fi
            a, cx, cy, width = touching_face_u(pi, fi, bx, by, ex, ey, scale[i], edges[eu, 0],
                                               edges[eu, 1], edges[eu, 2])
            if a == 0.0:
                continue  # the faces touch nowhere
            if a > 0.0:
                if drop:
                    on[k] = 2  # touching, dropped: no force
                    continue
                nx, ny = centre_normal(M, R, REL_TOL * scale[i])
            else:
                proj[fj, 0] = bx
                proj[fj, 1] = by
                proj[fj1, 0] = ex
                proj[fj1, 1] = ey
        if a < 0.0:
            for v in range(nj):
                if v != fj and v != fj1:
                    px, py = j_to_i(M, verts[oj + v, 0], verts[oj + v, 1], R, inv_r)
                    proj[v, 0] = px
                    proj[v, 1] = py
            pj = proj[:nj]
            if test:
                e = separating_edge(pi, pj, margin[i], hint[k])
                if e >= 0:
                    hint[k] = e
                    continue
            c2x, c2y = j_to_i(M, 0.0, 0.0, R, inv_r)
            a, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_inline(pi, pj, xy, tag, c2x,
                                                                           c2y, drop)
            if a <= 0.0:
                if ncross < 0:
                    on[k] = 2  # touching, dropped: no force; no separating-axis test next time
                continue
            width = _width(pi, pj, a, ncross, p1x, p1y, p2x, p2y, nx, ny)
        # the contact's evaluation waits for the block (_collision_block)
        b = nb * B_SIZE
        blk[b + B_K] = k
        blk[b + B_AREA] = a
        blk[b + B_CX] = cx
        blk[b + B_CY] = cy
        blk[b + B_NX] = nx
        blk[b + B_NY] = ny
        blk[b + B_WIDTH] = width
        for m in range(9):
            blk[b + B_M + m] = M[m]
        nb += 1
        if nb == CBLOCK:
            _collision_block(evaluate, pars, V, w, meff, h, E, area, pairs, R, out, on, g, res,
                             blk, nb)
            no += nb
            nb = 0
    if nb:
        _collision_block(evaluate, pars, V, w, meff, h, E, area, pairs, R, out, on, g, res, blk,
                         nb)
        no += nb
    return no


#: the functions the parallel loops call with the evaluator (``kernel_cache.specialise``)
JOINT_HELPERS = (_joint_chunk,)
COLLISION_HELPERS = (_collision_block, _collision_chunk)


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


def gather_forces(F, T, joff, jidx, jside, jout, jon, poff, pidx, pside, pout, pon, nch):
    """Add to ``F[e], T[e]`` the contributions of element ``e``'s joints, then of its pairs,
    each in ascending contact index (fixed order: independent of the thread count)."""
    _gather_forces(F, T, joff, jidx, jside, jout, jon, poff, pidx, pside, pout, pon, nch,
                   tasks(nch))


@njit(cache=True, parallel=True)
def _gather_forces(F, T, joff, jidx, jside, jout, jon, poff, pidx, pside, pout, pon, nch, nt):
    n = F.shape[0]
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, n)
            _gather_chunk(F, T, joff, jidx, jside, jout, jon, poff, pidx, pside, pout, pon, lo,
                          hi)


@njit(cache=True)
def _gather_chunk(F, T, joff, jidx, jside, jout, jon, poff, pidx, pside, pout, pon, lo, hi):
    """Elements ``lo <= e < hi`` of :func:`gather_forces`."""
    for e in range(lo, hi):
        fx = F[e, 0]
        fy = F[e, 1]
        t = T[e]
        for a in range(joff[e], joff[e + 1]):
            k = jidx[a]
            if jon[k]:
                s = 3 * jside[a]
                fx += jout[k, s]
                fy += jout[k, s + 1]
                t += jout[k, s + 2]
        for a in range(poff[e], poff[e + 1]):
            k = pidx[a]
            if pon[k] == 1:
                s = 3 * pside[a]
                fx += pout[k, s]
                fy += pout[k, s + 1]
                t += pout[k, s + 2]
        F[e, 0] = fx
        F[e, 1] = fy
        T[e] = t
