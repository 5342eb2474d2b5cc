"""The clip of two quadrilaterals: the engine's against a boundary-integral variant.

``python -m bench.clip_variants [--n 10000]`` (one thread, about a minute) takes every
candidate pair without a joint that overlaps after 20 steps of the collision scene and of the
bonded pack, projects ``j`` into ``i``'s plane as the contact loop does, and times on those
quadrilaterals (ns per pair, best of 10 rounds):

* ``engine``: :func:`siku_core.geometry.clip.overlap_inline` (Sutherland–Hodgman with the
  tolerance rules: merged vertices, shared edges, touching areas);
* ``engine, one pair repeated``: the same on one pair copied over the whole array, so that
  every branch is predicted: what the clip costs without branch mispredictions;
* ``boundary``: :func:`boundary_quads`, the overlap as the pieces of either boundary inside
  the other polygon (each edge clipped to a parameter interval against the other's four
  lines, Green's theorem for area and centroid, crossings counted on the pieces), valid only
  where none of the clip's tolerance rules can act, else the engine's clip.

and checks that, where the variant is valid, both give the same area, centroid, crossing
points and normal to round-off. The validity conditions (``FAST_K = 4`` times the clip's
tolerance ``tol``): every vertex of either polygon farther than ``FAST_K tol`` from every edge
line of the other, every edge longer than that, every end of a piece farther than that from
the other polygon's lines it does not lie on, and an area above twice the touching area.
Then no two vertices of the clipped polygon are within ``tol`` (each piece is longer than
``FAST_K tol``), no piece lies within ``tol`` of a line of the other polygon (its ends are
farther), every sign the clip tests is decided by more than its round-off, and the clipped
polygon's boundary classes change exactly at the crossings: the same polygon, the same
crossings. ``bench/RESULTS.md`` has the numbers (the variant is correct and slower).
"""
from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np
from numba import njit

from siku_core.contact.contact_frames import j_to_i, relative_matrix
from siku_core.geometry.clip import (
    REL_TOL,
    _unit_or_x,
    make_overlap_scratch,
    overlap_inline,
)

