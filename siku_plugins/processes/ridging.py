"""``ridging``: pressed ice that reached its plastic limit turns overlap into thicker ice.

With the ``ridging`` contact law, two elements pressed together beyond the plastic limit ``P h
w`` (the law's module docstring) no longer push harder: they overlap further. This process turns
that overlap into ridged ice. For every colliding pair whose normal force the law capped at the
plastic limit in the last evaluation (the law says so: its collision evaluator writes the flag
``out[3]``, which the contact model keeps per pair, ``ctx.contacts.keep_caps``), the growth
``dA`` [m²] of its overlap area, clipped again in the state after the step, beyond the largest
one already converted is ice of the thinner element (thickness ``h_t``) piled onto the thicker
one (the carrier; on equal thickness, the second of the pair): the volume ``dV = dA h_t`` [m³]
moves from the thinner element to the carrier,

    h_t -= dV / A_t,    h_c += dV / A_c,

so the total volume ``sum(A h)`` is unchanged (to round-off) and the ridge shows up as thicker
ice on the carrier, in the outputs and on grids. Ice thinner than the law's ``raft_thickness``
rafts rather than ridges: the same transfer, counted in ``rafted_volume``. Pairs with an
element that has melted away are left alone. A pair that stops overlapping is forgotten (it
starts from zero if it meets again). Elastic overlaps (below the plastic limit) are never
converted.

With thickness categories (``ctx.categories``, :mod:`siku_core.categories`) an element's ice
volume is ``A sum(a_k h_k)`` (:func:`~siku_core.categories.element_volume`), so the overlap
``dA`` of the giver holds ``dV = dA v_t``, ``v_t = sum a_k h_k`` its ice per area (its
concentration times ``h_t``; the thinner element is still the one of smaller mean thickness
``h_t``). The carrier's gain piles onto its thickest category ``m`` (the largest ``h_k`` with
``a_k > 0``), ``h_m += dV / (a_m A_c)``, and the giver's ice thins as a whole, every ``h_k`` by
the factor ``(v_t - dV / A_t) / v_t``; the fractions do not change and each element volume
changes by exactly ``dV``.

Declared per-element fields (summed on grids): ``ridged_volume`` and ``rafted_volume`` [m³],
the volume the element has received by ridging and by rafting since the start.

Cost. Only candidates have their overlap clipped again (:func:`ridge_candidates`): the
remembered pairs and the pairs the law capped, in one pass over the colliding pairs that reads
the flags.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np
from numba import njit, prange

from siku_core.categories import row_mean, row_sum
from siku_core.contact_frames import rotation_row, j_to_i, relative_matrix
from siku_core.errors import SceneError
from siku_core.geometry.clip import make_overlap_scratch, overlap_inline
from siku_core.fields import ElementField
from siku_core.interfaces import Process
from siku_core.limits import check_count, most_count
from siku_core.parallel import alone, chunk_bounds, chunks
from siku_core.params import Param
from siku_core.records import record_type
from siku_core.state import MELTED

#: the contact law parameters the process needs (those of the ``ridging`` law)
LAW_KEYS = ("strength", "raft_thickness", "raft_strength")


#: the contact model's candidate pairs as the process reads them (:meth:`Ridging.apply`)
RidgeContacts = record_type("RidgeContacts", __name__, [
    ("pairs", "i", 2, "the candidate pairs (i, j)"),
    ("active", "i", 1, "1 where the pair overlapped at the last evaluation"),
    ("caps", "i", 1, "1 where the law capped the pair's normal force at the plastic limit"),
    ("poff", "i", 1, "element e's pairs are pidx[poff[e]:poff[e+1]]"),
    ("pidx", "i", 1, "pair of each entry"),
], "The candidate pairs the ridging kernels read.")

#: the pairs the process remembers (:class:`Ridging`, their producer)
RidgeMemory = record_type("RidgeMemory", __name__, [
    ("keys", "i", 1, "sorted pair keys min(i, j) N + max(i, j), -1 beyond the count"),
    ("converted", "f", 1, "overlap area of each already converted [m^2]"),
], "The pairs being converted.")

#: the candidates of one application (:class:`Ridging`, their producer; one entry per pair)
RidgeCandidates = record_type("RidgeCandidates", __name__, [
    ("cand", "i", 1, "the candidate pairs, first ones"),
    ("known_at", "i", 1, "each candidate's place among the remembered pairs, -1: none"),
    ("geo", "f", 1, "each candidate's overlap area [m^2] (pair_geometry)"),
    ("mark", "i", 1, "scratch, -1 between calls"),
], "The candidates of one application of ridging.")

#: the volume transfers of one application (scratch, one entry per remembered pair)
RidgeTransfers = record_type("RidgeTransfers", __name__, [
    ("new_keys", "i", 1, "the keys remembered from now on"),
    ("new_conv", "f", 1, "their converted areas [m^2]"),
    ("giver", "i", 1, "element giving ice in each transfer"),
    ("carrier", "i", 1, "element receiving it"),
    ("moved", "f", 1, "volume moved [m^3]"),
    ("rafts", "b", 1, "whether the transfer rafts (else ridges)"),
], "The ridging kernels' scratch of volume transfers.")

#: the ice the process changes (:meth:`Ridging.apply`, their producer)
RidgeIce = record_type("RidgeIce", __name__, [
    ("thickness", "f", 1, "thickness [m] (updated)"),
    ("area", "f", 1, "area [m^2]"),
    ("flags", "i", 1, "element flags (siku_core.state)"),
    ("ridged", "f", 1, "ice volume received by ridging [m^3] (updated)"),
    ("rafted", "f", 1, "ice volume received by rafting [m^3] (updated)"),
    ("fraction", "f", 2, "category fractions a_k [1], (n, K); K = 0: no categories"),
    ("hk", "f", 2, "category thicknesses h_k [m], (n, K) (updated)"),
    ("loss", "f", 1, "scratch per element [m^3], zero (empty without categories)"),
    ("gain", "f", 1, "scratch per element [m^3], zero (empty without categories)"),
    ("row", "f", 1, "scratch, one category row (K)"),
], "The per-element data ridging reads and changes.")


@njit(cache=True)
def ridge_candidates(cp, mem, count, flags, q, rm, cd):
    """The colliding pairs (``cp.active[k] == 1``; ``cp``: :data:`RidgeContacts`) the process
    looks at, in ascending ``k``, into ``cd.cand`` (``cd``: :data:`RidgeCandidates`): the
    remembered ones (their place in the first ``count`` sorted ``mem.keys`` goes to
    ``cd.known_at``, -1 for the others, found through the element-to-pair index ``cp.poff,
    cp.pidx``) and those without a melted element (``flags``) whose normal force the law
    capped at the plastic limit in the last evaluation (``cp.caps[k] == 1``, kept by the
    contact model: ``ctx.contacts.keep_caps``); their elements' rotation matrices ``rm`` from
    ``q``. ``cd.mark`` (one per pair, -1) is scratch, left -1. Returns the number of
    candidates."""
    pairs = cp.pairs
    active = cp.active
    caps = cp.caps
    poff = cp.poff
    pidx = cp.pidx
    keys = mem.keys
    mark = cd.mark
    cand = cd.cand
    known_at = cd.known_at
    n = flags.shape[0]
    for r in range(count):
        i = keys[r] // n
        j = keys[r] % n
        for s in range(poff[i], poff[i + 1]):
            k = pidx[s]
            if (pairs[k, 0] == i and pairs[k, 1] == j) or (pairs[k, 0] == j and pairs[k, 1] == i):
                mark[k] = r
                break
    nc = 0
    for k in range(pairs.shape[0]):
        r = mark[k]
        if r >= 0:
            mark[k] = -1
        if active[k] != 1:
            continue
        i = pairs[k, 0]
        j = pairs[k, 1]
        if r < 0 and (caps[k] == 0 or flags[i] == MELTED or flags[j] == MELTED):
            continue  # neither remembered nor plastic: nothing to do
        cand[nc] = k
        known_at[nc] = r
        nc += 1
        rotation_row(q, rm, i)
        rotation_row(q, rm, j)
    return nc


@njit(cache=True, parallel=True)
def pair_geometry(rm, offsets, verts, pairs, cand, nc, R, nmax, geo, nch):
    """Per candidate ``a < nc`` (pair ``cand[a]``): ``geo[a]``, its overlap area [m²] for the
    rotation matrices ``rm``, by the contact loop's own functions (as
    :func:`siku_core.contact_overlaps.pair_overlaps`). ``nch`` chunks, each writing its own
    rows."""
    inv_r = 1.0 / R
    for c in prange(nch):
        lo_a, hi_a = chunk_bounds(c, nch, nc)
        xy, tag = make_overlap_scratch(nmax, nmax)
        proj = np.empty((nmax, 2))
        for a in range(lo_a, hi_a):
            k = cand[a]
            i = pairs[k, 0]
            j = pairs[k, 1]
            M = relative_matrix(rm, i, j)
            oj = offsets[j]
            nj = offsets[j + 1] - oj
            for v in range(nj):
                proj[v, 0], proj[v, 1] = j_to_i(M, verts[oj + v, 0], verts[oj + v, 1], R,
                                                inv_r)
            pi = verts[offsets[i]:offsets[i + 1]]
            c2x, c2y = j_to_i(M, 0.0, 0.0, R, inv_r)
            geo[a] = overlap_inline(pi, proj[:nj], xy, tag, c2x, c2y, False)[0]


@njit(cache=True)
def ridge_pairs(cp, cd, nc, ice, raft_h, mem, count, tr):
    """One application of the process (module docstring) to the candidate pairs
    ``cd.cand[:nc]`` of the contact model ``cp`` (:func:`ridge_candidates`; ``cd.known_at``:
    their place among the remembered ones or -1), their overlap areas in ``cd.geo``
    (:func:`pair_geometry`), ``cp.caps`` whether the law capped each pair's normal force in
    the last evaluation, in place: ``ice.thickness``, ``ice.ridged``, ``ice.rafted``
    (:data:`RidgeIce`) and the remembered pairs (sorted ``mem.keys``, ``mem.converted``, the
    first ``count``); ice thinner than ``raft_h`` (the law's ``raft_thickness``, m) rafts.
    Returns the number of pairs remembered now, or minus it (and nothing changed) when that
    exceeds ``len(mem.keys)``.

    The transfers apply in pair order, every loss first, then every gain (the order of the
    former ``np.subtract.at`` and ``np.add.at``). With thickness categories (``ice.fraction``,
    ``ice.hk`` ``(n, K)``; ``K = 0``: none) each element that gave or carried has its
    categories changed by :func:`_ridge_categories`. ``tr`` (:data:`RidgeTransfers`,
    ``len(mem.keys)`` each), ``ice.loss``, ``ice.gain`` (``n``, zero) and ``ice.row`` (``K``)
    are scratch."""
    pairs = cp.pairs
    caps = cp.caps
    cand = cd.cand
    known_at = cd.known_at
    geo = cd.geo
    thickness = ice.thickness
    area = ice.area
    flags = ice.flags
    ridged = ice.ridged
    rafted = ice.rafted
    fraction = ice.fraction
    hk = ice.hk
    scratch = ice.row
    keys = mem.keys
    converted = mem.converted
    new_keys = tr.new_keys
    new_conv = tr.new_conv
    giver = tr.giver
    carrier = tr.carrier
    moved = tr.moved
    rafts = tr.rafts
    cap = keys.shape[0]
    n = thickness.shape[0]
    m = 0  # pairs remembered from now on
    nt = 0  # volume transfers (each by a remembered pair)
    ordered = True
    for a in range(nc):
        area_ij = geo[a]
        if not area_ij > 0.0:
            continue  # no longer overlapping (forgotten)
        k = cand[a]
        i = pairs[k, 0]
        j = pairs[k, 1]
        known = known_at[a] >= 0
        done = converted[known_at[a]] if known else 0.0
        h_i = thickness[i]
        h_j = thickness[j]
        ht = min(h_i, h_j)
        raft = ht < raft_h
        # (an element melted in this step by an earlier process still has its pairs here)
        alive = flags[i] != MELTED and flags[j] != MELTED
        plastic = alive and caps[k] != 0
        if not (known or plastic):
            continue
        if m < cap:
            key = min(i, j) * n + max(i, j)
            if m and key < new_keys[m - 1]:
                ordered = False
            new_keys[m] = key
            new_conv[m] = max(done, area_ij if plastic else 0.0)
            dV = max(area_ij - done, 0.0) * ht if plastic else 0.0
            if dV > 0.0 and hk.shape[1]:  # the giver's ice per area, sum a_k h_k
                g = i if h_i < h_j else j
                for q in range(hk.shape[1]):
                    scratch[q] = fraction[g, q] * hk[g, q]
                dV = max(area_ij - done, 0.0) * row_sum(scratch)
            if dV > 0.0:
                # the thinner element gives, the thicker carries (equal: j carries)
                giver[nt] = i if h_i < h_j else j
                carrier[nt] = j if h_i < h_j else i
                moved[nt] = dV
                rafts[nt] = raft
                nt += 1
        m += 1
    if m > cap:
        return -m
    for t in range(nt):
        g = giver[t]
        thickness[g] = thickness[g] - moved[t] / area[g]
    for t in range(nt):
        c = carrier[t]
        thickness[c] = thickness[c] + moved[t] / area[c]
    for t in range(nt):
        if rafts[t]:
            rafted[carrier[t]] += moved[t]
        else:
            ridged[carrier[t]] += moved[t]
    if hk.shape[1]:
        _ridge_categories(tr, nt, ice)
    if not ordered:
        order = np.argsort(new_keys[:m])
        new_keys[:m] = new_keys[:m][order]
        new_conv[:m] = new_conv[:m][order]
    keys[:m] = new_keys[:m]
    converted[:m] = new_conv[:m]
    keys[m:count] = -1
    converted[m:count] = 0.0
    return m


@njit(cache=True)
def _ridge_categories(tr, nt, ice):
    """The categories of the elements of the first ``nt`` transfers ``tr`` (module docstring;
    ``ice``: :data:`RidgeIce`): a
    giver's ice thins in proportion, ``h_k *= (v - L / A) / v`` (``L`` [m³] all it gave, ``v =
    sum a_k h_k``), a carrier's gain ``G`` [m³] piles onto its thickest category ``m`` (the
    largest ``h_k`` with ``a_k > 0``), ``h_m += G / (a_m A)``, so that the element's volume
    ``A sum(a_k h_k)`` changes by exactly ``G - L``; the fractions do not change. The thickness
    becomes the categories' mean. ``ice.loss``, ``ice.gain`` are left zero."""
    giver = tr.giver
    carrier = tr.carrier
    moved = tr.moved
    thickness = ice.thickness
    area = ice.area
    fraction = ice.fraction
    hk = ice.hk
    loss = ice.loss
    gain = ice.gain
    scratch = ice.row
    for t in range(nt):
        loss[giver[t]] += moved[t]
        gain[carrier[t]] += moved[t]
    for t in range(2 * nt):
        e = giver[t] if t < nt else carrier[t - nt]
        if loss[e] == 0.0 and gain[e] == 0.0:
            continue  # done already
        a = fraction[e]
        h = hk[e]
        if loss[e] > 0.0:
            for k in range(h.shape[0]):
                scratch[k] = a[k] * h[k]
            v0 = row_sum(scratch)
            r = (v0 - loss[e] / area[e]) / v0
            for k in range(h.shape[0]):
                h[k] *= r
        if gain[e] > 0.0:
            m = -1
            for k in range(h.shape[0]):
                if a[k] > 0.0 and (m < 0 or h[k] >= h[m]):
                    m = k
            h[m] += gain[e] / (a[m] * area[e])
        thickness[e] = row_mean(a, h, scratch)
        loss[e] = 0.0
        gain[e] = 0.0


