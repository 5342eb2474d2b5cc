"""Contact dampers that cannot destabilise the step: each damper bounded by what one step can
carry on its share of the two elements' masses.

A contact's damper (a joint's or a collision's: force ``-c v`` on the velocity ``v`` of ``j``
relative to ``i`` at the contact, with ``c = 2 zeta sqrt(k m)`` a share ``zeta`` of critical)
is applied by the integrator to the old velocity (semi-implicit Euler). Explicit, a damper
whose rate exceeds what one step resolves overshoots; and an element's dampers add up: six
joints of a small cell, sized from the pair's translational reduced mass, act on its rotation
at the joints' lever arms with a rate of about three times its frequency. The scheme needs
``omega² dt² + 2 gamma dt < 4`` in every mode (``gamma``: the damping rate), so the damping,
not the stiffness, set the step (the default scene: 1.66 s against 5.70 s undamped).

The engine bounds each damper by the rate one step can carry on the pair's share of the two
elements' masses, each element's mass split evenly between the dampers that can act on it
(the *mass splitting* of parallel contact solvers):

    c' = min(c, phi m_d / dt),     1 / m_d = n_i (1/m_i + r_i² / I_i) + n_j (1/m_j + r_j² / I_j)

(:func:`step_damper`; ``n`` an element's intact joints plus one collision per edge, ``r`` the
contact's largest lever arm about the element's centre, ``m``, ``I`` mass and moment of
inertia, no term for a static or steady element; ``phi`` = :data:`DAMPER_SHARE`). A damper the
step can carry acts exactly as written (the same bits); only an over-damped one is cut, and
every damper returns to ``c`` as ``dt -> 0``. Equilibria and rigid motions are untouched (a
damper acts on relative velocity only).

Why it holds the step: by the Cauchy–Schwarz inequality each contact's ``c' |v_rel|²`` is at
most ``phi / dt`` times its share of twice the two elements' kinetic energy, so the damping
matrix satisfies ``dt C' <= phi M``; at ``phi < 2`` that alone makes the scheme stable for
``omega dt < sqrt(4 - 2 phi)``. The bound is loose on meshes (the split's factor 2, a collision
counted on every edge beside each joint): ``phi = 4`` keeps 2–4 times more damping, and the
stable-step estimate (``siku_core.contact.stable_step``) measures the bounded dampers' largest rate
``gamma'`` at the undamped limit ``h = 2 / omega`` and takes ``dt_c = sqrt(4 - 2 h gamma'(h)) /
omega`` (``h gamma'(h)`` only grows with ``h``): on the test packs 0.77–0.84 of ``2 / omega``,
within the exact limit of the integrator's amplification matrix.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..state import FREE

#: ``phi``: a damper may reach ``phi m_d / dt`` (``dt C' < phi M``, see the module)
DAMPER_SHARE = 4.0


@njit(cache=True, inline="always")
def step_damper(c, dtm):
    """The damping coefficient [N s/m] a damper ``c`` [N s/m] exerts in a step: ``c`` itself
    where ``c dtm <= 1``, else ``1 / dtm``; ``dtm = dt / (phi m_d)`` [s/kg] the contact's
    ``g[J_DTM]`` or ``g[G_DTM]`` (0: no bound)."""
    if c * dtm > 1.0:
        return 1.0 / dtm
    return c


@njit(cache=True, inline="always")
def damping_mobility(dmob, i, j, ri2, rj2):
    """``1 / m_d`` [1/kg] of a contact between ``i`` and ``j`` with squared lever arms ``ri2``,
    ``rj2`` [m²]: ``dmob[e] = (n_e / m_e, n_e / I_e)`` (zeros for a static or steady element)."""
    return dmob[i, 0] + ri2 * dmob[i, 1] + dmob[j, 0] + rj2 * dmob[j, 1]


def critical_step(omega: float, gamma: float, bounded: bool = True) -> float:
    """The critical step [s] of a mode of frequency ``omega`` [rad/s] with explicit damping rate
    ``gamma`` [1/s]: ``4 / (gamma + sqrt(gamma² + 4 omega²))``, and with the dampers bounded by
    :func:`step_damper` (``bounded``) at least ``sqrt(4 - 2 DAMPER_SHARE) / omega``."""
    if omega <= 0.0 and gamma <= 0.0:
        return math.inf
    explicit = 4.0 / (gamma + math.sqrt(gamma * gamma + 4.0 * omega * omega))
    if not bounded or omega <= 0.0:
        return explicit
    floor = 4.0 - 2.0 * DAMPER_SHARE
    return max(explicit, math.sqrt(floor) / omega) if floor > 0.0 else explicit


def mobility(flags, m, inertia, vert_offsets, ji, jj, intact, free_flag=FREE) -> np.ndarray:
    """Per element ``(n/m, n/I) / phi`` [1/kg, 1/(kg m²)] (zeros for an element that is not
    free; ``phi`` = :data:`DAMPER_SHARE`):
    ``n`` counts the dampers that can act on it, its intact joints plus one collision per edge
    (the rule of the stable-step estimate's collision budget, ``siku_core.contact.stable_step``). A
    function of the state alone (joints, masses, shapes), so a restart and any number of
    threads give the same dampers."""
    n = len(m)
    count = np.diff(vert_offsets).astype(np.float64)
    if len(ji):
        live = np.asarray(intact, dtype=bool)
        count += np.bincount(ji[live], minlength=n) + np.bincount(jj[live], minlength=n)
    free = flags == free_flag
    out = np.zeros((n, 2))
    out[free, 0] = count[free] / (DAMPER_SHARE * m[free])
    out[free, 1] = count[free] / (DAMPER_SHARE * inertia[free])
    return out


def contact_mobility(model) -> np.ndarray:
    """:func:`mobility` of a :class:`~siku_core.contact.contact_model.ContactModel`'s elements and
    joints (no joints under a law without them)."""
    st = model.state
    none = np.zeros(0, dtype=np.int64)
    ji, jj, live = ((model.ji, model.jj, model.intact) if model.n_joints and
                    model.law.uses_joints else (none, none, none))
    return mobility(st.flags, st.m, st.I, st.vert_offsets, ji, jj, live, FREE)
