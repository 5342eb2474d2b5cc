"""``ridging``: pressed ice that reached its plastic limit turns overlap into thicker ice and
open water, conserving the ice volume and the area it covers.

With the ``ridging`` contact law, two elements pressed together beyond the plastic limit ``P h
w`` (the law's module docstring) no longer push harder: they overlap further. This process turns
that overlap into ridged ice. For every colliding pair whose normal force the law capped at the
plastic limit in the last evaluation (the law says so: its collision evaluator writes the flag
``out[3]``, which the contact model keeps per pair, ``ctx.contacts.keep_caps``), the growth
``dA`` [m²] of its overlap area, clipped again in the state after the step, beyond the largest
one already converted is closed: the pair's footprints now cover ``dA`` twice, and the ice of
one of them, the giver (the thinner element when the pair is first converted; on equal
thickness, the second of the pair), leaves that area. As in the thickness redistribution of
Thorndike et al. (1975) and Hibler (1980), the closing takes open water first and then ice: of
``dA``, the giver's free open water ``W = A_g (1 - c_g) - S_g`` (``c_g = sum a_k`` its
concentration, ``S_g`` the area of its footprint already ceded under its other remembered
pairs, whose ice left before) closes, and the rest,

    dA_i = dA - min(dA, max(W, 0)),

is ice of the giver's thickness ``h_g`` that ridges onto the other element (the carrier): the
volume ``dV = dA_i h_g`` [m³] moves, the giver's ice area shrinks by ``dA_i`` (its fractions
``a_k`` scale by ``1 - dA_i / (c_g A_g)``, its thicknesses stay) and the carrier's thickest
category ``m`` (the largest ``h_k`` with ``a_k > 0``) thickens,

    a_k -> a_k (v_g - dV / A_g) / v_g   (giver, v_g = sum a_k h_k),
    h_m -> h_m + dV / (a_m A_c)        (carrier),

so the total volume ``sum A sum a_k h_k`` is unchanged (to round-off), the ice area ``sum A
sum a_k`` falls by the area the pack closed (no ice is counted twice, a gridded concentration
stays at most 1), the giver holds open water where its ice ridged, and the ridge is thicker ice
on the carrier, in the outputs and on grids. The ridged ice takes no area of its own: it piles
onto the carrier's ice (the limit of a large ridging ratio ``k``, ridged ice ``k`` times as
thick on ``1/k`` of the area). Ice thinner than the law's ``raft_thickness`` rafts rather than
ridges: the same transfer, counted in ``rafted_volume``. A giver keeps at least
:data:`MIN_COVER` of its area as ice (a concentration that stays a distribution); overlap
beyond that is not converted. Pairs with an element that has melted away are left alone. A
pair that stops overlapping is forgotten (its ceded area is open water in the giver again, and
it starts from zero if it meets again). Elastic overlaps (below the plastic limit) are never
converted.

The process needs a concentration per element (``needs_categories``): a scene whose sources
give no thickness categories gets one per element, all ice (``a = 1``,
:func:`~siku_core.categories.one_category`), which ridging opens.

Declared per-element fields (summed on grids): ``ridged_volume`` and ``rafted_volume`` [m³],
the volume the element has received by ridging and by rafting since the start.

Cost. Only candidates have their overlap clipped again (:func:`ridge_candidates`): the
remembered pairs and the pairs the law capped, in one pass over the colliding pairs that reads
the flags.

References: Thorndike, A. S., Rothrock, D. A., Maykut, G. A., Colony, R. (1975), The thickness
distribution of sea ice, J. Geophys. Res. 80(33), 4501–4513. Hibler, W. D. (1980), Modeling a
variable thickness sea ice cover, Mon. Weather Rev. 108, 1943–1973.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np
from numba import njit, prange

from siku_core.categories import row_mean, row_sum
from siku_core.contact.contact_frames import rotation_row, j_to_i, relative_matrix
from siku_core.errors import SceneError
from siku_core.geometry.clip import make_overlap_scratch, overlap_inline
from siku_core.fields import ElementField
from siku_core.interfaces import Process
from siku_core.run.limits import check_count, most_count
from siku_core.parallel import alone, chunk_bounds, chunks
from siku_core.params import Param
from siku_core.records import record_type
from siku_core.state import MELTED

#: the contact law parameters the process needs (those of the ``ridging`` law)
LAW_KEYS = ("strength", "raft_thickness", "raft_strength")

#: bytes the process holds per remembered pair (keys, converted areas, givers and the
#: kernels' seven scratch arrays)
PAIR_BYTES = 80.0

#: the share of its area an element keeps as ice however far it is overridden [1]: an
#: element's concentration stays positive (a category distribution with no ice is refused)
MIN_COVER = 1e-3


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
    ("giver", "i", 1, "the element of each whose ice the overlap took, -1: not chosen yet"),
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
    ("new_giver", "i", 1, "their givers"),
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
    ("fraction", "f", 2, "category fractions a_k [1], (n, K) (updated)"),
    ("hk", "f", 2, "category thicknesses h_k [m], (n, K) (updated)"),
    ("loss", "f", 1, "scratch per element [m^3], zero"),
    ("gain", "f", 1, "scratch per element [m^3], zero"),
    ("cut", "f", 1, "scratch per element [m^2], zero: ice area taken in this application"),
    ("ceded", "f", 1, "scratch per element [m^2], zero: its footprint under other elements"),
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
    :func:`siku_core.contact.contact_overlaps.pair_overlaps`). ``nch`` chunks, each writing its own
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
    the last evaluation, in place: the categories ``ice.fraction``, ``ice.hk`` ``(n, K)`` and
    ``ice.thickness`` (their mean), ``ice.ridged``, ``ice.rafted`` (:data:`RidgeIce`) and the
    remembered pairs (sorted ``mem.keys``, ``mem.converted``, ``mem.giver``, the first
    ``count``); ice thinner than ``raft_h`` (the law's ``raft_thickness``, m) rafts. Returns
    the number of pairs remembered now, or minus it (and nothing changed) when that exceeds
    ``len(mem.keys)``.

    The pairs are taken in order, each closing first the giver's free open water and then its
    ice (against what earlier pairs of the application took); the transfers apply after them,
    every loss first, then every gain (:func:`_ridge_categories`). ``tr``
    (:data:`RidgeTransfers`, ``len(mem.keys)`` each), ``ice.loss``, ``ice.gain``,
    ``ice.cut``, ``ice.ceded`` (``n``, zero, left zero) and ``ice.row`` (``K``) are
    scratch."""
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
    cut = ice.cut
    ceded = ice.ceded
    scratch = ice.row
    keys = mem.keys
    converted = mem.converted
    mgiver = mem.giver
    new_keys = tr.new_keys
    new_conv = tr.new_conv
    new_giver = tr.new_giver
    giver = tr.giver
    carrier = tr.carrier
    moved = tr.moved
    rafts = tr.rafts
    cap = keys.shape[0]
    n = thickness.shape[0]
    K = fraction.shape[1]
    # the footprint each element cedes to the others: the converted overlaps of its pairs
    for r in range(count):
        if mgiver[r] >= 0:
            ceded[mgiver[r]] += converted[r]
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
        raft = min(h_i, h_j) < raft_h
        # (an element melted in this step by an earlier process still has its pairs here)
        alive = flags[i] != MELTED and flags[j] != MELTED
        plastic = alive and caps[k] != 0
        if not (known or plastic):
            continue
        if m < cap:
            key = min(i, j) * n + max(i, j)
            if m and key < new_keys[m - 1]:
                ordered = False
            g = mgiver[known_at[a]] if known else -1
            if g < 0 and plastic:  # the thinner element gives (equal: j gives)
                g = i if h_i < h_j else j
            new_keys[m] = key
            new_conv[m] = max(done, area_ij if plastic else 0.0)
            new_giver[m] = g
            dA = max(area_ij - done, 0.0) if plastic else 0.0
            if dA > 0.0:
                A = area[g]
                for q in range(K):
                    scratch[q] = fraction[g, q]
                held = row_sum(scratch) * A - cut[g]  # the giver's ice area [m²]
                water = A - held - ceded[g]  # its open water not under other elements
                ceded[g] += dA
                take = dA - min(dA, max(water, 0.0))  # closed water first, then ice
                take = min(take, max(held - MIN_COVER * A, 0.0))
                if take > 0.0:
                    cut[g] += take
                    giver[nt] = g
                    carrier[nt] = j if g == i else i
                    moved[nt] = take * thickness[g]  # its ice has the mean thickness
                    rafts[nt] = raft
                    nt += 1
        m += 1
    for r in range(count):  # the scratch left zero
        if mgiver[r] >= 0:
            ceded[mgiver[r]] = 0.0
    for t in range(min(m, cap)):
        if new_giver[t] >= 0:
            ceded[new_giver[t]] = 0.0
    for t in range(nt):
        cut[giver[t]] = 0.0
    if m > cap:
        return -m
    for t in range(nt):
        if rafts[t]:
            rafted[carrier[t]] += moved[t]
        else:
            ridged[carrier[t]] += moved[t]
    _ridge_categories(tr, nt, ice)
    if not ordered:
        order = np.argsort(new_keys[:m])
        new_keys[:m] = new_keys[:m][order]
        new_conv[:m] = new_conv[:m][order]
        new_giver[:m] = new_giver[:m][order]
    keys[:m] = new_keys[:m]
    converted[:m] = new_conv[:m]
    mgiver[:m] = new_giver[:m]
    keys[m:count] = -1
    converted[m:count] = 0.0
    mgiver[m:count] = -1
    return m


