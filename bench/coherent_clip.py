"""The coherent clip against the engine's clip, on the real overlaps of the collision scene.

``python -m bench.coherent_clip [--n 10000] [--steps 1]`` (one thread, about a minute) takes
every candidate pair without a joint that overlaps after 20 steps of the collision scene,
projects ``j`` into ``i``'s plane as the contact loop does (the quadrilaterals of
``bench.clip_variants``), reads each pair's crossing edges from the engine's clip there (the
hint, :func:`siku_core.geometry.coherent.crossing_edges`), runs ``--steps`` more steps and
times on the pairs' new geometry (ns per pair, best of 10 rounds):

* ``engine``: :func:`siku_core.geometry.clip.overlap_inline`;
* ``coherent``: :func:`siku_core.geometry.coherent.overlap_coherent` from the old hints (the
  coherent overlap where its check holds, else the clip and a new hint; the hints are reset
  before every round, so every round does the same work);

and prints the share of pairs the coherent check accepts and the largest differences from the
clip where it does (area relative; centroid, crossings over ``L``; normal).
"""
from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np
from numba import njit

from bench.clip_variants import _quads, differences
from siku_core.geometry.clip import make_overlap_scratch, overlap_inline
from siku_core.geometry.coherent import coherent_overlap, crossing_edges, overlap_coherent


@njit(cache=True)
def _hints(Q, C, hints):
    xy, tag = make_overlap_scratch(4, 4)
    for n in range(Q.shape[0]):
        e = overlap_inline(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False)
        hints[n] = crossing_edges(Q[n, 0], Q[n, 1], e[4], e[5], e[6], e[7]) if e[3] == 2 else -1


@njit(cache=True)
def _time_engine(Q, C, h0, h, reps):
    xy, tag = make_overlap_scratch(4, 4)
    s = 0.0
    for _ in range(reps):
        for n in range(Q.shape[0]):
            r = overlap_inline(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False)
            s += r[0] + r[1] + r[8]
    return s


@njit(cache=True)
def _time_coherent(Q, C, h0, h, reps):
    xy, tag = make_overlap_scratch(4, 4)
    s = 0.0
    for _ in range(reps):
        h[:] = h0
        for n in range(Q.shape[0]):
            r = overlap_coherent(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False, h, n)
            s += r[0] + r[1] + r[8]
    return s


@njit(cache=True)
def _compare(Q, C, h, out):
    xy, tag = make_overlap_scratch(4, 4)
    for n in range(Q.shape[0]):
        e = overlap_inline(Q[n, 0], Q[n, 1], xy, tag, C[n, 0], C[n, 1], False)
        b = coherent_overlap(Q[n, 0], Q[n, 1], C[n, 0], C[n, 1], h[n])
        out[n, :] = 0.0
        if not b[0]:
            continue
        differences(b, e, np.abs(Q[n]).max(), out[n])


def _best(fn, Q, C, h0, reps=5, rounds=10) -> float:
    h = h0.copy()
    fn(Q, C, h0, h, 1)
    best = math.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn(Q, C, h0, h, reps)
        best = min(best, time.perf_counter() - t0)
    return best / reps / len(Q) * 1e9


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.coherent_clip", description=__doc__)
    ap.add_argument("--n", type=int, default=10000, help="elements (default 10000)")
    ap.add_argument("--steps", type=int, default=1, help="steps between hint and clip")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    from bench.scenes import scene
    from siku_core.run.simulation import Simulation

    sim = Simulation(scene("collision", args.n, None), out=False)
    for _ in range(20):
        sim.step()
    cm, st = sim.contacts, sim.state
    quad = np.diff(st.vert_offsets) == 4
    sel = np.flatnonzero((cm.pface[:, 0] < 0) & (cm.pair_active == 1) & quad[cm.pairs[:, 0]]
                         & quad[cm.pairs[:, 1]])
    pairs = cm.pairs.copy()
    Q = np.empty((len(sel), 2, 4, 2))
    C = np.empty((len(sel), 2))
    _quads(cm.rm, st.verts, st.vert_offsets, pairs, sel, sim.radius, Q, C)
    h0 = np.empty(len(sel), np.int32)
    _hints(Q, C, h0)
    for _ in range(args.steps):
        sim.step()
    _quads(cm.rm, st.verts, st.vert_offsets, pairs, sel, sim.radius, Q, C)
    cmp = np.empty((len(Q), 6))
    _compare(Q, C, h0, cmp)
    ok = cmp[:, 0] == 1.0
    print(f"pairs {len(sel)} ({len(sel) / st.n:.3f} per element), hinted {np.mean(h0 >= 0):.1%}, "
          f"coherent {ok.mean():.1%} after {args.steps} step(s)")
    if ok.any():
        print(f"largest differences where coherent: area {cmp[ok, 1].max():.1e} relative, "
              f"centroid {cmp[ok, 2].max():.1e} L, crossings {cmp[ok, 3].max():.1e} L, normal "
              f"{cmp[ok, 4].max():.1e}, ncross equal {bool(cmp[ok, 5].all())}")
    for _ in range(2):
        print(f"engine {_best(_time_engine, Q, C, h0):.1f} ns/pair, "
              f"coherent {_best(_time_coherent, Q, C, h0):.1f} ns/pair")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
