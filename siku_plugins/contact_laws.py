"""Built-in contact laws (rheologies): collision, distributed_spring, mohr_coulomb,
bonded_particle.

Over 500 lines for a reason: the four laws stay side by side in this one module, each evaluator
beside its class, so that the rheologies can be read and compared together.

docs/explanation/physics.md §4.3. Each law is an ``@njit`` evaluator of one contact; the engine's
loops in :mod:`siku_core.contacts` call it (the contract, layouts of ``g`` and sign conventions are
in :mod:`siku_core.contact_law`: forces and couples returned act on element ``j``, in ``i``'s
frame). Each law declares the entries of its parameter vectors once, as a
:class:`~siku_core.contact_law.ParameterRecord`; its evaluator reads them by name through the
record's index (``pars[CP.damping_ratio]``). Every law collides overlapping elements with the
collision evaluator; joint laws add their joint evaluator for intact frozen joints, and a broken
joint continues as a collision contact.
"""
from __future__ import annotations

import math

from numba import njit

from siku_core import Param, hookimpl
from siku_core.contact_law import (
    BREAK_COMPRESSION,
    BREAK_SHEAR,
    BREAK_STRAIN,
    BREAK_TENSION,
    G_AREA,
    G_AREA_I,
    G_AREA_J,
    G_K,
    G_MEFF,
    G_NX,
    G_NY,
    G_VX,
    G_VY,
    G_WIDTH,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_EI,
    J_EJ,
    J_HI,
    J_HJ,
    J_K,
    J_L0,
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
    ContactLaw,
    ParameterRecord,
)

#: the collision parameter vector (every law)
COLLISION_RECORD = ParameterRecord("sqrt_area", "damping_ratio", "viscosity", "friction")
CP = COLLISION_RECORD.index


@njit(cache=True)
def collision_evaluator(g, pars, out):
    """Eqs. 9–11: elastic ``K A n`` (or ``K sqrt(A) sqrt(A_min)``), damping, Coulomb friction.

    Damping: a share ``zeta`` of critical for the normal stiffness per penetration depth
    (``K width`` for the linear law), plus the eq. 11 viscosity ``-A eta v_rel``. No cut-off of
    attractive damping forces, so a linear face contact has restitution
    ``exp(-zeta pi / sqrt(1 - zeta²))``. Friction: tangential viscous force capped at
    ``mu |F_n|``.
    """
    A = g[G_AREA]
    nx, ny = g[G_NX], g[G_NY]
    K = g[G_K]
    L = g[G_WIDTH]
    vx, vy = g[G_VX], g[G_VY]
    if pars[CP.sqrt_area] != 0.0:
        ac = math.sqrt(min(g[G_AREA_I], g[G_AREA_J]))
        sa = math.sqrt(A)
        fel = K * sa * ac
        # tangent stiffness dF/d(depth) = K ac L / (2 sqrt(A)); none without overlap (A = 0)
        k = 0.5 * K * ac * L / sa if sa > 0.0 else 0.0
    else:
        fel = K * A
        k = K * L
    c = 2.0 * pars[CP.damping_ratio] * math.sqrt(k * g[G_MEFF])
    vn = vx * nx + vy * ny
    fn = fel - c * vn
    fx = fn * nx - pars[CP.viscosity] * A * vx
    fy = fn * ny - pars[CP.viscosity] * A * vy
    if pars[CP.friction] > 0.0:
        tx, ty = vx - vn * nx, vy - vn * ny
        vt = math.hypot(tx, ty)
        if vt > 0.0:
            ft = min(pars[CP.friction] * abs(fn), c * vt)
            fx -= ft * tx / vt
            fy -= ft * ty / vt
    out[OUT_FX] = fx
    out[OUT_FY] = fy
    out[OUT_COUPLE] = 0.0


class Collision(ContactLaw):
    """Independent elements: elastic repulsion by overlap area (eqs. 9–11), no joints."""

    name = "collision"
    params = {
        "sqrt_area": Param(False, "", "Matuttis-style force ~ sqrt(overlap area)", type=bool),
        "damping_ratio": Param(0.1, "1", "share of critical damping of the normal contact",
                               min=0, max=0.99),
        "viscosity": Param(0.0, "Pa s/m", "eq. 11 viscosity eta of overlapping areas", min=0),
        "friction": Param(0.0, "1", "Coulomb friction coefficient mu", min=0),
    }
    collision_evaluator = collision_evaluator
    collision_record = COLLISION_RECORD


#: the distributed spring's joint parameter vector
SPRING_RECORD = ParameterRecord("tensile_strain", "joint_damping_ratio", "damage_onset")
SP = SPRING_RECORD.index