class Ridging(Process):
    """Overlap of ice pressed beyond its plastic limit becomes ridged (or rafted) ice."""

    name = "ridging"
    #: its remembered pairs (by element index) and the ghosts' new thickness would have to
    #: move between ranks
    ranks_refusal = ("it remembers its ridging pairs from step to step by element index and "
                     "changes both elements of each, which ranks do not carry between them")
    conserves = ("volume",)
    params: ClassVar[dict[str, Param]] = {
        "capacity": Param(8, "1", "pairs remembered per element (a fault names it if a pack "
                          "needs more)", type=int, min=1),
    }
    owned_fields = (
        ElementField("ridged_volume", "m3", "ice volume received by ridging since the start",
                     grid="sum"),
        ElementField("rafted_volume", "m3", "ice volume received by rafting since the start",
                     grid="sum"),
    )

    def setup(self, ctx) -> None:
        cm = ctx.contacts
        law = cm.law_params if cm is not None else None
        if law is None or not all(k in law for k in LAW_KEYS):
            raise SceneError(f"{ctx.where(self.table)}: process 'ridging' needs the contact law "
                             "'ridging' (its plastic limit); set [contact] law = \"ridging\"")
        self.law = law
        st = ctx.state
        # keys, converted areas and the kernels' six scratch arrays: 64 bytes per pair
        check_count(ctx.where(self.table), "capacity", self.p["capacity"], 64.0, st.n,
                    " of pairs remembered")
        n = st.n * int(self.p["capacity"])
        #: pairs being converted: sorted keys (min * N + max) and the overlap area already
        #: converted [m²]; -1 / 0 beyond ``self.count``
        self.keys = np.full(n, -1, dtype=np.int64)
        self.converted = np.zeros(n)
        self.count = 0
        self.raft_h = float(self.law["raft_thickness"])
        cm.keep_caps()  # whether the law capped each pair, for ridge_candidates and ridge_pairs
        # the kernels' scratch, allocated once (the per-pair ones grow with the pairs)
        self._rm = np.empty((st.n, 3, 3))
        self._nmax = int(np.max(np.diff(st.vert_offsets))) if st.n else 3
        self._geo = np.empty(0)
        self._mark = np.empty(0, dtype=np.int64)
        self._cand = np.empty(0, dtype=np.int64)
        self._known_at = np.empty(0, dtype=np.int64)
        self._none = np.zeros((st.n, 0))
        self._empty = np.zeros(0)
        self._loss = self._gain = self._row = None
        self._scratch = RidgeTransfers(
            new_keys=np.empty(n, dtype=np.int64), new_conv=np.empty(n),
            giver=np.empty(n, dtype=np.int64), carrier=np.empty(n, dtype=np.int64),
            moved=np.empty(n), rafts=np.empty(n, dtype=np.bool_))

    def apply(self, ctx, dt: float) -> None:
        if dt <= 0.0:
            return
        st, cm = ctx.state, ctx.contacts
        npairs = len(cm.pairs)
        if len(cm.pair_active) != npairs:
            return self._forget_all()
        if len(self._mark) < npairs:  # grown with the candidate list, never per step
            size = npairs + npairs // 2
            self._geo = np.empty(size)
            self._mark = np.full(size, -1, dtype=np.int64)
            self._cand = np.empty(size, dtype=np.int64)
            self._known_at = np.empty(size, dtype=np.int64)
        cp = RidgeContacts(pairs=cm.pairs, active=cm.pair_active, caps=cm.pair_capped,
                           poff=cm.pair_offsets, pidx=cm.pair_index)
        mem = RidgeMemory(keys=self.keys, converted=self.converted)
        cd = RidgeCandidates(cand=self._cand, known_at=self._known_at, geo=self._geo,
                             mark=self._mark)
        nc = ridge_candidates(cp, mem, self.count, st.flags, st.q, self._rm, cd)
        if nc:
            nch = chunks(nc)
            with alone(nch):
                pair_geometry(self._rm, st.vert_offsets, st.verts, cm.pairs, self._cand, nc,
                              float(ctx.radius), self._nmax, self._geo, nch)
        fraction, hk, loss, gain, row = self._categories(ctx)
        ice = RidgeIce(thickness=st.thickness, area=st.area, flags=st.flags,
                       ridged=ctx.fields["ridged_volume"], rafted=ctx.fields["rafted_volume"],
                       fraction=fraction, hk=hk, loss=loss, gain=gain, row=row)
        m = ridge_pairs(cp, cd, nc, ice, self.raft_h, mem, self.count, self._scratch)
        if m < 0:
            raise SceneError(f"{ctx.where(self.table)}: more than {len(self.keys)} ridging pairs; "
                             "raise the process's capacity" + most_count(64.0, st.n))
        self.count = m

    def _categories(self, ctx) -> tuple:
        """The kernel's category arguments: fractions, thicknesses and scratch."""
        cats = ctx.categories
        if cats is None:
            return self._none, self._none, self._empty, self._empty, self._empty
        if self._loss is None:
            n = ctx.state.n
            self._loss, self._gain, self._row = np.zeros(n), np.zeros(n), np.empty(cats.K)
        return cats.fraction, cats.thickness, self._loss, self._gain, self._row

    def _forget_all(self) -> None:
        """No colliding pairs: every remembered pair is forgotten."""
        self.keys[:self.count] = -1
        self.converted[:self.count] = 0.0
        self.count = 0

    def history(self):
        return {"keys": self.keys.copy(), "converted": self.converted.copy(),
                "count": np.array(self.count)}

    def set_history(self, arrays) -> None:
        self.keys[:] = arrays["keys"]
        self.converted[:] = arrays["converted"]
        self.count = int(arrays["count"])
