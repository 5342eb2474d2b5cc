"""``refreeze``: broken joints whose two sides stay together freeze again.

A broken joint is *closed* while the two copies of each of its ends (one on each element) are
within ``gap`` [m] of each other. A joint closed without a break for ``freeze_time`` [s]
refreezes: it holds again from the next force evaluation, at rest where its two sides are
(``ContactModel.refreeze_joints``), under the scene's contact law. New ice in a lead thickens as
the square root of time (Stefan's law), so the refrozen joint's tensile strength grows the same
way until it reaches the intact ice's:

    sigma_r(tau) = strength * min(1, sqrt(tau / strength_time))

``tau`` [s] the time since it refroze. While ``tau < strength_time`` the process breaks a
refrozen joint (mode ``tension``) whose normal traction (opening positive, force over joint
length and the thinner side's thickness, ``ContactModel.joint_tension``) exceeds
``sigma_r(tau)``; from then on only the contact law's own strength holds it. Checked every time
the process runs, so its timing resolution is the process's ``every`` (one step by default).
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from siku_core.contact_law import BreakMode
from siku_core.interfaces import Process
from siku_core.params import Param


def refrozen_strength(tau, strength: float, strength_time: float):
    """Tensile strength [Pa] of a joint refrozen ``tau`` [s] ago (module docstring)."""
    return strength * np.minimum(1.0, np.sqrt(np.maximum(tau, 0.0) / strength_time))


class Refreeze(Process):
    """Broken joints that stay closed refreeze, their strength growing with time.

    A joint whose sides stay within ``gap`` for ``freeze_time`` holds again; its strength grows
    as the square root of the time frozen (module docstring)."""

    name = "refreeze"
    params: ClassVar[dict[str, Param]] = {
        "gap": Param(1.0, "m", "largest distance between the two sides of a broken joint that "
                     "counts as closed", min=0.0),
        "freeze_time": Param(86400.0, "s", "time a broken joint must stay closed to refreeze",
                             min=0.0),
        "strength": Param(5e5, "Pa", "tensile strength of a fully refrozen joint", min=0.0),
        "strength_time": Param(864000.0, "s", "time a refrozen joint takes to reach full "
                               "strength", min=1e-9),
    }

    def setup(self, ctx) -> None:
        self.ctx = ctx
        n = ctx.contacts.n_joints if ctx.contacts is not None else 0
        #: per joint: model time since which it has been broken and closed [s] (NaN: not)
        self.closed_since = np.full(n, np.nan)
        #: per joint: model time it refroze [s], while it is below full strength (NaN: not)
        self.refrozen_at = np.full(n, np.nan)
        self.refrozen_total = 0

    def apply(self, ctx, dt: float) -> None:
        cm = ctx.contacts
        if cm is None or not cm.n_joints:
            return
        t = ctx.time
        p = self.p
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
        young = np.flatnonzero(cm.intact & (self.refrozen_at < t))
        if len(young):
            tau = t - self.refrozen_at[young]
            weak = cm.joint_tension(young) > refrozen_strength(tau, p["strength"],
                                                                p["strength_time"])
            if weak.any():
                cm.break_joints(young[weak], BreakMode.TENSION, t)
                self.refrozen_at[young[weak]] = np.nan
            grown = ~weak & (tau >= p["strength_time"])
            self.refrozen_at[young[grown]] = np.nan

    def history(self):
        return {"closed_since": self.closed_since.copy(), "refrozen_at": self.refrozen_at.copy(),
                "refrozen_total": np.array(self.refrozen_total)}

    def set_history(self, arrays) -> None:
        self.closed_since[:] = arrays["closed_since"]
        self.refrozen_at[:] = arrays["refrozen_at"]
        self.refrozen_total = int(arrays["refrozen_total"])

    diagnostic_units: ClassVar[dict[str, str]] = {"refrozen_joints": "1"}

    def diagnostics(self, ctx):
        return {"refrozen_joints": float(self.refrozen_total)}
