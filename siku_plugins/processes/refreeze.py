"""``refreeze``: broken joints whose two sides stay together freeze again.

A broken joint is *closed* while the two copies of each of its ends (one on each element) are
within ``gap`` [m] of each other. A joint closed without a break for ``freeze_time`` [s]
refreezes: it holds again from the next force evaluation, at rest where its two sides are
(``ctx.contacts.refreeze_joints``), under the scene's contact law. New ice in a lead thickens as
the square root of time (Stefan's law), so the refrozen joint's tensile strength grows the same
way until it reaches the intact ice's:

    sigma_r(tau) = strength * min(1, sqrt(tau / strength_time))

``tau`` [s] the time since it refroze (or was made by ``weld``, below). While ``tau <
strength_time`` the process breaks a refrozen joint (mode ``tension``) whose normal traction
(opening positive, force over joint length and the thinner side's thickness,
``ctx.contacts.joint_tension``) exceeds ``sigma_r(tau)``; from then on only the contact law's
own strength holds it. Checked every time the process runs, so its timing resolution is the
process's ``every`` (one step by default).

With ``weld = true`` floes that touch and stay together freeze into one as well: two elements
without a joint between them (neither intact nor broken: a broken one is the refreezing's) that
carried a contact force at every check for ``weld_time`` [s] are joined by a new joint
(``ctx.contacts.create_joints``) under the scene's joint contact law, at rest where they are,
along the line where their outlines cross (``ctx.contacts.contact_lines``), with the same
strength growth as a refrozen joint. A pair that parts forgets its time. The run reserves
``weld_capacity`` new joints per element at set-up (none without ``weld``); a run that needs
more stops in one line naming ``weld_capacity``, and one with more than ``weld_pairs`` touching
pairs per element followed at once names ``weld_pairs``.

On MPI ranks each rank decides for the joints and touching pairs of the elements it holds,
from their two elements alone, and the engine numbers the joints it welds in the run's joint
table as one rank does (``docs/explanation/scaling_out.md``): the same bits on any number of
ranks.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from siku_core.contact_law import BreakMode
from siku_core.errors import SceneError
from siku_core.interfaces import Process
from siku_core.run.limits import BYTES_PER_JOINT, check_count, most_count
from siku_core.params import Param
from siku_core.state import MELTED


def refrozen_strength(tau, strength: float, strength_time: float):
    """Tensile strength [Pa] of a joint refrozen ``tau`` [s] ago (module docstring)."""
    return strength * np.minimum(1.0, np.sqrt(np.maximum(tau, 0.0) / strength_time))


class Refreeze(Process):
    """Broken joints that stay closed refreeze, their strength growing with time.

    A joint whose sides stay within ``gap`` for ``freeze_time`` holds again; its strength grows
    as the square root of the time frozen (module docstring)."""

    name = "refreeze"
    #: on ranks: each rank decides for the joints and pairs it holds, from their two elements
    #: alone, and numbers the joints it welds as the engine does (``create_joints``); the
    #: counts add what ``refreeze_joints`` returns and what ``n_reported`` counts of the new
    #: joints (on ranks: the joints a rank reports); the pairs followed (with ``weld``) go
    #: between the ranks by their elements' identities
    runs_on_ranks = True
    reads_contacts = True
    rank_history: ClassVar[dict[str, str]] = {"closed_since": "joint", "refrozen_at": "joint",
                                              "refrozen_total": "total", "keys": "pair_keys",
                                              "since": "pair_times", "count": "pair_count",
                                              "welded_total": "total"}
    params: ClassVar[dict[str, Param]] = {
        "gap": Param(1.0, "m", "largest distance between the two sides of a broken joint that "
                     "counts as closed", min=0.0),
        "freeze_time": Param(86400.0, "s", "time a broken joint must stay closed to refreeze",
                             min=0.0),
        "strength": Param(5e5, "Pa", "tensile strength of a fully refrozen joint", min=0.0),
        "strength_time": Param(864000.0, "s", "time a refrozen joint takes to reach full "
                               "strength", min=1e-9),
        "weld": Param(False, "1", "elements that stay in contact freeze into a new joint",
                      type=bool),
        "weld_time": Param(86400.0, "s", "time two elements must stay in contact to weld",
                           min=0.0),
        "weld_capacity": Param(1.0, "1", "new joints the run may make, per element (slots "
                               "reserved at set-up)", min=0.0),
        "weld_pairs": Param(8, "1", "touching pairs followed at once, per element", type=int,
                            min=1),
    }

    def joints_to_create(self, n_elements: int) -> int:
        where = f"[{self.table}] process 'refreeze'" if self.table else "process 'refreeze'"
        if self.p["weld"]:
            check_count(where, "weld_capacity", self.p["weld_capacity"], BYTES_PER_JOINT,
                        n_elements, " of joint slots")
        return math.ceil(self.p["weld_capacity"] * n_elements) if self.p["weld"] else 0

    def setup(self, ctx) -> None:
        self.ctx = ctx
        cm = ctx.contacts
        if self.p["weld"] and (cm is None or not cm.law_uses_joints):
            raise SceneError(f"{ctx.where(self.table)}: process 'refreeze' with weld = true "
                             "needs a contact law with joints (distributed_spring, "
                             "mohr_coulomb)")
        n = cm.joint_slots if cm is not None else 0
        #: with ``weld``: the touching pairs followed, as sorted keys (min * N + max) and the
        #: model time since which they touch [s]; -1 / NaN beyond ``self.count``
        check_count(ctx.where(self.table), "weld_pairs", self.p["weld_pairs"], 16.0,
                    ctx.state.n, " of pairs followed")
        m = ctx.state.n * int(self.p["weld_pairs"]) if self.p["weld"] else 0
        self.keys = np.full(m, -1, dtype=np.int64)
        self.since = np.full(m, np.nan)
        self.count = 0
        self.welded_total = 0
        if not self.p["weld"]:  # reports what it does only
            self.diagnostic_units = {"refrozen_joints": "1"}
        #: per joint: model time since which it has been broken and closed [s] (NaN: not)
        self.closed_since = np.full(n, np.nan)
        #: per joint: model time it refroze [s], while it is below full strength (NaN: not)
        self.refrozen_at = np.full(n, np.nan)
        self.refrozen_total = 0

    def apply(self, ctx, dt: float) -> None:
        cm = ctx.contacts
        if cm is None or not cm.joint_slots:
            return
        t = ctx.time
        p = self.p
        if p["weld"]:
            self._weld(ctx, cm, t)
        k = np.flatnonzero(~cm.intact)
        if len(k):
            closed = cm.joint_gaps(k) <= p["gap"]
            since = self.closed_since[k]
            since = np.where(closed, np.where(np.isnan(since), t, since), np.nan)
            # times are multiples of dt: allow for their round-off only
            due = closed & (t - since >= p["freeze_time"] - 1e-9 * max(ctx.dt, 1.0))
            if due.any():
                self.refrozen_total += cm.refreeze_joints(k[due], t)
                self.refrozen_at[k[due]] = t
                since[due] = np.nan
            self.closed_since[k] = since
        # (a joint that refroze just now has felt no force yet)
        young = np.flatnonzero(cm.intact & (self.refrozen_at[:cm.n_joints] < t))
        if len(young):
            tau = t - self.refrozen_at[young]
            weak = cm.joint_tension(young) > refrozen_strength(tau, p["strength"],
                                                                p["strength_time"])
            if weak.any():
                cm.break_joints(young[weak], BreakMode.TENSION, t)
                self.refrozen_at[young[weak]] = np.nan
            grown = ~weak & (tau >= p["strength_time"])
            self.refrozen_at[young[grown]] = np.nan

    def _weld(self, ctx, cm, t: float) -> None:
        """Pairs in contact without a joint: follow them, and freeze those due (module
        docstring)."""
        st, n = ctx.state, ctx.state.n
        ks = (np.flatnonzero(cm.pair_active == 1) if len(cm.pair_active) == len(cm.pairs)
              else np.zeros(0, np.int64))
        i, j = cm.pairs[ks, 0], cm.pairs[ks, 1]
        keys = np.minimum(i, j).astype(np.int64) * n + np.maximum(i, j)
        jointed = np.minimum(cm.ji, cm.jj).astype(np.int64) * n + np.maximum(cm.ji, cm.jj)
        ok = ~np.isin(keys, jointed) & (st.flags[i] != MELTED) & (st.flags[j] != MELTED)
        ks, keys = ks[ok], keys[ok]
        old = self.keys[:self.count]
        at = np.minimum(np.searchsorted(old, keys), max(self.count - 1, 0))
        known = old[at] == keys if self.count else np.zeros(len(keys), bool)
        since = np.where(known, self.since[at] if self.count else t, t)
        # times are multiples of dt: allow for their round-off only
        due = t - since >= self.p["weld_time"] - 1e-9 * max(ctx.dt, 1.0)
        if due.any():
            kd = ks[due]
            if cm.n_joints + len(kd) > cm.joint_slots:
                raise SceneError(
                    f"{ctx.where(self.table)}: process 'refreeze' needs more than the "
                    f"{self.joints_to_create(n)} new joints that weld_capacity = "
                    f"{self.p['weld_capacity']:g} per element reserves; raise weld_capacity"
                    + most_count(BYTES_PER_JOINT, n))
            new = cm.create_joints(cm.pairs[kd], cm.contact_lines(kd))
            self.refrozen_at[new] = t
            self.welded_total += cm.n_reported(new)
        keep = ~due
        m = int(keep.sum())
        if m > len(self.keys):
            raise SceneError(f"{ctx.where(self.table)}: process 'refreeze' follows more than "
                             f"{len(self.keys)} touching pairs; raise weld_pairs"
                             + most_count(16.0, ctx.state.n))
        order = np.argsort(keys[keep], kind="stable")
        self.keys[:m] = keys[keep][order]
        self.since[:m] = since[keep][order]
        self.keys[m:self.count] = -1
        self.since[m:self.count] = np.nan
        self.count = m

    def history(self):
        out = {"closed_since": self.closed_since.copy(), "refrozen_at": self.refrozen_at.copy(),
               "refrozen_total": np.array(self.refrozen_total)}
        if self.p["weld"]:
            out.update(keys=self.keys.copy(), since=self.since.copy(),
                       count=np.array(self.count), welded_total=np.array(self.welded_total))
        return out

    def set_history(self, arrays) -> None:
        self.closed_since[:] = arrays["closed_since"]
        self.refrozen_at[:] = arrays["refrozen_at"]
        self.refrozen_total = int(arrays["refrozen_total"])
        if self.p["weld"]:
            self.keys[:] = arrays["keys"]
            self.since[:] = arrays["since"]
            self.count = int(arrays["count"])
            self.welded_total = int(arrays["welded_total"])

    diagnostic_units: ClassVar[dict[str, str]] = {"refrozen_joints": "1", "welded_joints": "1"}

    def diagnostics(self, ctx):
        out = {"refrozen_joints": float(self.refrozen_total)}
        if self.p["weld"]:
            out["welded_joints"] = float(self.welded_total)
        return out
