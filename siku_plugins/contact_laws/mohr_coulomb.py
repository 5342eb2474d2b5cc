"""The Mohr–Coulomb law: joints in segments whose normal and shear stresses fail against a
Mohr–Coulomb envelope with a tension cut-off (docs/explanation/contacts.md §4.3)."""
from __future__ import annotations

import math

from numba import njit

from siku_core import Param
from siku_core.contact.damping import step_damper
from siku_core.contact_law import (
    BREAK_COMPRESSION,
    BREAK_SHEAR,
    BREAK_STRAIN,
    BREAK_TENSION,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_EI,
    J_EJ,
    J_HI,
    J_HJ,
    J_L0,
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


#: the Mohr–Coulomb joint parameter vector (``tan_phi``: of ``friction_angle``)
MOHR_COULOMB_RECORD = ParameterRecord("sigma_c", "tensile_ratio", "tan_phi", "n_segments",
                                      "break_share", "joint_damping_ratio")
MC = MOHR_COULOMB_RECORD.index


@njit(cache=True, inline="always")
def _mc_all_hold(hist, nseg, EL, GL, s, frame, strength):
    """Every segment of a Mohr–Coulomb joint is intact and holds, decided from the two end
    segments: the displacement (``s = (s1x, s1y, s2x, s2y)`` [m], at the first and the last
    end), and so ``sigma_n = EL d·n`` and ``sigma_s = GL d·t`` (``EL = E_s / L0``, ``GL = G_s
    / L0`` [Pa/m]; ``frame = (nx, ny, tx, ty)``, the joint's unit normal and tangent), are
    linear in the position ``z`` along the joint, and each
    failure function (``sigma_n - sigma_t``, ``-sigma_n - sigma_c``, ``|sigma_s| -
    tan(phi)(sigma_t - sigma_n)``) is convex in ``z``, so its largest value over the segment
    centres is at the first or the last. A margin of ``1e-9`` of the strength covers the
    round-off between the segments' own arithmetic and the ends'; a joint within that margin
    of failing takes the segment loop. ``strength``: ``(sigma_t, sigma_c, tan(phi))`` [Pa, Pa,
    1]."""
    s1x, s1y, s2x, s2y = s
    nx, ny, tx, ty = frame
    sigt, sigc, tanphi = strength
    for k in range(nseg):
        if hist[k] != 0.0:
            return False
    tol = 1e-9 * (sigt + sigc)
    for e in range(2):
        z = (0.5 if e == 0 else nseg - 0.5) / nseg
        dx = s1x + z * (s2x - s1x)
        dy = s1y + z * (s2y - s1y)
        sn = EL * (dx * nx + dy * ny)
        ss = GL * (dx * tx + dy * ty)
        if not (sn <= sigt - tol and sn >= -sigc + tol and abs(ss) <= tanphi * (sigt - sn) - tol):
            return False
    return True


@njit(cache=True)
def mohr_coulomb_evaluator(g, pars, hist, out):
    """Eqs. 14–16 with Table 1: segment-wise stresses and Mohr–Coulomb failure with tension cut-off.

    The joint (ends ``a``, ``b`` in ``i``'s frame, unit tangent ``t = (b - a)/w``, outward
    normal of ``i`` ``n = (t_y, -t_x)``) is split into ``n_segments``; at each segment centre
    the displacement ``d = s1 + zeta (s2 - s1)`` gives ``sigma_n = E_s d·n / L0`` (tension
    positive) and ``sigma_s = G_s d·t / L0``, ``G_s = E_s/(2(1 + nu))``. A segment fails for
    good when ``sigma_n > sigma_t``, ``sigma_n < -sigma_c`` or ``|sigma_s| > tan(phi)(sigma_t -
    sigma_n)``; ``hist[k] = 1`` marks it. Intact segments pull ``i`` with ``h_s (sigma_n n +
    sigma_s t) w / n_segments`` at their centres. The joint breaks when the failed share
    reaches ``break_share``.

    **Two materials** (``a = h_i E_i``, ``b = h_j E_j``): the joint is two elastic strips in
    series, ``i``'s from its centre to the joint (length ``r_i``, the distance of the joint's
    midpoint from ``i``'s centre) and ``j``'s the rest of the centre distance ``L0 - r_i``;
    the traction per unit length is ``(h E)_eff d / L0`` with ``(h E)_eff = a b / (lam b +
    (1 - lam) a)``, ``lam = r_i / L0`` (``2 a b / (a + b)`` for equal cells). This is eq. 9's
    series combination ``K = a b / (a r_j + b r_i)`` that the spring law uses and
    ``ContactModel.stiffness_bound`` assumes, with ``L0 - r_i`` for ``j``'s lever arm ``r_j``
    (not in ``g``). As ``r_i + r_j >= L0`` the law exceeds ``K`` only by that geometric
    excess, a factor ``1 + a (r_i + r_j - L0) / (a (L0 - r_i) + b r_i)``: ``(r_i + r_j)/L0``
    for identical cells, as the mean-``h E`` law did (at most 1.004 in jittered packs; on
    regular packs ``1 + 1e-10`` for 10 m cells to ``1 + 2e-4`` for 100 km ones); the
    mean-``h E`` law was 50× stiffer than ``K`` for 5 cm ice jointed to 10 m ice.
    The traction is the same on both sides, so the stress is largest on the thinner one:
    ``h_s = min(h_i, h_j)`` and ``E_s = (h E)_eff / h_s`` (``G_s`` from ``E_s``, so shear is
    softened the same way); the default ``sigma_c`` is Table 1's at ``h_s`` as well. For
    cells of equal ``h E`` (``a == b``, uniform ice) the factor is 1 whatever ``lam``: ``E_s``
    is the thinner side's ``E`` exactly, and neither ``lam`` nor the factor is computed. The
    damping uses the same stiffness, ``(h E)_eff w / L0``.

    It stays one function: one compiled pass over the segments, and splitting it would cost
    numba's inlining or change the order of the floating-point operations (results are
    bit-for-bit).
    """
    nseg = int(pars[MC.n_segments])
    L0 = g[J_L0]
    hi, hj = g[J_HI], g[J_HJ]
    a = hi * g[J_EI]
    b = hj * g[J_EJ]
    inv_l0 = 1.0 / L0 if L0 > 0.0 else 0.0
    if a == b and a > 0.0:
        # equal h E (uniform ice): the series factor b / den is exactly 1, whatever lam
        h = min(hi, hj)
        E = g[J_EI] if hi <= hj else g[J_EJ]
    else:
        # i's share of the centre distance: the joint midpoint's distance from i's centre
        mx2, my2 = g[J_AX] + g[J_BX], g[J_AY] + g[J_BY]
        lam = 0.5 * math.sqrt(mx2 * mx2 + my2 * my2) * inv_l0 if L0 > 0.0 else 0.5
        lam = min(max(lam, 0.0), 1.0)
        # h, E: the thinner side's thickness and its modulus scaled so that h E = (h E)_eff;
        # den = lam b + (1 - lam) a
        if hi <= hj:
            h = hi
            den = b + (1.0 - lam) * (a - b)
            E = g[J_EI] * (b / den) if den > 0.0 else 0.0
        else:
            h = hj
            den = a + lam * (b - a)
            E = g[J_EJ] * (a / den) if den > 0.0 else 0.0
    EL = E * inv_l0  # sigma_n per metre of normal displacement [Pa/m]
    GL = EL * (0.5 / (1.0 + g[J_NU]))
    sigc = pars[MC.sigma_c]
    if sigc <= 0.0:
        sigc = 1285e3 * h ** (2.0 / 3.0)
    sigt = pars[MC.tensile_ratio] * sigc
    tanphi = pars[MC.tan_phi]
    ax, ay, bx, by = g[J_AX], g[J_AY], g[J_BX], g[J_BY]
    w = g[J_W]
    if w > 0.0:
        inv_w = 1.0 / w
        tx, ty = (bx - ax) * inv_w, (by - ay) * inv_w
    else:  # zero-width joint (coincident ends): no segment carries traction; any direction
        tx, ty = 1.0, 0.0
    nx, ny = ty, -tx
    mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    seg = w / nseg
    fx = 0.0
    fy = 0.0
    ci = 0.0
    nfailed = 0
    mode = BREAK_STRAIN
    if _mc_all_hold(hist, nseg, EL, GL, (s1x, s1y, s2x, s2y), (nx, ny, tx, ty),
                    (sigt, sigc, tanphi)):
        # every segment intact and safely inside the criterion: the sums over the segments
        # in closed form (the stresses are linear along the joint; see _mc_all_hold)
        dn1 = s1x * nx + s1y * ny
        dn2 = s2x * nx + s2y * ny
        sn = EL * (0.5 * (dn1 + dn2))  # mean over the segment centres
        ss = GL * (0.5 * ((s1x * tx + s1y * ty) + (s2x * tx + s2y * ty)))
        fx = h * w * (sn * nx + ss * tx)
        fy = h * w * (sn * ny + ss * ty)
        # sum_k (z_k - 1/2) sigma_n(z_k) over centres z_k = (k + 1/2)/n: (n² - 1)/(12 n) times
        # the slope; the lever (z - 1/2)(b - a) is along t, so only sigma_n turns the joint
        ci = -h * seg * w * (EL * (dn2 - dn1)) * (nseg * nseg - 1.0) / (12.0 * nseg)
        nseg_loop = 0
    else:
        nseg_loop = nseg
    for k in range(nseg_loop):
        z = (k + 0.5) / nseg
        dx = s1x + z * (s2x - s1x)
        dy = s1y + z * (s2y - s1y)
        sn = EL * (dx * nx + dy * ny)
        ss = GL * (dx * tx + dy * ty)
        if hist[k] == 0.0:
            if sn > sigt:
                hist[k] = 1.0
                mode = BREAK_TENSION
            elif sn < -sigc:
                hist[k] = 1.0
                mode = BREAK_COMPRESSION
            elif abs(ss) > tanphi * (sigt - sn):
                hist[k] = 1.0
                mode = BREAK_SHEAR
        if hist[k] != 0.0:
            nfailed += 1
            continue
        sfx = h * seg * (sn * nx + ss * tx)
        sfy = h * seg * (sn * ny + ss * ty)
        px = ax + z * (bx - ax) - mx
        py = ay + z * (by - ay) - my
        fx += sfx
        fy += sfy
        ci += px * sfy - py * sfx
    if nfailed >= pars[MC.break_share] * nseg - 1e-9:
        out[OUT_BREAK] = mode  # the criterion of the segment whose failure broke the joint
        return
    # damping: share of critical for the normal stiffness (h E)_eff w / L0 on the reduced mass
    # (bounded by the step: siku_core.contact.damping)
    c = step_damper(2.0 * pars[MC.joint_damping_ratio] * math.sqrt(h * EL * w * g[J_MEFF]),
                    g[J_DTM])
    if nfailed:
        c *= (nseg - nfailed) / nseg
    vax, vay, vbx, vby = g[J_VAX], g[J_VAY], g[J_VBX], g[J_VBY]
    fx += c * 0.5 * (vax + vbx)
    fy += c * 0.5 * (vay + vby)
    wx, wy = bx - ax, by - ay
    ci += c * (wx * (vby - vay) - wy * (vbx - vax)) * (1.0 / 12.0)
    out[OUT_FX] = -fx
    out[OUT_FY] = -fy
    out[OUT_COUPLE] = -ci


class MohrCoulomb(Collision):
    """Modified Hopkins–Frankenstein / Wilchinsky–Feltham–Hopkins joints (eqs. 14–16, Table 1)."""

    bounded_damping = True  # (siku_core.contact.damping)
    name = "mohr_coulomb"
    uses_joints = True
    params = {
        **Collision.params,
        "sigma_c": Param(0.0, "Pa", "compressive strength; 0: 1285 h_min^(2/3) kPa (Table 1)",
                         min=0),
        "tensile_ratio": Param(0.1, "1", "sigma_t / sigma_c (Table 1)", min=0, max=1),
        "friction_angle": Param(15.0, "deg", "Mohr–Coulomb friction angle phi", min=0, max=53),
        "n_segments": Param(10, "1", "segments per joint", type=int, min=1, max=64),
        "break_share": Param(1.0, "1", "failed share of segments that breaks the joint",
                             min=0.01, max=1),
        "joint_damping_ratio": Param(0.1, "1", "share of critical damping of a joint", min=0,
                                     max=0.99),
    }
    joint_evaluator = mohr_coulomb_evaluator
    joint_record = MOHR_COULOMB_RECORD

    def __init__(self, params=None):
        super().__init__(params)
        self.history_names = tuple(f"failed_{k}" for k in range(int(self.p["n_segments"])))

    def stability_rates(self):
        """Shear stiffness ``G/E = 1/(2(1 + nu))`` of the normal one; the normal damper acts
        along the joint too."""
        return {**super().stability_rates(), "joint_shear": "poisson",
                "joint_shear_damping": "normal"}

    def parameter_values(self):
        return {**self.p, "tan_phi": math.tan(math.radians(self.p["friction_angle"]))}
