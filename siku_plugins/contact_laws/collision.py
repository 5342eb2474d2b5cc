"""The collision law: independent elements repel by their overlap area (eqs. 9–11 of
Kulchitsky et al. 2017, docs/explanation/physics.md §4.3), with damping and Coulomb friction.
Every law collides overlapping elements with this evaluator."""
from __future__ import annotations

import math

from numba import njit

from siku_core import Param
from siku_core.contact.damping import step_damper
from siku_core.contact_law import (
    G_AREA,
    G_AREA_I,
    G_AREA_J,
    G_K,
    G_DTM,
    G_MEFF,
    G_NX,
    G_NY,
    G_VX,
    G_VY,
    G_WIDTH,
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


@njit(cache=True, inline="always")
def collision_force(g, sqrt_area, zeta, eta, mu, fmax, out):
    """The force of eqs. 9–11 on ``j`` into ``out`` (see :func:`collision_evaluator`), its
    normal part capped at ``fmax`` [N] (``inf``: no cap; the ridging law's plastic limit).
    ``out[OUT_BREAK]`` (unused by collisions otherwise) is 1 when the cap bound the normal
    force (``fn >= fmax``), else 0: the plastic flag the ``ridging`` process reads."""
    A = g[G_AREA]
    nx, ny = g[G_NX], g[G_NY]
    K = g[G_K]
    L = g[G_WIDTH]
    vx, vy = g[G_VX], g[G_VY]
    if sqrt_area != 0.0:
        ac = math.sqrt(min(g[G_AREA_I], g[G_AREA_J]))
        sa = math.sqrt(A)
        fel = K * sa * ac
        # tangent stiffness dF/d(depth) = K ac L / (2 sqrt(A)); none without overlap (A = 0)
        k = 0.5 * K * ac * L / sa if sa > 0.0 else 0.0
    else:
        fel = K * A
        k = K * L
    c = step_damper(2.0 * zeta * math.sqrt(k * g[G_MEFF]), g[G_DTM])
    vn = vx * nx + vy * ny
    fn = fel - c * vn
    capped = fn >= fmax
    if capped:
        fn = fmax
    fx = fn * nx - eta * A * vx
    fy = fn * ny - eta * A * vy
    if mu > 0.0:
        tx, ty = vx - vn * nx, vy - vn * ny
        vt = math.hypot(tx, ty)
        if vt > 0.0:
            ft = min(mu * abs(fn), c * vt)
            fx -= ft * tx / vt
            fy -= ft * ty / vt
    out[OUT_FX] = fx
    out[OUT_FY] = fy
    out[OUT_COUPLE] = 0.0
    out[OUT_BREAK] = 1.0 if capped else 0.0


@njit(cache=True)
def collision_evaluator(g, pars, out):
    """Eqs. 9–11: elastic ``K A n`` (or ``K sqrt(A) sqrt(A_min)``), damping, Coulomb friction.

    Damping: a share ``zeta`` of critical for the normal stiffness per penetration depth
    (``K width`` for the linear law), plus the eq. 11 viscosity ``-A eta v_rel``. No cut-off of
    attractive damping forces, so a linear face contact has restitution
    ``exp(-zeta pi / sqrt(1 - zeta²))``. Friction: tangential viscous force capped at
    ``mu |F_n|``.
    """
    collision_force(g, pars[CP.sqrt_area], pars[CP.damping_ratio], pars[CP.viscosity],
                    pars[CP.friction], math.inf, out)


class Collision(ContactLaw):
    """Independent elements: elastic repulsion by overlap area (eqs. 9–11), no joints."""

    bounded_damping = True  # its dampers go through step_damper (siku_core.contact.damping)
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