@njit(cache=True)
def _ridge_categories(tr, nt, ice):
    """The categories of the elements of the first ``nt`` transfers ``tr`` (module docstring;
    ``ice``: :data:`RidgeIce`): a giver's ice area shrinks in proportion, ``a_k *= (v - L / A)
    / v`` (``L`` [m³] all it gave, ``v = sum a_k h_k``; its thicknesses unchanged: open water
    takes the place of the ice that ridged), a carrier's gain ``G`` [m³] piles onto its
    thickest category ``m`` (the largest ``h_k`` with ``a_k > 0``), ``h_m += G / (a_m A)``, so
    that the element's volume ``A sum(a_k h_k)`` changes by exactly ``G - L``. The thickness
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
                a[k] *= r
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
    """Overlap of ice pressed beyond its plastic limit becomes ridged (or rafted) ice on the
    carrier and open water in the giver."""

    name = "ridging"
    #: on ranks: each rank ridges the pairs of the elements it holds (an owned element has all
    #: its pairs there); the remembered pairs go between ranks by their elements' identities
    runs_on_ranks = True
    reads_contacts = True
    rank_history: ClassVar[dict[str, str]] = {"keys": "pair_keys", "converted": "pair_rows",
                                              "givers": "pair_elements", "count": "pair_count"}
    conserves = ("volume",)
    needs_categories = True  # the ice area an element loses to a ridge becomes open water
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
        # keys, converted areas, givers and the kernels' seven scratch arrays: 80 bytes per pair
        check_count(ctx.where(self.table), "capacity", self.p["capacity"], PAIR_BYTES, st.n,
                    " of pairs remembered")
        n = st.n * int(self.p["capacity"])
        #: pairs being converted: sorted keys (min * N + max) and the overlap area already
        #: converted [m²]; -1 / 0 beyond ``self.count``
        self.keys = np.full(n, -1, dtype=np.int64)
        self.converted = np.zeros(n)
        self.givers = np.full(n, -1, dtype=np.int64)
        self.count = 0
        self.raft_h = float(self.law["raft_thickness"])
        cm.keep_caps()  # whether the law capped each pair, for ridge_candidates and ridge_pairs
        # the kernels' scratch, allocated once (the per-pair ones grow with the pairs)
        self._rm = np.empty((st.n, 3, 3))
        self._row = None
        self._nmax = int(np.max(np.diff(st.vert_offsets))) if st.n else 3
        self._geo = np.empty(0)
        self._mark = np.empty(0, dtype=np.int64)
        self._cand = np.empty(0, dtype=np.int64)
        self._known_at = np.empty(0, dtype=np.int64)
        self._per_element = [np.zeros(st.n) for _ in range(4)]  # loss, gain, cut, ceded
        self._scratch = RidgeTransfers(
            new_keys=np.empty(n, dtype=np.int64), new_conv=np.empty(n),
            new_giver=np.empty(n, dtype=np.int64), giver=np.empty(n, dtype=np.int64),
            carrier=np.empty(n, dtype=np.int64), moved=np.empty(n),
            rafts=np.empty(n, dtype=np.bool_))

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
        mem = RidgeMemory(keys=self.keys, converted=self.converted, giver=self.givers)
        cd = RidgeCandidates(cand=self._cand, known_at=self._known_at, geo=self._geo,
                             mark=self._mark)
        nc = ridge_candidates(cp, mem, self.count, st.flags, st.q, self._rm, cd)
        if nc:
            nch = chunks(nc)
            with alone(nch):
                pair_geometry(self._rm, st.vert_offsets, st.verts, cm.pairs, self._cand, nc,
                              float(ctx.radius), self._nmax, self._geo, nch)
        cats = ctx.categories
        if self._row is None or len(self._row) != cats.K:
            self._row = np.empty(cats.K)
        loss, gain, cut, ceded = self._per_element
        ice = RidgeIce(thickness=st.thickness, area=st.area, flags=st.flags,
                       ridged=ctx.fields["ridged_volume"], rafted=ctx.fields["rafted_volume"],
                       fraction=cats.fraction, hk=cats.thickness, loss=loss, gain=gain,
                       cut=cut, ceded=ceded, row=self._row)
        m = ridge_pairs(cp, cd, nc, ice, self.raft_h, mem, self.count, self._scratch)
        if m < 0:
            raise SceneError(f"{ctx.where(self.table)}: more than {len(self.keys)} ridging pairs; "
                             "raise the process's capacity" + most_count(PAIR_BYTES, st.n))
        self.count = m

    def _forget_all(self) -> None:
        """No colliding pairs: every remembered pair is forgotten."""
        self.keys[:self.count] = -1
        self.converted[:self.count] = 0.0
        self.givers[:self.count] = -1
        self.count = 0

    def history(self):
        return {"keys": self.keys.copy(), "converted": self.converted.copy(),
                "givers": self.givers.copy(), "count": np.array(self.count)}

    def set_history(self, arrays) -> None:
        self.keys[:] = arrays["keys"]
        self.converted[:] = arrays["converted"]
        # (a file written before the givers were kept: each pair's giver is chosen again)
        self.givers[:] = arrays["givers"] if "givers" in arrays else -1
        self.count = int(arrays["count"])
