"""The bonded-particle law: one elastic bond per joint, brittle in tension or shear (Orzech et
al. eqs. 10–13; docs/explanation/contacts.md §4.4)."""
from __future__ import annotations

import math

from numba import njit

from siku_core import Param
from siku_core.contact.damping import step_damper
from siku_core.contact_law import (
    BREAK_SHEAR,
    BREAK_TENSION,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_HI,
    J_HJ,
    J_K,
    J_DTM,
    J_MEFF,
    J_NU,
    J_S1X,
    J_S1Y,
    J_S2X,
    J_S2Y,
    J_VAX,
    J_VAY,
    J_VBX,
    J_VBY,
    J_W,
    OUT_BREAK,
    OUT_COUPLE,
    OUT_FX,
    OUT_FY,
    ParameterRecord,
)

from .collision import Collision


#: the bonded-particle joint parameter vector
BOND_RECORD = ParameterRecord("sigma_crit", "tau_crit", "joint_damping_ratio")
BP = BOND_RECORD.index


@njit(cache=True, inline="always")
def bond_rotation(wx, wy, Wx, Wy):
    """Angle [rad] from ``(wx, wy)`` to ``(Wx, Wy)``, counter-clockwise positive, in
    ``(-pi, pi]``: ``atan2(w × W, w · W)``, evaluated as the series ``x - x³/3 + x⁵/5 - x⁷/7 +
    x⁹/9`` of ``atan x``, ``x = (w × W)/(w · W)``, when ``|x| <= 1e-2`` (its remainder, below
    ``x¹¹/11``, is 1e-21 relative: under round-off) and by ``atan2`` otherwise. A bond turns by
    at most ``2 sigma_crit D / (E w)`` before it breaks (2e-3 rad for 1 MPa bonds in 1 GPa
    ice), so the series is the rule."""
    cross = wx * Wy - wy * Wx
    dot = wx * Wx + wy * Wy
    if dot > 0.0 and abs(cross) <= 1e-2 * dot:
        x = cross / dot
        x2 = x * x
        return x * (1.0 - x2 * (1.0 / 3.0 - x2 * (0.2 - x2 * (1.0 / 7.0 - x2 * (1.0 / 9.0)))))
    return math.atan2(cross, dot)


@njit(cache=True)
def bonded_particle_evaluator(g, pars, hist, out):
    """Orzech et al. eqs. 10–13: one elastic bond per joint, brittle in tension or shear.

    The bond sits at the joint midpoint ``m``; its cross-section is the joint, width ``w``
    (joint length) by thickness ``h_b = min(h_i, h_j)``: area ``A = w h_b``, in-plane second
    moment ``I = h_b w³/12``. With ``t = (b - a)/w`` along the joint and ``n = (t_y, -t_x)``
    from ``i`` towards ``j`` (``i``'s frame):

    * normal and tangential displacement of the bond point ``d_n = d·n``, ``d_s = d·t``, with
      ``d = (s1 + s2)/2`` (``j``'s copy of the midpoint minus ``i``'s; opening positive);
    * relative rotation ``theta``: the angle from the joint ``b - a`` to ``j``'s copy of it
      ``(b + s2) - (a + s1)`` (counter-clockwise positive; exact for any angle);
    * bond stiffness per unit area ``k_n = K / h_b`` [Pa/m], ``K`` of eq. 9: ``E / D`` (eq. 12)
      for two equal elements with ``D = r_i + r_j`` their centre distance, the two halves in
      series otherwise; ``k_s = k_n / (2 (1 + nu))`` (eq. 13);
    * force on ``j``: ``-A (k_n d_n n + k_s d_s t)`` at ``m``, couple ``-k_n I theta``;
    * stresses (eqs. 10–11 with Potyondy–Cundall's bending): ``sigma = k_n d_n + (w/2) k_n
      |theta|`` (the largest normal stress over the section: the bending moment ``k_n I theta``
      over the section modulus ``I / (w/2)``), ``tau = k_s |d_s|`` (in the plane there is no
      twisting about the bond axis);
    * the bond breaks for good when ``sigma > sigma_crit`` (``out[OUT_BREAK] = BREAK_TENSION``) or
      ``tau > tau_crit`` (``BREAK_SHEAR``; the larger ratio to its strength decides when both
      exceed theirs) and carries no force from then on;
    * damping: a share ``zeta`` of critical for each stiffness on the reduced mass, on the
      relative velocity of the bond point (normal and tangential) and on the relative spin
      ``(w × (v_b - v_a))/w²`` with the same ratio to the bending stiffness.

    ``hist[0]``, ``hist[1]``: the largest ``sigma`` and ``tau`` [Pa] the bond has carried.
    """
    w = g[J_W]
    wx, wy = g[J_BX] - g[J_AX], g[J_BY] - g[J_AY]
    if w > 0.0:
        inv_w = 1.0 / w
        tx, ty = wx * inv_w, wy * inv_w
    else:  # zero-width joint: no section, no force; any direction
        tx, ty = 1.0, 0.0
    nx, ny = ty, -tx
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    dx = 0.5 * (s1x + s2x)
    dy = 0.5 * (s1y + s2y)
    dn = dx * nx + dy * ny
    ds = dx * tx + dy * ty
    theta = bond_rotation(wx, wy, wx + s2x - s1x, wy + s2y - s1y) if w > 0.0 else 0.0
    hb = min(g[J_HI], g[J_HJ])
    kn = g[J_K] / hb if hb > 0.0 else 0.0  # [Pa/m]
    share = 1.0 / (2.0 * (1.0 + g[J_NU]))  # k_s / k_n
    sigma = kn * (dn + 0.5 * w * abs(theta))
    tau = kn * share * abs(ds)
    if sigma > hist[0]:
        hist[0] = sigma
    if tau > hist[1]:
        hist[1] = tau
    sigc = pars[BP.sigma_crit]
    tauc = pars[BP.tau_crit]
    if sigma > sigc or tau > tauc:
        out[OUT_BREAK] = BREAK_TENSION if sigma / sigc >= tau / tauc else BREAK_SHEAR
        return
    # k_n A = K w [N/m] (A = w h_b), k_s A = share K w, k_n I = K w³/12
    kna = g[J_K] * w if hb > 0.0 else 0.0
    c2 = 2.0 * pars[BP.joint_damping_ratio]
    cn = step_damper(c2 * math.sqrt(kna * g[J_MEFF]), g[J_DTM])
    cs = step_damper(c2 * math.sqrt(share * kna * g[J_MEFF]), g[J_DTM])
    vax, vay, vbx, vby = g[J_VAX], g[J_VAY], g[J_VBX], g[J_VBY]
    vx = 0.5 * (vax + vbx)
    vy = 0.5 * (vay + vby)
    fn = kna * dn + cn * (vx * nx + vy * ny)
    fs = share * kna * ds + cs * (vx * tx + vy * ty)
    # couple k_n I theta + c_n (w²/12) spin, spin = (w × (v_b - v_a))/w²
    couple = (kna * w * w * theta + cn * (wx * (vby - vay) - wy * (vbx - vax))) / 12.0
    out[OUT_FX] = -(fn * nx + fs * tx)
    out[OUT_FY] = -(fn * ny + fs * ty)
    out[OUT_COUPLE] = -couple


