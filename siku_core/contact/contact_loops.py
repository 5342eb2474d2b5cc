"""The engine's contact loops over joints and over candidate pairs: the template that
:func:`siku_core.contact.kernel_cache.instantiate` makes one module of per contact law.

docs/explanation/physics.md section 4; the entry points, and the meaning of every argument, are
:func:`siku_core.contact.contact_forces.joint_forces` and
:func:`siku_core.contact.contact_forces.collision_forces`.

This source is a template, not a module to call: the loops call the law's evaluator of one
contact as the module global ``evaluate`` and take their compilation options from ``NRT``,
``CACHE`` and ``CHIST``, the four names of the binding below. An instance is this source run
as a new module with those names bound first: a generated file (a header rendered from
``kernel_cache.HEADER``, then this source verbatim) that numba caches like any other module,
or, where no such file can serve, this file run with the names preset (nothing cached). Hence
its rules: absolute imports only, no ``from __future__`` import, and no name of the binding
assigned anywhere else. Imported as ``siku_core.contact.contact_loops`` it compiles nothing.
"""
import math

import numpy as np
from numba import njit, prange

from siku_core.contact.contact_frames import (
    overlap_width, centre_normal, eq9_stiffness, i_to_j, j_to_i, pair_contribution,
    relative_matrix, relative_velocity_m,
)
from siku_core.contact.contact_tables import ContactElements, JointTable, PairTable
from siku_core.contact.damping import damping_mobility
from siku_core.contact_law import (
    G_AREA,
    G_AREA_I,
    G_AREA_J,
    G_HI,
    G_HJ,
    G_CX,
    G_CY,
    G_DTM,
    G_K,
    G_MEFF,
    G_NX,
    G_NY,
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
from siku_core.geometry.clip import REL_TOL, make_overlap_scratch, overlap_inline, separating_edge
from siku_core.geometry.coherent import overlap_coherent
from siku_core.geometry.face import touching_face_u
from siku_core.contact.ice_follow import joints_from
from siku_core.parallel import chunk_bounds, claim

# ------------------------------------------------------------------------------ the binding
#: the law's evaluator of one contact (``siku_core.contact_law``), called by the chunks
evaluate = globals().get("evaluate")
#: whether the chunks keep numba's reference counting (``False`` where the evaluator can be
#: compiled without it: ``kernel_cache.without_nrt``)
NRT = globals().get("NRT", True)
#: whether numba caches the compiled loops (an instance in a generated file)
CACHE = globals().get("CACHE", False)
#: whether the collision evaluator takes a per-contact history row (``evaluate(g, pars, hist,
#: out)``, a law with ``contact_history_names``); a compile-time constant: without it the
#: branches that pass the row are pruned and the collision loop is the one without history
CHIST = globals().get("CHIST", False)

#: overlapping pairs per block of the collision loop (its geometry first, then the evaluations:
#: ``_collision_block``); a block's row (``BLK_*``): the pair, the overlap (area, point,
#: normal, width) and the relative rotation ``M`` of ``relative_matrix`` (nine entries)
CBLOCK = 32
BLK_K, BLK_AREA, BLK_CX, BLK_CY, BLK_NX, BLK_NY, BLK_WIDTH, BLK_M = range(8)
BLK_SIZE = BLK_M + 9


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
# parallel loop). In a law's instance of this template (``kernel_cache.instantiate``) they are
# compiled without numba's reference counting (``NRT = False``) together with the law's
# evaluator (``kernel_cache.without_nrt``), where the evaluator allows it (it allocates nothing
# either): with it, every array view and every call that passes an array costs a pair of
# atomic increments and decrements, which numba's pruning leaves in loops with branches like
# these (about half of the joint loop's time and a third of the collision loop's, measured on
# the 10 000-element pack). An evaluator that allocates keeps reference counting, in its loop
# too, and works unchanged.
#
# Steps 2–3 write one row of six numbers per contact (the generalised force and torque on ``i``
# and on ``j``, ``ROW_*``) and a flag saying whether the contact carries force; no two tasks write
# the same place, so there are no races, and step 4 sums every element's contributions in the
# same order whatever the number of threads: results are bit-identical for any thread count,
# and equal (to round-off in the rotations) to the serial reference loops of the tests
# (``tests/contacts/reference_loops.py``), which add contacts to ``F, T`` in exactly that order.


# The parallel loops are thin: each task calls a (serially compiled) chunk function. Numba's
# parallel compilation of a large loop body takes twice as long as compiling it serially.
@njit(parallel=True, cache=CACHE)
def _joint_forces(pars, el_t, jt_t, R, dt, commit, nch, nt):
    # the records arrive as plain tuples (numba types those in C: records.py, "At the
    # boundary") and are named again here, at no cost
    el = ContactElements(*el_t)
    jt = JointTable(*jt_t)
    counts = np.zeros(nch, dtype=np.int64)
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        g = np.empty(J_SIZE)
        res = np.empty(4)
        scratch = np.empty(jt.hist.shape[1])
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, jt.ji.shape[0])
            counts[c] = _joint_chunk(pars, el, jt, R, dt, commit, lo, hi, g, res, scratch)
    return counts.sum()


