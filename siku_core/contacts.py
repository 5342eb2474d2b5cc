"""The engine's contact loops: one over joints, one over candidate pairs, and the gather.

docs/explanation/physics.md section 4. The engine owns the loops; a contact law supplies small
``@njit`` evaluators of *one* contact (HOOMD's "template evaluator"), whose contract (layouts
of ``g`` and ``out``, break modes, parameter records, sign conventions) is
:mod:`siku_core.contact_law`; the frames and geometry helpers the loops use are
:mod:`siku_core.contact_frames`.

* :func:`joint_forces`: every intact joint, its evaluator's result written to its row
  (``ROW_*``) of ``out``;
* :func:`collision_forces`: every candidate pair, clipped where it may overlap and evaluated
  where it does;
* :func:`gather_forces`: each element's sum of its contacts' rows.

Each loop exists once, in the template module :mod:`siku_core.contact_loops`, where it calls
the law's evaluator as the module global ``evaluate``; :func:`~siku_core.kernel_cache.instantiate`
makes a module of that template for one evaluator (a generated file that numba caches; the
generic instance, compiled in every process, where no file can serve), and the entry points
here call its loops. Their positional arguments are documented in :func:`joint_forces` and
:func:`collision_forces` (grouping them into tuples costs nothing in numba's typing but every
call unpacks them again: they stay positional).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import contact_loops
from .deprecation import moved_names
from .geometry.face import edge_table
from .kernel_cache import instantiate
from .parallel import chunk_bounds, claim, tasks


def joint_forces(evaluate, pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width, jK,
                 jmeff, intact, break_mode, hist, R, dt, commit, out, active, nch, fresh=None,
                 arms=None, dmob=None):
    """Evaluate every intact joint into ``out[k]`` (``ROW_*``) and ``active[k]``; returns the number
    that broke (only when ``commit``; their break mode, the evaluator's ``out[3]``, goes to
    ``break_mode[k]``). ``fresh`` (two values per element, ``h E`` [Pa m] and the inverse mass
    a joint counts [1/kg]; :func:`~siku_core.ice_follow.follow_contacts`) and ``arms`` (the
    lever arms ``ri, rj`` [m]): every joint's ``jK``, ``jmeff`` are first computed from them,
    in the same parallel loop (after a process changed the ice). ``dmob`` (per element ``n/m``
    [1/kg], ``n/I`` [1/(kg m²)], ``n`` its contacts; ``None``: the dampers unbounded): the
    bound of the dampers (:mod:`siku_core.damping`, ``g[J_DTM]``)."""
    loops = instantiate(contact_loops, evaluate)
    if fresh is None:
        fresh, arms = _NO_FRESH, (_NO_FRESH, _NO_FRESH)
    if dmob is None:
        dmob = _NO_DMOB
    return loops._joint_forces(pars, rm, V, w, h, E, nu, ji, jj, ends_i, ends_j, L0, width, jK,
                               jmeff, intact, break_mode, hist, R, dt, commit, out, active, nch,
                               tasks(nch), fresh, *arms, dmob)


#: what the joint loop gets for ``fresh`` and the lever arms when its constants are current
_NO_FRESH = np.zeros(0)
#: ... and for ``dmob`` when the dampers are unbounded
_NO_DMOB = np.zeros((0, 2))


def collision_forces(evaluate, pars, rm, V, w, minv, h, E, area, offsets, verts, pairs, R,
                     nmax, pretest, out, active, nch, margin=None, hint=None, drop=False, face=None,
                     scale=None, edges=None, chist=None, commit=False, caps=None,
                     chint=None, dmob=None, dt=0.0):
    """Clip every candidate pair (unless, with ``pretest``, the separating-axis test
    :func:`~siku_core.geometry.clip.separating_edge` finds an edge line that separates or touches
    them) and evaluate the overlapping ones into ``out[k]`` with ``active[k] = 1`` (``0`` for the
    others, ``2`` for a touching overlap dropped under ``drop``: no force either); returns the
    number of overlapping pairs. A pair with ``active[k] = 1`` or ``2`` from the last evaluation
    skips the test (it almost always still overlaps or touches; the clip finds no area where
    the test would have found the pair apart, and no more than the touching area where the
    test with the margin would have).

    ``minv`` (per element, 1/kg): the inverse mass, 0 for a static or steady element (an
    overlapping pair's reduced mass ``1 / (minv_i + minv_j)`` [kg] is computed as it is
    evaluated); ``margin`` (per element ``i``, m; zeros by default): the test's margin;
    ``hint`` (per pair, int16, updated): the edge that separated the pair last, tried first;
    ``drop``: touching
    overlaps (area at most the clip's tolerance) carry no force (``contact.touching =
    "ignore"``, with ``margin = REL_TOL L_i / 3``, so that the test settles such pairs);
    ``face`` (per pair, int16 ``(K, 2)``, ``-1`` for none): the edges of ``i`` and ``j`` the
    pair is jointed along, whose touching overlap :func:`~siku_core.geometry.face.touching_face`
    finds without the clip; ``scale`` (per element, m): its largest absolute vertex coordinate;
    ``edges`` (per vertex row): :func:`~siku_core.geometry.face.edge_table` of ``offsets,
    verts``, the constants of the edge a jointed pair touches along (built here when not given);
    ``chist`` (per pair, float64 ``(K, C)``; ``None`` for a law without per-contact history):
    the pairs' history rows, passed to the evaluator ``evaluate(g, pars, hist, out)`` of an
    overlapping pair and updated from it only when ``commit`` (the rows of the other pairs are
    left as they are: the caller drops them, ``ContactModel``); ``caps`` (per pair, int8;
    ``None``: not kept): 1 where the evaluator capped the normal force (its ``out[3]``, the
    ``ridging`` law's plastic limit), else 0, written where ``active[k] = 1`` (others keep what
    they held); ``chint`` (per pair, int32, updated;
    ``None``: off): the crossing edges each pair's overlap had last, from which the coherent
    clip (:func:`~siku_core.geometry.coherent.overlap_coherent`) computes it again (the same
    results to round-off; where its check fails, the full clip bit for bit); ``dmob`` (as
    :func:`joint_forces`) and the step ``dt`` [s]: the bound of the dampers (``g[G_DTM]``).
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
    if caps is None:
        caps = _NO_CAPS
    history = chist is not None
    if not history:
        chist = _NO_HISTORY
    if chint is None:
        chint = _NO_HINTS
    if dmob is None:
        dmob = _NO_DMOB
    loops = instantiate(contact_loops, evaluate, history)
    return loops._collision_forces(pars, rm, V, w, minv, h, E, area, offsets, verts, pairs, R,
                                   nmax, pretest, out, active, nch, tasks(nch), margin, hint, drop,
                                   face, scale, edges, chist, bool(commit), caps, chint, dmob,
                                   float(dt))