@njit(cache=True)
def spring_evaluator(g, pars, hist, out):
    """Eqs. 12–13 (corrected): force ``K w (s1 + s2)/2``, couple ``K w (w × (s2 - s1))/12``.

    ``hist[0]`` is the largest strain ``max(|s1|, |s2|)/L0`` reached. The joint breaks when it
    exceeds ``tensile_strain``; between ``damage_onset × tensile_strain`` and the threshold the
    stiffness falls linearly to zero (damage depends on the strain history only, never on dt).
    Damping: a share ``zeta`` of critical for ``K w`` on the reduced mass, applied to the
    relative velocity distribution along the joint like the displacement.
    """
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    strain = math.sqrt(max(s1x * s1x + s1y * s1y, s2x * s2x + s2y * s2y)) / g[J_L0]
    if strain > hist[0]:
        hist[0] = strain
    eps_t = pars[SP.tensile_strain]
    if hist[0] > eps_t:
        out[OUT_BREAK] = BREAK_STRAIN
        return
    onset = pars[SP.damage_onset] * eps_t
    dmg = 0.0
    if hist[0] > onset and eps_t > onset:
        dmg = (hist[0] - onset) / (eps_t - onset)
    K = g[J_K] * (1.0 - dmg)
    w = g[J_W]
    wx, wy = g[J_BX] - g[J_AX], g[J_BY] - g[J_AY]
    c = 2.0 * pars[SP.joint_damping_ratio] * math.sqrt(g[J_K] * w * g[J_MEFF])
    vax, vay, vbx, vby = g[J_VAX], g[J_VAY], g[J_VBX], g[J_VBY]
    # force on i pulls i's copy towards j's copy; j gets the opposite
    fx = K * w * 0.5 * (s1x + s2x) + c * 0.5 * (vax + vbx)
    fy = K * w * 0.5 * (s1y + s2y) + c * 0.5 * (vay + vby)
    ci = (K * w * (wx * (s2y - s1y) - wy * (s2x - s1x))
          + c * (wx * (vby - vay) - wy * (vbx - vax))) / 12.0
    out[OUT_FX] = -fx
    out[OUT_FY] = -fy
    out[OUT_COUPLE] = -ci


def spring_energy(g, pars, hist):
    """Elastic energy [J] of a distributed-spring joint: ``K_d w (|s1|² + |s2|² + s1·s2)/6``,
    the integral of ``K_d |d(z)|² / 2`` along the joint (``d`` linear from ``s1`` to ``s2``),
    ``K_d = K (1 - damage)`` with the damage of ``hist``."""
    eps_t = pars[SP.tensile_strain]
    onset = pars[SP.damage_onset] * eps_t
    dmg = (hist[0] - onset) / (eps_t - onset) if hist[0] > onset and eps_t > onset else 0.0
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    q = s1x * s1x + s1y * s1y + s2x * s2x + s2y * s2y + s1x * s2x + s1y * s2y
    return g[J_K] * (1.0 - dmg) * g[J_W] * q / 6.0


class DistributedSpring(Collision):
    """Coalesced elements: a distributed spring along each frozen joint, brittle failure."""

    name = "distributed_spring"
    uses_joints = True
    history_names = ("max_strain",)
    params = {
        **Collision.params,
        "tensile_strain": Param(2e-4, "1", "joint breaks above this strain max|s|/L0", min=0),
        "damage_onset": Param(1.0, "1", "share of tensile_strain where softening starts "
                              "(1: brittle)", min=0, max=1),
        "joint_damping_ratio": Param(0.1, "1", "share of critical damping of a joint", min=0,
                                     max=0.99),
    }
    joint_evaluator = spring_evaluator
    joint_energy = staticmethod(spring_energy)
    joint_record = SPRING_RECORD


#: the Mohr–Coulomb joint parameter vector (``tan_phi``: of ``friction_angle``)
MOHR_COULOMB_RECORD = ParameterRecord("sigma_c", "tensile_ratio", "tan_phi", "n_segments",
                                      "break_share", "joint_damping_ratio")
MC = MOHR_COULOMB_RECORD.index


@njit(cache=True, inline="always")
def _mc_all_hold(hist, nseg, EL, GL, s1x, s1y, s2x, s2y, nx, ny, tx, ty, sigt, sigc, tanphi):
    """Every segment of a Mohr–Coulomb joint is intact and holds, decided from the two end
    segments: the displacement, and so ``sigma_n = EL d·n`` and ``sigma_s = GL d·t`` (``EL =
    E_s / L0``, ``GL = G_s / L0``), are linear in the position ``z`` along the joint, and each
    failure function (``sigma_n - sigma_t``, ``-sigma_n - sigma_c``, ``|sigma_s| -
    tan(phi)(sigma_t - sigma_n)``) is convex in ``z``, so its largest value over the segment
    centres is at the first or the last. A margin of ``1e-9`` of the strength covers the
    round-off between the segments' own arithmetic and the ends'; a joint within that margin
    of failing takes the segment loop."""
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
    if _mc_all_hold(hist, nseg, EL, GL, s1x, s1y, s2x, s2y, nx, ny, tx, ty, sigt, sigc,
                    tanphi):
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
    c = 2.0 * pars[MC.joint_damping_ratio] * math.sqrt(h * EL * w * g[J_MEFF])
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

    def parameter_values(self):
        return {**self.p, "tan_phi": math.tan(math.radians(self.p["friction_angle"]))}


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
    """Seed 004 eqs. 10–13: one elastic bond per joint, brittle in tension or shear.

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
    cn = c2 * math.sqrt(kna * g[J_MEFF])
    cs = c2 * math.sqrt(share * kna * g[J_MEFF])
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
    """Bonded-particle floes (seed 004 eqs. 10–13): elastic bonds that break in tension or shear.

    One bond per frozen joint, at the joint midpoint, of cross-section ``w × h``: normal and
    shear stiffness per unit area ``k_n = E / D``, ``k_s = k_n / (2 (1 + nu))`` (``D`` the
    centre distance; eq. 9's series stiffness for unequal elements), bending ``k_n I``. A bond
    whose normal stress ``k_n d_n + (w/2) k_n |theta|`` exceeds ``sigma_crit`` or whose shear
    stress ``k_s |d_s|`` exceeds ``tau_crit`` breaks for good; the pair then collides.
    """

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

    def stiffness_factor(self) -> float:
        """Normal stiffness ``k_n A = K w`` and bending ``k_n I = K w³/12``: the spring's."""
        return 1.0


@hookimpl
def siku_register_contact_laws():
    return [Collision, DistributedSpring, MohrCoulomb, BondedParticle]