@njit(cache=CACHE, _nrt=NRT)
def _joint_chunk(pars, el, jt, R, dt, commit, lo, hi, g, res, scratch):
    """Joints ``lo <= k < hi`` of :func:`~siku_core.contact.contact_forces.joint_forces`; returns
    how many
    broke. ``el``, ``jt``: the elements and the joint table (records of
    :mod:`siku_core.contact.contact_tables`); ``g``, ``res``, ``scratch``: the task's buffers
    (geometry, result, history row). ``jt.fresh`` (not empty): the joints' constants ``jt.K``,
    ``jt.meff`` are first computed from it (:func:`~siku_core.contact.ice_follow.joints_from`, lever
    arms ``jt.ri``, ``jt.rj``). ``el.dmob`` (per element ``n/m, n/I``; empty: the dampers
    unbounded): ``g[J_DTM]`` of each joint (:mod:`siku_core.contact.damping`)."""
    ji = jt.ji
    jj = jt.jj
    ends_i = jt.ends_i
    ends_j = jt.ends_j
    intact = jt.intact
    hist = jt.hist
    out = jt.rows
    active = jt.active
    rm = el.rm
    V = el.V
    w = el.w
    h = el.h
    E = el.E
    dmob = el.dmob
    if jt.fresh.shape[0]:
        joints_from(lo, hi, jt.fresh, ji, jj, jt.ri, jt.rj, jt.K, jt.meff)
    nh = hist.shape[1]
    inv_r = 1.0 / R
    bounded = dmob.shape[0] > 0
    nb = 0
    for k in range(lo, hi):
        active[k] = 0
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
        g[J_L0] = jt.L0[k]
        g[J_W] = jt.width[k]
        g[J_K] = jt.K[k]
        g[J_MEFF] = jt.meff[k]
        # the material points at the ends: i's copy at a (b), j's copy at A (B)
        xa, ya = i_to_j(M, ax, ay, R, inv_r)
        xb, yb = i_to_j(M, bx, by, R, inv_r)
        g[J_VAX], g[J_VAY] = relative_velocity_m(M, V, w, i, j, ax, ay, xa, ya)
        g[J_VBX], g[J_VBY] = relative_velocity_m(M, V, w, i, j, bx, by, xb, yb)
        g[J_HI] = h[i]
        g[J_HJ] = h[j]
        g[J_EI] = E[i]
        g[J_EJ] = E[j]
        g[J_NU] = el.nu[i]
        g[J_DT] = dt
        if bounded:
            # the largest lever arms of the joint's points: its ends, in each element's frame
            ri2 = max(ax * ax + ay * ay, bx * bx + by * by)
            rj2 = max(ends_j[k, 0, 0] ** 2 + ends_j[k, 0, 1] ** 2,
                      ends_j[k, 1, 0] ** 2 + ends_j[k, 1, 1] ** 2)
            g[J_DTM] = dt * damping_mobility(dmob, i, j, ri2, rj2)
        else:
            g[J_DTM] = 0.0
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
                jt.break_mode[k] = res[3]
                nb += 1
            continue
        pair_contribution(M, res[0], res[1], 0.5 * (ax + bx), 0.5 * (ay + by), res[2], inv_r,
                          R, out, k)
        active[k] = 1
    return nb