#: what the collision loop gets for ``chist`` under a law without per-contact history (the
#: loop never reads it: ``contact_loops.CHIST`` prunes the branches)
_NO_HISTORY = np.zeros((0, 0))
#: ... and for ``caps`` when no component keeps them
_NO_CAPS = np.zeros(0, dtype=np.int8)
#: ... and for ``chint`` without the coherent clip
_NO_HINTS = np.zeros(0, dtype=np.int32)


def gather_forces(F, T, joff, jidx, jside, jout, joint_active, poff, pidx, pside, pout,
                  pair_active, nch):
    """Add to ``F[e], T[e]`` the contributions of element ``e``'s joints, then of its pairs,
    each in ascending contact index (fixed order: independent of the thread count)."""
    _gather_forces(F, T, joff, jidx, jside, jout, joint_active, poff, pidx, pside, pout,
                   pair_active, nch, tasks(nch))


@njit(cache=True, parallel=True)
def _gather_forces(F, T, joff, jidx, jside, jout, joint_active, poff, pidx, pside, pout,
                   pair_active, nch, nt):
    n = F.shape[0]
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        while True:
            c = claim(counter)
            if c >= nch:
                break
            lo, hi = chunk_bounds(c, nch, n)
            _gather_chunk(F, T, joff, jidx, jside, jout, joint_active, poff, pidx, pside, pout,
                          pair_active, lo, hi)


@njit(cache=True)
def _gather_chunk(F, T, joff, jidx, jside, jout, joint_active, poff, pidx, pside, pout,
                  pair_active, lo, hi):
    """Elements ``lo <= e < hi`` of :func:`gather_forces`."""
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


#: names of the contact-law contract that this module held before siku 0.2.0: the geometry and
#: result layouts, their tables and the break modes (:mod:`siku_core.contact_law` since; a
#: deprecation alias each, :mod:`siku_core.deprecation`)
MOVED_TO_CONTACT_LAW = (
    "G_AREA G_CX G_CY G_NX G_NY G_WIDTH G_K G_MEFF G_VX G_VY G_AREA_I G_AREA_J G_SIZE "
    "J_S1X J_S1Y J_S2X J_S2Y J_AX J_AY J_BX J_BY J_L0 J_W J_K J_MEFF J_VAX J_VAY J_VBX J_VBY "
    "J_HI J_HJ J_EI J_EJ J_NU J_DT J_SIZE COLLISION_LAYOUT JOINT_LAYOUT OUT_LAYOUT layout_table "
    "BREAK_STRAIN BREAK_TENSION BREAK_SHEAR BREAK_COMPRESSION BREAK_EXTERNAL BREAK_FLEXURE "
    "BREAK_MODES").split()
__getattr__ = moved_names(__name__, dict.fromkeys(MOVED_TO_CONTACT_LAW, "siku_core.contact_law"))
