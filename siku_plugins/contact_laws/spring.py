"""The distributed-spring law: a spring along each frozen joint, brittle failure (eqs. 12–13,
corrected; docs/explanation/physics.md §4.3)."""
from __future__ import annotations

import math

from numba import njit

from siku_core import Param
from siku_core.contact_law import (
    BREAK_STRAIN,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_K,
    J_L0,
    J_DTM,
    J_MEFF,
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

from siku_core.contact.damping import step_damper

from .collision import Collision


#: the distributed spring's joint parameter vector
SPRING_RECORD = ParameterRecord("tensile_strain", "joint_damping_ratio", "damage_onset")
SP = SPRING_RECORD.index


@njit(cache=True)
def _factor(hist):
    """The joint's strength factor ``exp(hist[1])``; 1 for a history row of one column (a law
    that wraps this evaluator with ``history_names = ("max_strain",)``)."""
    if hist.shape[0] < 2 or hist[1] == 0.0:
        return 1.0  # exp(0) = 1 exactly: the exponential only where a process set a factor
    return math.exp(hist[1])


@njit(cache=True)
def spring_evaluator(g, pars, hist, out):
    """Eqs. 12–13 (corrected): force ``K w (s1 + s2)/2``, couple ``K w (w × (s2 - s1))/12``.

    ``hist[0]`` is the largest strain ``max(|s1|, |s2|)/L0`` reached. The joint breaks when it
    exceeds its strength ``tensile_strain × exp(hist[1])`` (``hist[1]`` the joint's log
    strength factor, 0 unless a process such as ``joint_strength`` sets it); between
    ``damage_onset ×`` that strength and the strength the stiffness falls linearly to zero
    (damage depends on the strain history only, never on dt).
    Damping: a share ``zeta`` of critical for ``K w`` on the reduced mass, applied to the
    relative velocity distribution along the joint like the displacement, bounded by the step
    (:func:`~siku_core.contact.damping.step_damper`).
    """
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    strain = math.sqrt(max(s1x * s1x + s1y * s1y, s2x * s2x + s2y * s2y)) / g[J_L0]
    if strain > hist[0]:
        hist[0] = strain
    eps_t = pars[SP.tensile_strain] * _factor(hist)
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
    c = step_damper(2.0 * pars[SP.joint_damping_ratio] * math.sqrt(g[J_K] * w * g[J_MEFF]),
                    g[J_DTM])
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
    eps_t = pars[SP.tensile_strain] * _factor(hist)
    onset = pars[SP.damage_onset] * eps_t
    dmg = (hist[0] - onset) / (eps_t - onset) if hist[0] > onset and eps_t > onset else 0.0
    s1x, s1y, s2x, s2y = g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y]
    q = s1x * s1x + s1y * s1y + s2x * s2x + s2y * s2y + s1x * s2x + s1y * s2y
    return g[J_K] * (1.0 - dmg) * g[J_W] * q / 6.0


class DistributedSpring(Collision):
    """Coalesced elements: a distributed spring along each frozen joint, brittle failure."""

    bounded_damping = True  # (siku_core.contact.damping)
    name = "distributed_spring"
    uses_joints = True
    #: the largest strain reached, and the joint's log strength factor (``joint_strength``)
    history_names = ("max_strain", "log_strength")
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