@njit(parallel=True, cache=CACHE)
def _collision_forces(pars, el_t, pt_t, R, dt, nmax, pretest, drop, commit, nch, nt):
    el = ContactElements(*el_t)   # plain tuples named again (as in _joint_forces)
    pt = PairTable(*pt_t)
    counts = np.zeros(nch, dtype=np.int64)
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        xy, tag = make_overlap_scratch(nmax, nmax)
        proj = np.empty((nmax, 2))
        g = np.empty(G_SIZE)
        res = np.empty(4)
        blk = np.empty(CBLOCK * BLK_SIZE)
        if CHIST:
            hrow = np.empty(pt.chist.shape[1])
        else:
            hrow = res  # never read: the row's branches are pruned
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, pt.pairs.shape[0])
            counts[c] = _collision_chunk(pars, el, pt, R, dt, pretest, drop, commit, lo, hi,
                                         (xy, tag, proj, g, res, blk, hrow))
    return counts.sum()


@njit(cache=CACHE, _nrt=NRT)
def _collision_block(pars, el, pt, R, dt, commit, g, res, blk, nb, hrow):
    """Evaluate the ``nb`` overlapping pairs of one block of :func:`_collision_chunk` (rows of
    ``blk``, ``BLK_*``) into ``pt.rows`` and ``pt.active``; with ``CHIST``, pair ``k``'s
    history row ``pt.chist[k]`` goes to the evaluator in ``hrow`` and back to ``pt.chist[k]``
    when ``commit``; ``pt.caps[k]`` gets the evaluator's ``res[3]`` (1: the law capped the
    normal force) where ``pt.caps`` is not empty; ``g[G_DTM]`` from ``el.dmob`` and the step
    ``dt`` [s] (:mod:`siku_core.contact.damping`; 0 where ``el.dmob`` is empty).
    Apart from the geometry that finds them, a contact's evaluation is a chain of dependent
    square roots and divisions (lever arms, stiffness, damping); evaluated in a loop of their
    own, the chains of consecutive contacts overlap in the processor instead of waiting for the
    next pair's clip."""
    V = el.V
    w = el.w
    minv = el.minv
    h = el.h
    E = el.E
    area = el.area
    dmob = el.dmob
    pairs = pt.pairs
    out = pt.rows
    active = pt.active
    chist = pt.chist
    caps = pt.caps
    inv_r = 1.0 / R
    for n in range(nb):
        b = n * BLK_SIZE
        k = int(blk[b + BLK_K])
        a = blk[b + BLK_AREA]
        cx = blk[b + BLK_CX]
        cy = blk[b + BLK_CY]
        M = (blk[b + BLK_M], blk[b + BLK_M + 1], blk[b + BLK_M + 2], blk[b + BLK_M + 3],
             blk[b + BLK_M + 4], blk[b + BLK_M + 5], blk[b + BLK_M + 6], blk[b + BLK_M + 7],
             blk[b + BLK_M + 8])
        i = pairs[k, 0]
        j = pairs[k, 1]
        ri = math.sqrt(cx * cx + cy * cy)
        xj, yj = i_to_j(M, cx, cy, R, inv_r)
        rj = math.sqrt(xj * xj + yj * yj)
        g[G_AREA] = a
        g[G_CX] = cx
        g[G_CY] = cy
        g[G_NX] = blk[b + BLK_NX]
        g[G_NY] = blk[b + BLK_NY]
        g[G_WIDTH] = blk[b + BLK_WIDTH]
        g[G_K] = eq9_stiffness(h[i], E[i], h[j], E[j], ri, rj)
        g[G_MEFF] = 1.0 / (minv[i] + minv[j])  # the reduced mass [kg]
        g[G_VX], g[G_VY] = relative_velocity_m(M, V, w, i, j, cx, cy, xj, yj)
        g[G_AREA_I] = area[i]
        g[G_AREA_J] = area[j]
        g[G_HI] = h[i]
        g[G_HJ] = h[j]
        if dmob.shape[0]:
            g[G_DTM] = dt * damping_mobility(dmob, i, j, cx * cx + cy * cy, xj * xj + yj * yj)
        else:
            g[G_DTM] = 0.0
        res[0] = 0.0
        res[1] = 0.0
        res[2] = 0.0
        res[3] = 0.0
        if CHIST:
            nh = hrow.shape[0]
            for c in range(nh):
                hrow[c] = chist[k, c]
            evaluate(g, pars, hrow, res)
            if commit:
                for c in range(nh):
                    chist[k, c] = hrow[c]
        else:
            evaluate(g, pars, res)
        pair_contribution(M, res[0], res[1], cx, cy, res[2], inv_r, R, out, k)
        active[k] = 1
        if caps.shape[0]:
            caps[k] = 1 if res[3] != 0.0 else 0


