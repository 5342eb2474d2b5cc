"""The engine's contact loops: one over joints, one over candidate pairs, and the gather.

docs/explanation/physics.md section 4. The engine owns the loops; a contact law supplies small
``@njit`` evaluators of *one* contact (HOOMD's "template evaluator"), whose contract (layouts
of ``g`` and ``out``, break modes, parameter records, sign conventions) is
:mod:`siku_core.contact_law`; the frames and geometry helpers the loops use are
:mod:`siku_core.contact.contact_frames`.

* :func:`joint_forces`: every intact joint, its evaluator's result written to its row
  (``ROW_*``) of ``out``;
* :func:`collision_forces`: every candidate pair, clipped where it may overlap and evaluated
  where it does;
* :func:`gather_forces`: each element's sum of its contacts' rows.

Each loop exists once, in the template module :mod:`siku_core.contact.contact_loops`, where it calls
the law's evaluator as the module global ``evaluate``;
:func:`~siku_core.contact.kernel_cache.instantiate`
makes a module of that template for one evaluator (a generated file that numba caches; the
generic instance, compiled in every process, where no file can serve), and the entry points
here call its loops. The loops take the contact records of :mod:`siku_core.contact.contact_tables`
(the elements, the joint table, the pair table, the element-to-contact index: named records,
:mod:`siku_core.records`) and a few scalars, documented in :func:`joint_forces`,
:func:`collision_forces` and :func:`gather_forces`.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import contact_loops
from .contact_tables import ContactElements, ContactIndex, JointTable, PairTable
from .kernel_cache import instantiate
from ..parallel import chunk_bounds, claim, tasks


def joint_forces(evaluate, pars: np.ndarray, el: ContactElements, jt: JointTable, R: float,
                 dt: float, commit: bool, nch: int) -> int:
    """Evaluate every intact joint of the joint table ``jt`` into ``jt.rows[k]`` (``ROW_*``)
    and ``jt.active[k]``; returns the number that broke (only when ``commit``; their break
    mode, the evaluator's ``out[3]``, goes to ``jt.break_mode[k]``, and their history row
    ``jt.hist[k]`` changes only then too). ``el``: the elements
    (:data:`~siku_core.contact.contact_tables.ContactElements`); ``pars``: the law's parameter
    vector;
    ``R``: the planet radius [m]; ``dt``: the step [s]; ``nch``: the number of chunks.
    ``jt.fresh`` (two values per element, ``h E`` [Pa m] and the inverse mass a joint counts
    [1/kg]; :func:`~siku_core.contact.ice_follow.follow_contacts`) and the lever arms ``jt.ri``,
    ``jt.rj`` [m], where not empty: every joint's ``jt.K``, ``jt.meff`` are first computed
    from them, in the same parallel loop (after a process changed the ice). ``el.dmob`` (per
    element ``n/m`` [1/kg], ``n/I`` [1/(kg m²)], ``n`` its contacts; no rows: the dampers
    unbounded): the bound of the dampers (:mod:`siku_core.contact.damping`, ``g[J_DTM]``)."""
    loops = instantiate(contact_loops, evaluate)
    return loops._joint_forces(pars, tuple(el), tuple(jt), R, dt, commit, nch, tasks(nch))


def collision_forces(evaluate, pars: np.ndarray, el: ContactElements, pt: PairTable, R: float,
                     nmax: int, pretest: bool, nch: int, drop: bool = False,
                     commit: bool = False, dt: float = 0.0) -> int:
    """Clip every candidate pair of the pair table ``pt`` (unless, with ``pretest``, the
    separating-axis test :func:`~siku_core.geometry.clip.separating_edge` finds an edge line
    that separates or touches them) and evaluate the overlapping ones into ``pt.rows[k]`` with
    ``pt.active[k] = 1`` (``0`` for the others, ``2`` for a touching overlap dropped under
    ``drop``: no force either); returns the number of overlapping pairs. A pair with
    ``pt.active[k] = 1`` or ``2`` from the last evaluation skips the test (it almost always
    still overlaps or touches; the clip finds no area where the test would have found the pair
    apart, and no more than the touching area where the test with the margin would have).
    ``nmax``: the most vertices of an element; ``R``: the planet radius [m]; ``nch``: the
    number of chunks.

    The elements ``el`` (:data:`~siku_core.contact.contact_tables.ContactElements`, built with
    defaults by :func:`~siku_core.contact.contact_tables.element_table`): ``el.minv`` (1/kg) the
    inverse mass, 0 for a static or steady element (an overlapping pair's reduced mass
    ``1 / (minv_i + minv_j)`` [kg] is computed as it is evaluated); ``el.margin`` (m) the
    test's margin; ``el.scale`` (m) each element's largest absolute vertex coordinate;
    ``el.edges`` (per vertex row) :func:`~siku_core.geometry.face.edge_table` of ``el.offsets,
    el.verts``, the constants of the edge a jointed pair touches along; ``el.dmob`` and the
    step ``dt`` [s]: the bound of the dampers (``g[G_DTM]``, as :func:`joint_forces`).

    The pairs ``pt`` (:data:`~siku_core.contact.contact_tables.PairTable`, built with defaults by
    :func:`~siku_core.contact.contact_tables.pair_table`): ``pt.hint`` (int16, updated) the edge
    that
    separated the pair last, tried first; ``pt.face`` (int16 ``(K, 2)``, ``-1`` for none) the
    edges of ``i`` and ``j`` the pair is jointed along, whose touching overlap
    :func:`~siku_core.geometry.face.touching_face` finds without the clip; ``pt.chist``
    (float64 ``(K, C)``; no columns for a law without per-contact history) the pairs' history
    rows, passed to the evaluator ``evaluate(g, pars, hist, out)`` of an overlapping pair and
    updated from it only when ``commit`` (the rows of the other pairs are left as they are:
    the caller drops them, ``ContactModel``); ``pt.caps`` (int8; empty: not kept) 1 where the
    evaluator capped the normal force (its ``out[3]``, the ``ridging`` law's plastic limit),
    else 0, written where ``active[k] = 1`` (others keep what they held); ``pt.chint`` (int32,
    updated; empty: off) the crossing edges each pair's overlap had last, from which the
    coherent clip (:func:`~siku_core.geometry.coherent.overlap_coherent`) computes it again
    (the same results to round-off; where its check fails, the full clip bit for bit).
    ``drop``: touching overlaps (area at most the clip's tolerance) carry no force
    (``contact.touching = "ignore"``, with ``margin = REL_TOL L_i / 3``, so that the test
    settles such pairs).
    """
    loops = instantiate(contact_loops, evaluate, pt.chist.shape[1] > 0)
    return loops._collision_forces(pars, tuple(el), tuple(pt), R, float(dt), nmax, pretest, drop,
                                   bool(commit), nch, tasks(nch))


def gather_forces(F, T, index: ContactIndex, jout, joint_active, pout, pair_active, nch):
    """Add to ``F[e], T[e]`` (force [N], torque [N m]) the contributions of element ``e``'s
    joints (rows ``jout`` where ``joint_active``), then of its pairs (rows ``pout`` where
    ``pair_active == 1``), each in ascending contact index as the element-to-contact
    ``index`` lists them (fixed order: independent of the thread count)."""
    _gather_forces(F, T, tuple(index), jout, joint_active, pout, pair_active, nch,
                   tasks(nch))


@njit(cache=True, parallel=True)
def _gather_forces(F, T, index_t, jout, joint_active, pout, pair_active, nch, nt):
    index = ContactIndex(*index_t)   # a plain tuple named again (records.py, "At the boundary")
    n = F.shape[0]
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, n)
            _gather_chunk(F, T, index, jout, joint_active, pout, pair_active, lo, hi)


@njit(cache=True)
def _gather_chunk(F, T, index, jout, joint_active, pout, pair_active, lo, hi):
    """Elements ``lo <= e < hi`` of :func:`gather_forces`."""
    joff = index.joff
    jidx = index.jidx
    jside = index.jside
    poff = index.poff
    pidx = index.pidx
    pside = index.pside
    for e in range(lo, hi):
        fx = F[e, 0]
        fy = F[e, 1]
        t = T[e]
        for a in range(joff[e], joff[e + 1]):
            k = jidx[a]
            if joint_active[k]:
                s = 3 * jside[a]
                fx += jout[k, s]
                fy += jout[k, s + 1]
                t += jout[k, s + 2]
        for a in range(poff[e], poff[e + 1]):
            k = pidx[a]
            if pair_active[k] == 1:
                s = 3 * pside[a]
                fx += pout[k, s]
                fy += pout[k, s + 1]
                t += pout[k, s + 2]
        F[e, 0] = fx
        F[e, 1] = fy
        T[e] = t
