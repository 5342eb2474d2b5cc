"""A brittle bond: a contact law whose joints break at stated tensile and shear strengths.

Each frozen joint is the distributed spring of the Siku report (eqs. 12–13): a traction
``K d`` [N/m] along the joint, ``d`` the displacement of ``j``'s copy of the joint from ``i``'s,
linear from ``s1`` at one end to ``s2`` at the other. The bond fails when the stress at either
end, the traction over the thinner element's thickness ``h``, exceeds a strength:

* tension: ``sigma = K (d · n) / h > tensile_strength`` (``n`` from ``i`` towards ``j``);
* shear: ``tau = K |d · t| / h > shear_strength`` (``t`` along the joint).

Overlapping elements collide with siku's collision law, which the class reuses by subclassing
``Collision``: its parameters, its collision evaluator and its parameter vector come with it.
"""
from __future__ import annotations

import math

from numba import njit

from siku_core import Param
from siku_core.contact_law import (
    BREAK_SHEAR, BREAK_TENSION, J_AX, J_AY, J_BX, J_BY, J_HI, J_HJ, J_K, J_MEFF, J_S1X, J_S1Y,
    J_S2X, J_S2Y, J_VAX, J_VAY, J_VBX, J_VBY, J_W, ParameterRecord,
)
from siku_plugins.contact_laws import Collision

# the joint parameter vector, declared once: the engine packs it from the law's parameters
BOND_RECORD = ParameterRecord("tensile_strength", "shear_strength", "stiffness_scale",
                              "joint_damping_ratio")
P = BOND_RECORD.index  # pars[P.tensile_strength]: a compile-time constant index


@njit(cache=True)
def brittle_bond_evaluator(g, pars, hist, out):
    """Distributed spring ``K' = stiffness_scale K`` with tension and shear cut-offs.

    Force on ``j`` (``i``'s frame) ``-(K' w (s1 + s2)/2 + c (v_a + v_b)/2)`` [N] at the joint
    midpoint, couple ``-(K' w (w × (s2 - s1)) + c (w × (v_b - v_a)))/12`` [N m], with ``c`` a
    share ``zeta`` of critical damping of ``K' w`` on the reduced mass. ``hist``: the largest
    ``sigma`` and ``tau`` [Pa] the bond has carried.
    """
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    wx, wy = g[J_BX] - g[J_AX], g[J_BY] - g[J_AY]
    w = g[J_W]
    tx, ty = 1.0, 0.0  # any direction for a zero-width joint
    if w > 0.0:
        tx, ty = wx / w, wy / w
    nx, ny = ty, -tx  # from i towards j
    K = pars[P.stiffness_scale] * g[J_K]
    h = min(g[J_HI], g[J_HJ])
    sigma = K * max(s1x * nx + s1y * ny, s2x * nx + s2y * ny) / h
    tau = K * max(abs(s1x * tx + s1y * ty), abs(s2x * tx + s2y * ty)) / h
    hist[0] = max(hist[0], sigma)
    hist[1] = max(hist[1], tau)
    if sigma > pars[P.tensile_strength]:
        out[3] = BREAK_TENSION
        return
    if tau > pars[P.shear_strength]:
        out[3] = BREAK_SHEAR
        return
    c = 2.0 * pars[P.joint_damping_ratio] * math.sqrt(K * w * g[J_MEFF])
    vax, vay, vbx, vby = g[J_VAX], g[J_VAY], g[J_VBX], g[J_VBY]
    out[0] = -(K * w * 0.5 * (s1x + s2x) + c * 0.5 * (vax + vbx))
    out[1] = -(K * w * 0.5 * (s1y + s2y) + c * 0.5 * (vay + vby))
    out[2] = -(K * w * (wx * (s2y - s1y) - wy * (s2x - s1x))
               + c * (wx * (vby - vay) - wy * (vbx - vax))) / 12.0


def brittle_bond_energy(g, pars, hist):
    """Elastic energy [J] of an intact bond: ``K' w (|s1|² + |s2|² + s1·s2) / 6``."""
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    q = s1x * s1x + s1y * s1y + s2x * s2x + s2y * s2y + s1x * s2x + s1y * s2y
    return pars[P.stiffness_scale] * g[J_K] * g[J_W] * q / 6.0


class BrittleBond(Collision):
    """Brittle bonds along frozen joints: elastic until a tensile or shear strength, then gone."""

    name = "brittle_bond"
    uses_joints = True
    history_names = ("max_sigma", "max_tau")  # Pa
    history_update = "state"  # maxima of what the bond has seen: repeat calls change nothing
    params = {
        **Collision.params,
        "tensile_strength": Param(2.0e5, "Pa", "tensile stress that breaks a bond", min=0.0),
        "shear_strength": Param(4.0e5, "Pa", "shear stress that breaks a bond", min=0.0),
        "stiffness_scale": Param(1.0, "1", "bond stiffness as a multiple of K (eq. 9)",
                                 min=0.01, max=100.0),
        "joint_damping_ratio": Param(0.1, "1", "share of critical damping of a bond", min=0.0,
                                     max=0.99),
    }
    joint_evaluator = brittle_bond_evaluator
    joint_energy = staticmethod(brittle_bond_energy)
    joint_record = BOND_RECORD

    def stiffness_factor(self) -> float:
        """The bond is ``stiffness_scale`` times the spring the time-step estimate assumes."""
        return float(self.p["stiffness_scale"])
