"""Bonded beams along frozen joints.

A frozen joint of width ``w`` carries the distributed spring of the Siku report: a traction
``K' d`` [N/m] along the joint, ``d`` the opening, linear from ``s1`` at one end to ``s2`` at
the other. Read as a beam of depth ``w`` and thickness ``h``, the mean normal opening gives the
axial stress ``sigma_a = K' (s1 + s2)/2 · n / h`` and the difference between the ends the
bending stress ``sigma_b = K' |(s2 - s1) · n| / (2 h)`` [Pa]; the bond breaks in tension when
``sigma_a + sigma_b`` exceeds ``tensile_strength`` and in shear when the mean tangential
stress ``K' |(s1 + s2)/2 · t| / h`` exceeds ``shear_strength``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core import Param
from siku_core.contacts import (
    BREAK_SHEAR, BREAK_TENSION, J_AX, J_AY, J_BX, J_BY, J_HI, J_HJ, J_K, J_MEFF, J_S1X, J_S1Y,
    J_S2X, J_S2Y, J_VAX, J_VAY, J_VBX, J_VBY, J_W,
)
from siku_plugins.contact_laws import Collision

# the joint parameter vector, in the order joint_parameters() returns it
P_SIGMA_T, P_TAU_C, P_SCALE, P_ZETA = range(4)


@njit(cache=True)
def bonded_beam_evaluator(g, pars, hist, out):
    """Distributed spring ``K' = stiffness_scale K`` as a beam with tension and shear limits.

    Force on ``j`` (``i``'s frame) ``-(K' w (s1 + s2)/2 + c (v_a + v_b)/2)`` [N] at the joint
    midpoint, couple ``-(K' w (w × (s2 - s1)) + c (w × (v_b - v_a)))/12`` [N m], ``c`` a share
    ``zeta`` of critical damping of ``K' w`` on the reduced mass. ``hist``: the largest
    axial-plus-bending and shear stresses [Pa] the bond has carried.
    """
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    wx, wy = g[J_BX] - g[J_AX], g[J_BY] - g[J_AY]
    w = g[J_W]
    tx, ty = 1.0, 0.0  # any direction for a zero-width joint
    if w > 0.0:
        tx, ty = wx / w, wy / w
    nx, ny = ty, -tx  # from i towards j
    K = pars[P_SCALE] * g[J_K]
    h = min(g[J_HI], g[J_HJ])
    mx, my = 0.5 * (s1x + s2x), 0.5 * (s1y + s2y)
    axial = K * (mx * nx + my * ny) / h
    bending = 0.5 * K * abs((s2x - s1x) * nx + (s2y - s1y) * ny) / h
    tau = K * abs(mx * tx + my * ty) / h
    hist[0] = max(hist[0], axial + bending)
    hist[1] = max(hist[1], tau)
    if axial + bending > pars[P_SIGMA_T]:
        out[3] = BREAK_TENSION
        return
    if tau > pars[P_TAU_C]:
        out[3] = BREAK_SHEAR
        return
    c = 2.0 * pars[P_ZETA] * math.sqrt(K * w * g[J_MEFF])
    vax, vay, vbx, vby = g[J_VAX], g[J_VAY], g[J_VBX], g[J_VBY]
    out[0] = -(K * w * mx + c * 0.5 * (vax + vbx))
    out[1] = -(K * w * my + c * 0.5 * (vay + vby))
    out[2] = -(K * w * (wx * (s2y - s1y) - wy * (s2x - s1x))
               + c * (wx * (vby - vay) - wy * (vbx - vax))) / 12.0


class BondedBeam(Collision):
    """Bonded beams along frozen joints: elastic until the axial and bending stress reaches a
    tensile strength or the shear stress a shear strength."""

    name = "bonded_beam"
    uses_joints = True
    history_names = ("max_sigma", "max_tau")  # Pa
    history_update = "state"
    params = {
        **Collision.params,
        "tensile_strength": Param(3.0e5, "Pa", "axial plus bending stress that breaks a bond",
                                  min=0.0),
        "shear_strength": Param(5.0e5, "Pa", "shear stress that breaks a bond", min=0.0),
        "stiffness_scale": Param(1.0, "1", "bond stiffness as a multiple of K (eq. 9)",
                                 min=0.01, max=100.0),
        "joint_damping_ratio": Param(0.1, "1", "share of critical damping of a bond", min=0.0,
                                     max=0.99),
    }
    joint_evaluator = bonded_beam_evaluator

    def joint_parameters(self, sim):
        p = self.p
        return np.array([p["tensile_strength"], p["shear_strength"], p["stiffness_scale"],
                         p["joint_damping_ratio"]])

    def stiffness_factor(self) -> float:
        """The bond is ``stiffness_scale`` times the spring the time-step estimate assumes."""
        return float(self.p["stiffness_scale"])
