"""``ridging``: pressed ice that reached its plastic limit turns overlap into thicker ice.

With the ``ridging`` contact law, two elements pressed together beyond the plastic limit ``P h
w`` (the law's module docstring) no longer push harder: they overlap further. This process turns
that overlap into ridged ice. For every colliding pair whose contact force is at the plastic
limit (to 1e-6), the growth ``dA`` [m²] of its overlap area beyond the largest one already
converted is ice of the thinner element (thickness ``h_t``) piled onto the thicker one (the
carrier; on equal thickness, the second of the pair): the volume ``dV = dA h_t`` [m³] moves from
the thinner element to the carrier,

    h_t -= dV / A_t,    h_c += dV / A_c,

so the total volume ``sum(A h)`` is unchanged (to round-off) and the ridge shows up as thicker
ice on the carrier, in the outputs and on grids. Ice thinner than the law's ``raft_thickness``
rafts rather than ridges: the same transfer, counted in ``rafted_volume``. Pairs with an
element that has melted away are left alone. A pair that stops overlapping is forgotten (it
starts from zero if it meets again). Elastic overlaps (below the plastic limit) are never
converted.

Declared per-element fields (summed on grids): ``ridged_volume`` and ``rafted_volume`` [m³],
the volume the element has received by ridging and by rafting since the start.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from siku_core.contact_overlaps import overlaps
from siku_core.errors import SceneError
from siku_core.ice import ElementField
from siku_core.interfaces import Process
from siku_core.params import Param
from siku_core.state import MELTED

#: the contact law parameters the process needs (those of the ``ridging`` law)
LAW_KEYS = ("strength", "raft_thickness", "raft_strength")


class Ridging(Process):
    """Overlap of ice pressed beyond its plastic limit becomes ridged (or rafted) ice."""

    name = "ridging"
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
        law = getattr(cm, "law", None)
        if law is None or not all(k in law.p for k in LAW_KEYS):
            raise SceneError(f"{ctx.where(self.table)}: process 'ridging' needs the contact law "
                             "'ridging' (its plastic limit); set [contact] law = \"ridging\"")
        self.law = law.p
        n = ctx.state.n * int(self.p["capacity"])
        #: pairs being converted: sorted keys (min * N + max) and the overlap area already
        #: converted [m²]; -1 / 0 beyond ``self.count``
        self.keys = np.full(n, -1, dtype=np.int64)
        self.converted = np.zeros(n)
        self.count = 0

    def apply(self, ctx, dt: float) -> None:
        if dt <= 0.0:
            return
        st = ctx.state
        pairs, area, width, force = overlaps(ctx.contacts)
        i, j = pairs[:, 0], pairs[:, 1]
        hi, hj = st.thickness[i], st.thickness[j]
        ht = np.minimum(hi, hj)
        law = self.law
        raft = ht < law["raft_thickness"]
        P = np.where(raft, law["raft_strength"], law["strength"])
        # (an element melted in this step by an earlier process still has its pairs here)
        alive = (st.flags[i] != MELTED) & (st.flags[j] != MELTED)
        plastic = alive & (area > 0) & (force >= (1.0 - 1e-6) * P * ht * width)
        keys = np.minimum(i, j).astype(np.int64) * st.n + np.maximum(i, j)
        old = self.keys[:self.count]
        at = np.searchsorted(old, keys)
        at = np.minimum(at, max(self.count - 1, 0))
        known = (self.count > 0) & (old[at] == keys) if self.count else np.zeros(len(keys), bool)
        done = np.where(known, self.converted[:self.count][at] if self.count else 0.0, 0.0)
        dA = np.where(plastic, np.maximum(area - done, 0.0), 0.0)
        keep = (area > 0) & (known | plastic)
        if keep.sum() > len(self.keys):
            raise SceneError(f"{ctx.where(self.table)}: more than {len(self.keys)} ridging pairs; "
                             "raise the process's capacity")
        # the thinner element gives, the thicker carries (equal: j carries)
        thin = np.where(hi < hj, i, j)
        carrier = np.where(hi < hj, j, i)
        dV = dA * ht
        take = dV > 0
        if take.any():
            np.subtract.at(st.thickness, thin[take], dV[take] / st.area[thin[take]])
            np.add.at(st.thickness, carrier[take], dV[take] / st.area[carrier[take]])
            r = take & ~raft
            f = take & raft
            np.add.at(ctx.fields["ridged_volume"], carrier[r], dV[r])
            np.add.at(ctx.fields["rafted_volume"], carrier[f], dV[f])
        order = np.argsort(keys[keep], kind="stable")
        m = int(keep.sum())
        self.keys[:m] = keys[keep][order]
        self.converted[:m] = np.maximum(done, np.where(plastic, area, 0.0))[keep][order]
        self.keys[m:self.count] = -1
        self.converted[m:self.count] = 0.0
        self.count = m

    def history(self):
        return {"keys": self.keys.copy(), "converted": self.converted.copy(),
                "count": np.array(self.count)}

    def set_history(self, arrays) -> None:
        self.keys[:] = arrays["keys"]
        self.converted[:] = arrays["converted"]
        self.count = int(arrays["count"])
