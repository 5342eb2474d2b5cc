"""Global diagnostics: energy and momentum about the planet centre."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry.quat import q_center, qrotate


@njit(cache=True)
def _sums(q, V, w, m, I, radius):  # noqa: E741
    ke = 0.0
    p = np.zeros(3)
    L = np.zeros(3)
    vmax = 0.0
    vsum = 0.0
    v3 = np.zeros(3)
    for i in range(q.shape[0]):
        vx, vy = V[i, 0], V[i, 1]
        s2 = vx * vx + vy * vy
        ke += 0.5 * m[i] * s2 + 0.5 * I[i] * w[i] * w[i]
        v3[0] = vx
        v3[1] = vy
        v3[2] = 0.0
        vg = qrotate(q[i], v3)
        c = q_center(q[i])
        for k in range(3):
            p[k] += m[i] * vg[k]
        # r × m v with r = R c, plus the spin angular momentum I w c
        L[0] += m[i] * radius * (c[1] * vg[2] - c[2] * vg[1]) + I[i] * w[i] * c[0]
        L[1] += m[i] * radius * (c[2] * vg[0] - c[0] * vg[2]) + I[i] * w[i] * c[1]
        L[2] += m[i] * radius * (c[0] * vg[1] - c[1] * vg[0]) + I[i] * w[i] * c[2]
        s = np.sqrt(s2)
        vsum += s
        if s > vmax:
            vmax = s
    return ke, p, L, vsum, vmax


def element_diagnostics(q, V, w, m, I, radius) -> dict[str, float]:  # noqa: E741
    """Kinetic energy [J], linear momentum [kg m/s] (global frame), angular momentum about the
    planet centre [kg m²/s] (orbital ``R c × m v`` plus spin ``I w c``), mean and max speed [m/s].
    """
    n = q.shape[0]
    ke, p, L, vsum, vmax = _sums(q, V, w, m, I, float(radius))
    return {
        "kinetic_energy": ke,
        "momentum_x": p[0], "momentum_y": p[1], "momentum_z": p[2],
        "angular_momentum_x": L[0], "angular_momentum_y": L[1], "angular_momentum_z": L[2],
        "mean_speed": vsum / n if n else 0.0,
        "max_speed": vmax,
    }


@njit(cache=True)
def all_finite(a):
    """Whether every value of the 1-D array ``a`` is finite (no temporary arrays)."""
    for k in range(a.shape[0]):
        if not math.isfinite(a[k]):
            return False
    return True


@njit(cache=True)
def fastest(V):
    """``(i, |V_i|²)`` of the element with the largest ``Vx² + Vy²`` (first on ties); ``(-1, 0)``
    without elements."""
    best = -1
    s2 = 0.0
    for i in range(V.shape[0]):
        v = V[i, 0] ** 2 + V[i, 1] ** 2
        if best < 0 or v > s2:
            best = i
            s2 = v
    return best, s2