def bonded_particle_energy(g, pars, hist):
    """Elastic energy [J] of a bond: ``A (k_n d_n² + k_s d_s²)/2 + k_n I theta²/2`` (the
    quantities of :func:`bonded_particle_evaluator`)."""
    ax, ay, bx, by = g[J_AX], g[J_AY], g[J_BX], g[J_BY]
    w = g[J_W]
    wx, wy = bx - ax, by - ay
    tx, ty = (wx / w, wy / w) if w > 0.0 else (1.0, 0.0)
    nx, ny = ty, -tx
    dx = 0.5 * (g[J_S1X] + g[J_S2X])
    dy = 0.5 * (g[J_S1Y] + g[J_S2Y])
    dn = dx * nx + dy * ny
    ds = dx * tx + dy * ty
    theta = 0.0
    if w > 0.0:
        theta = bond_rotation(wx, wy, wx + g[J_S2X] - g[J_S1X], wy + g[J_S2Y] - g[J_S1Y])
    hb = min(g[J_HI], g[J_HJ])
    kn = g[J_K] / hb if hb > 0.0 else 0.0
    ks = kn / (2.0 * (1.0 + g[J_NU]))
    area = w * hb
    inertia = hb * w ** 3 / 12.0
    return 0.5 * area * (kn * dn * dn + ks * ds * ds) + 0.5 * kn * inertia * theta * theta


class BondedParticle(Collision):
    """Bonded-particle floes (Orzech et al. 2018, eqs. 10–13): bonds brittle in tension, shear.

    One bond per frozen joint, at the joint midpoint, of cross-section ``w × h``: normal and
    shear stiffness per unit area ``k_n = E / D``, ``k_s = k_n / (2 (1 + nu))`` (``D`` the
    centre distance; eq. 9's series stiffness for unequal elements), bending ``k_n I``. A bond
    whose normal stress ``k_n d_n + (w/2) k_n |theta|`` exceeds ``sigma_crit`` or whose shear
    stress ``k_s |d_s|`` exceeds ``tau_crit`` breaks for good; the pair then collides.
    """

    bounded_damping = True  # (siku_core.contact.damping)
    name = "bonded_particle"
    uses_joints = True
    history_names = ("max_sigma", "max_tau")
    params = {
        **Collision.params,
        "sigma_crit": Param(1.0e6, "Pa", "critical bond normal (tensile) stress sigma_b,crit",
                            min=1.0),
        "tau_crit": Param(1.0e6, "Pa", "critical bond shear stress tau_b,crit", min=1.0),
        "joint_damping_ratio": Param(0.1, "1", "share of critical damping of a bond", min=0,
                                     max=0.99),
    }
    joint_evaluator = bonded_particle_evaluator
    joint_energy = staticmethod(bonded_particle_energy)
    joint_record = BOND_RECORD

    def stability_rates(self):
        """``k_s = k_n / (2 (1 + nu))``, damped with its own share of critical."""
        return {**super().stability_rates(), "joint_shear": "poisson",
                "joint_shear_damping": "own"}

    def stiffness_factor(self) -> float:
        """Normal stiffness ``k_n A = K w`` and bending ``k_n I = K w³/12``: the spring's."""
        return 1.0