#: a vertex, piece end or edge counts as clear of the tolerance rules beyond FAST_K tol
FAST_K = 4.0
_NONE = (False, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@njit(cache=True, inline="always")
def _crossing(ncross, x, y, p1x, p1y, p2x, p2y):
    """One more crossing at ``(x, y)``: the first two are kept."""
    if ncross == 0:
        return 1, x, y, p2x, p2y
    if ncross == 1:
        return 2, p1x, p1y, x, y
    return ncross + 1, p1x, p1y, p2x, p2y


@njit(cache=True, inline="always")
def boundary_quads(A, B, xy, w, c2x, c2y):
    """``(valid, area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny)`` of two CCW quadrilaterals
    ``A`` (centred at the origin) and ``B`` (centre ``(c2x, c2y)``), as ``overlap_inline``
    returns them; ``valid`` False where a tolerance rule of the clip could act (the result is
    then zeros). ``xy``: the clip's scratch; ``w``: 40 floats of scratch."""
    big = 0.0
    for v in range(4):
        big = max(big, abs(A[v, 0]), abs(A[v, 1]), abs(B[v, 0]), abs(B[v, 1]))
    tol = REL_TOL * big
    lim = FAST_K * FAST_K * tol * tol
    # w[0:4], w[4:8]: lim |e|² of A's and B's edges; w[8:24]: e_B(k) × (A_v - B_k) at 8 + 4 v
    # + k; w[24:40]: e_A(k) × (B_v - A_k)
    for k in range(4):
        k1 = (k + 1) & 3
        ax = A[k1, 0] - A[k, 0]
        ay = A[k1, 1] - A[k, 1]
        bx = B[k1, 0] - B[k, 0]
        by = B[k1, 1] - B[k, 1]
        w[k] = lim * (ax * ax + ay * ay)
        w[4 + k] = lim * (bx * bx + by * by)
        if not (ax * ax + ay * ay > lim and bx * bx + by * by > lim):
            return _NONE
        for v in range(4):
            f = bx * (A[v, 1] - B[k, 1]) - by * (A[v, 0] - B[k, 0])
            if not f * f > w[4 + k]:
                return _NONE
            w[8 + 4 * v + k] = f
            g = ax * (B[v, 1] - A[k, 1]) - ay * (B[v, 0] - A[k, 0])
            if not g * g > w[k]:
                return _NONE
            w[24 + 4 * v + k] = g
    npc = 0
    ncross = 0
    p1x = p1y = p2x = p2y = 0.0
    for side in range(2):
        P = A if side == 0 else B
        d0 = 8 if side == 0 else 24
        l0 = 4 if side == 0 else 0
        for e in range(4):
            e1 = (e + 1) & 3
            tlo = 0.0
            thi = 1.0
            klo = -1
            khi = -1
            empty = False
            for k in range(4):
                f0 = w[d0 + 4 * e + k]
                f1 = w[d0 + 4 * e1 + k]
                if f0 < 0.0:
                    if f1 < 0.0:
                        empty = True
                        break
                    t = f0 / (f0 - f1)
                    if t > tlo:
                        tlo = t
                        klo = k
                elif f1 < 0.0:
                    t = f0 / (f0 - f1)
                    if t < thi:
                        thi = t
                        khi = k
            if empty or not tlo < thi:
                continue
            for k in range(4):  # a piece's ends clear of the lines they do not lie on
                f0 = w[d0 + 4 * e + k]
                df = w[d0 + 4 * e1 + k] - f0
                if klo >= 0 and k != klo:
                    f = f0 + tlo * df
                    if not f * f > w[l0 + k]:
                        return _NONE
                if khi >= 0 and k != khi:
                    f = f0 + thi * df
                    if not f * f > w[l0 + k]:
                        return _NONE
            x0 = P[e, 0]
            y0 = P[e, 1]
            ex = P[e1, 0] - x0
            ey = P[e1, 1] - y0
            if klo >= 0:
                sx = x0 + tlo * ex
                sy = y0 + tlo * ey
            else:
                sx = x0
                sy = y0
            if khi >= 0:
                qx = x0 + thi * ex
                qy = y0 + thi * ey
            else:
                qx = P[e1, 0]
                qy = P[e1, 1]
            xy[0, npc, 0] = sx
            xy[0, npc, 1] = sy
            xy[1, npc, 0] = qx
            xy[1, npc, 1] = qy
            npc += 1
            if side == 0:  # each crossing counted once: on A's pieces
                if klo >= 0:
                    ncross, p1x, p1y, p2x, p2y = _crossing(ncross, sx, sy, p1x, p1y, p2x, p2y)
                if khi >= 0:
                    ncross, p1x, p1y, p2x, p2y = _crossing(ncross, qx, qy, p1x, p1y, p2x, p2y)
    if npc == 0:
        return _NONE
    ox = xy[0, 0, 0]
    oy = xy[0, 0, 1]
    a2 = mx = my = 0.0
    for p in range(npc):  # Green's theorem over the pieces, about a point of the overlap
        xi = xy[0, p, 0] - ox
        yi = xy[0, p, 1] - oy
        xj = xy[1, p, 0] - ox
        yj = xy[1, p, 1] - oy
        cr = xi * yj - xj * yi
        a2 += cr
        mx += (xi + xj) * cr
        my += (yi + yj) * cr
    area = 0.5 * a2
    if not area > 2.0 * REL_TOL * big * big:
        return _NONE
    if ncross == 2:
        ux = p2x - p1x
        uy = p2y - p1y
        un = math.sqrt(ux * ux + uy * uy)
        if not un > tol:  # cannot happen where valid (the crossings are pieces apart)
            return _NONE
        nx = -uy / un
        ny = ux / un
        if nx * c2x + ny * c2y < 0.0:
            nx = -nx
            ny = -ny
    else:
        nx, ny = _unit_or_x(c2x, c2y, tol)  # the clip's fallback: towards j's centre
        p1x = p1y = p2x = p2y = 0.0
    cx = ox + mx / (3.0 * a2)
    cy = oy + my / (3.0 * a2)
    return True, area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny


@njit(cache=True)
def _quads(rm, verts, offsets, pairs, sel, R, out, cen):
    inv_r = 1.0 / R
    for n in range(sel.shape[0]):
        k = sel[n]
        i = pairs[k, 0]
        j = pairs[k, 1]
        M = relative_matrix(rm, i, j)
        for v in range(4):
            out[n, 0, v, 0] = verts[offsets[i] + v, 0]
            out[n, 0, v, 1] = verts[offsets[i] + v, 1]
            out[n, 1, v, 0], out[n, 1, v, 1] = j_to_i(M, verts[offsets[j] + v, 0],
                                                      verts[offsets[j] + v, 1], R, inv_r)
        cen[n, 0], cen[n, 1] = j_to_i(M, 0.0, 0.0, R, inv_r)


@njit(cache=True)
def _time_engine(Q, C, reps):
    xy, tag = make_overlap_scratch(4, 4)
    s = 0.0
    for _ in range(reps):
        for n in range(Q.shape[0]):
            r = overlap_inline(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False)
            s += r[0] + r[1] + r[8]
    return s


@njit(cache=True)
def _time_boundary(Q, C, reps):
    xy, tag = make_overlap_scratch(4, 4)
    w = np.empty(40)
    s = 0.0
    for _ in range(reps):
        for n in range(Q.shape[0]):
            r = boundary_quads(Q[n, 0], Q[n, 1], xy, w, C[n, 0], C[n, 1])
            if r[0]:
                s += r[1] + r[2] + r[9]
            else:
                e = overlap_inline(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False)
                s += e[0] + e[1] + e[8]
    return s


@njit(cache=True)
def differences(b, e, big, row):
    """Into ``row``: 1 (compared), the relative area difference, the centroid's and the
    crossing points' differences over the size ``big``, the normal's, and 1 where the number of
    crossings agrees; ``b`` a variant's result, ``e`` the engine clip's (``overlap_inline``)."""
    row[0] = 1.0
    row[1] = abs(b[1] - e[0]) / e[0]
    row[2] = max(abs(b[2] - e[1]), abs(b[3] - e[2])) / big
    same = math.hypot(b[5] - e[4], b[6] - e[5]) + math.hypot(b[7] - e[6], b[8] - e[7])
    swap = math.hypot(b[5] - e[6], b[6] - e[7]) + math.hypot(b[7] - e[4], b[8] - e[5])
    row[3] = min(same, swap) / big
    row[4] = max(abs(b[9] - e[8]), abs(b[10] - e[9]))
    row[5] = 1.0 if b[4] == e[3] else 0.0


@njit(cache=True)
def _compare(Q, C, out):
    """Per pair: valid, then the largest differences (area relative; centroid, crossings and
    normal over the coordinate scale), and whether ``ncross`` agrees."""
    xy, tag = make_overlap_scratch(4, 4)
    w = np.empty(40)
    for n in range(Q.shape[0]):
        e = overlap_inline(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False)
        b = boundary_quads(Q[n, 0], Q[n, 1], xy, w, C[n, 0], C[n, 1])
        out[n, :] = 0.0
        if not b[0]:
            continue
        differences(b, e, np.abs(Q[n]).max(), out[n])


def _best(fn, Q, C, reps=5, rounds=10) -> float:
    fn(Q, C, 1)
    best = math.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn(Q, C, reps)
        best = min(best, time.perf_counter() - t0)
    return best / reps / len(Q) * 1e9


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.clip_variants", description=__doc__)
    ap.add_argument("--n", type=int, default=10000, help="elements (default 10000)")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    from bench.scenes import scene
    from siku_core.run.simulation import Simulation

    print("| scene | pairs / element | engine [ns/pair] | engine, one pair repeated | "
          "boundary [ns/pair] | valid | max rel. area diff. | centroid, crossings, normal "
          "diff. / L | ncross equal |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---|")
    for kind in ("collision", "bonded"):
        sim = Simulation(scene(kind, args.n, "distributed_spring" if kind == "bonded" else None),
                         out=False)
        for _ in range(20):
            sim.step()
        cm, st = sim.contacts, sim.state
        quad = np.diff(st.vert_offsets) == 4
        sel = np.flatnonzero((cm.pface[:, 0] < 0) & (cm.pair_active == 1) & quad[cm.pairs[:, 0]]
                             & quad[cm.pairs[:, 1]])
        Q = np.empty((len(sel), 2, 4, 2))
        C = np.empty((len(sel), 2))
        _quads(cm.rm, st.verts, st.vert_offsets, cm.pairs, sel, sim.radius, Q, C)
        rep = np.empty(5)
        for m, n in enumerate(np.random.default_rng(1).integers(0, len(sel), 5)):
            rep[m] = _best(_time_engine, np.repeat(Q[n:n + 1], len(Q), axis=0),
                           np.repeat(C[n:n + 1], len(Q), axis=0), rounds=3)
        cmp = np.empty((len(Q), 6))
        _compare(Q, C, cmp)
        ok = cmp[:, 0] == 1.0
        diffs = (f"{cmp[ok, 1].max():.1e} | {cmp[ok, 2].max():.1e}, {cmp[ok, 3].max():.1e}, "
                 f"{cmp[ok, 4].max():.1e} | {bool(cmp[ok, 5].all())}") if ok.any() else "— | — | —"
        print(f"| {kind} | {len(sel) / st.n:.3f} | {_best(_time_engine, Q, C):.1f} | "
              f"{rep.min():.1f}–{rep.max():.1f} | {_best(_time_boundary, Q, C):.1f} | "
              f"{ok.mean():.1%} | {diffs} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
