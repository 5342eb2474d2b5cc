"""``joint_strength``: joints of unequal strength (heterogeneity of the frozen ice).

Each joint's strength is the contact law's (``tensile_strain`` of ``distributed_spring``) times
a factor ``X`` drawn once, at set-up, from a Weibull distribution of modulus ``m`` and mean 1:

    P(X ≤ x) = 1 - exp(-(x / s)^m),   s = 1 / Γ(1 + 1/m),

so a small ``m`` (2-5, brittle solids) gives a wide spread of strengths (coefficient of variation
``sqrt(Γ(1 + 2/m) / Γ(1 + 1/m)² - 1)``: 0.52 at ``m = 2``, 0.23 at ``m = 5``) and a large one
the homogeneous law. The draw of a joint depends on the seed and its two elements only (a
counter-based generator keyed by ``seed`` and the pair ``(min, max)``), so it is the same for
any joint order, any number of threads and after a restart. The factor is kept as ``log X`` in
the law's joint history (column ``log_strength``, which the law reads); joints made later
(``refreeze``) have the law's strength. The law's ``damage_onset`` (below 1) softens a joint
before it breaks.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from siku_core.errors import SceneError
from siku_core.interfaces import Process
from siku_core.params import Param


def weibull_factors(ji, jj, modulus: float, seed: int) -> np.ndarray:
    """Strength factors (mean 1, Weibull modulus ``modulus``) of the joints ``(ji, jj)``: one
    uniform number per joint from Philox keyed by ``seed``, counter ``(min, max)`` of the pair,
    mapped through the inverse distribution."""
    a = np.minimum(ji, jj).astype(np.uint64)
    b = np.maximum(ji, jj).astype(np.uint64)
    u = np.empty(len(a))
    for k in range(len(a)):  # one generator per pair: independent of the order of the joints
        g = np.random.Generator(np.random.Philox(key=int(seed), counter=[int(a[k]), int(b[k]),
                                                                       0, 0]))
        u[k] = g.random()
    scale = 1.0 / math.gamma(1.0 + 1.0 / modulus)
    return scale * (-np.log1p(-u)) ** (1.0 / modulus)


class JointStrength(Process):
    """Each joint's strength is the law's times a Weibull factor of mean 1 (module docstring)."""

    name = "joint_strength"
    params: ClassVar[dict[str, Param]] = {
        "modulus": Param(3.0, "1", "Weibull modulus m of the joints' strength factors (small: "
                         "wide spread)", min=0.1),
        "seed": Param(0, "1", "seed of the draws (a joint's draw depends on it and its two "
                      "elements only)", type=int, min=0),
    }

    def setup(self, ctx) -> None:
        cm = ctx.contacts
        names = cm.joint_history_names if cm is not None else ()
        if "log_strength" not in names:
            raise SceneError(f"{ctx.where(self.table)}: process 'joint_strength' needs a contact "
                             "law whose joints have a strength factor (log_strength in its "
                             "history): [contact] law = \"distributed_spring\"")
        f = weibull_factors(np.asarray(cm.ji), np.asarray(cm.jj), float(self.p["modulus"]),
                            int(self.p["seed"]))
        cm.set_joint_history("log_strength", np.log(f))

    def apply(self, ctx, dt: float) -> None:
        return None