@njit(cache=CACHE, _nrt=NRT)
def _collision_chunk(pars, el, pt, R, dt, pretest, drop, commit, lo, hi, buffers):
    """Pairs ``lo <= k < hi`` of :func:`~siku_core.contact.contact_forces.collision_forces`; returns
    how
    many overlap. ``el``, ``pt``: the elements and the pair table (records of
    :mod:`siku_core.contact.contact_tables`; ``pt.chist``, ``commit``: the per-contact history
    (``CHIST``) and whether it changes; ``pt.caps``: per pair, whether the law capped its
    normal force (empty: not kept); ``pt.chint``: the pairs' crossing edges for the coherent
    clip (``geometry.coherent``; empty: the clip in full); ``el.dmob``, ``dt``: the dampers'
    bound, :func:`_collision_block`). ``buffers``: the task's ``xy``, ``tag``, ``proj``,
    ``g``, ``res``, ``blk``, ``hrow`` (clipping, partner vertices, geometry, result, a block
    of overlaps waiting for :func:`_collision_block`, the history row). One compiled loop on
    purpose: the geometry, the pretest and the block hand-off share the task's buffers, and a
    split would cost calls in the hot loop."""
    xy, tag, proj, g, res, blk, hrow = buffers
    rm = el.rm
    offsets = el.offsets
    verts = el.verts
    margin = el.margin
    scale = el.scale
    edges = el.edges
    pairs = pt.pairs
    active = pt.active
    hint = pt.hint
    face = pt.face
    chint = pt.chint
    inv_r = 1.0 / R
    no = 0
    nb = 0
    for k in range(lo, hi):
        # a pair that overlapped at the last evaluation almost always still does, and one the
        # clip found touching (``on = 2``, ``drop`` only) mostly still touches: straight to the
        # clip (which finds no area for any pair ``apart`` would have settled, and at most the
        # touching area for any the test with the margin would have settled)
        test = pretest and active[k] == 0
        active[k] = 0
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
                    active[k] = 2  # touching, dropped: no force
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
            if chint.shape[0]:
                a, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_coherent(
                    pi, pj, xy, tag, c2x, c2y, drop, chint, k)
            else:
                a, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_inline(
                    pi, pj, xy, tag, c2x, c2y, drop)
            if a <= 0.0:
                if ncross < 0:
                    active[k] = 2  # touching, dropped: no force; no separating-axis test next time
                continue
            width = overlap_width(pi, pj, a, ncross, p1x, p1y, p2x, p2y, nx, ny)
        # the contact's evaluation waits for the block (_collision_block)
        b = nb * BLK_SIZE
        blk[b + BLK_K] = k
        blk[b + BLK_AREA] = a
        blk[b + BLK_CX] = cx
        blk[b + BLK_CY] = cy
        blk[b + BLK_NX] = nx
        blk[b + BLK_NY] = ny
        blk[b + BLK_WIDTH] = width
        for m in range(9):
            blk[b + BLK_M + m] = M[m]
        nb += 1
        if nb == CBLOCK:
            _collision_block(pars, el, pt, R, dt, commit, g, res, blk, nb, hrow)
            no += nb
            nb = 0
    if nb:
        _collision_block(pars, el, pt, R, dt, commit, g, res, blk, nb, hrow)
        no += nb
    return no
