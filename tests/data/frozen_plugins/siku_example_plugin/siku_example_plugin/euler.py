"""Forward Euler: the simplest integrator, first order, to show the integrator interface.

With ``Omega = (-Vy/R, Vx/R, w)`` the body-frame angular velocity on a sphere of radius ``R``,
and ``g = 1 - I/(m R²)`` the gyroscopic factor (see :mod:`siku_plugins.integrators`)::

    q(n+1) = normalise(q + dt/2 q ∘ (0, Omega))
    V(n+1) = V + dt (F/m - g w k × V)
    w(n+1) = w + dt T/I

all from the state at the start of the step. Static elements never move; steady elements move
with their prescribed ``V, w`` and ignore forces. Its global error falls as ``dt`` (order 1):
use it to illustrate, and ``siku2`` or ``rk4`` for real runs.
"""
from __future__ import annotations

import math

from numba import njit

from siku_core.interfaces import Integrator
from siku_core.state import FREE, STATIC


@njit(cache=True)
def _euler(q, V, w, F, T, m, I, flags, R, dt):  # noqa: E741
    for i in range(q.shape[0]):
        f = flags[i]
        if f == STATIC:
            continue
        vx, vy, wz = V[i, 0], V[i, 1], w[i]
        ox, oy, oz = -vy / R, vx / R, wz
        a0, a1, a2, a3 = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        h = 0.5 * dt
        b0 = a0 + h * (-a1 * ox - a2 * oy - a3 * oz)
        b1 = a1 + h * (a0 * ox + a2 * oz - a3 * oy)
        b2 = a2 + h * (a0 * oy - a1 * oz + a3 * ox)
        b3 = a3 + h * (a0 * oz + a1 * oy - a2 * ox)
        s = 1.0 / math.sqrt(b0 * b0 + b1 * b1 + b2 * b2 + b3 * b3)
        q[i, 0] = b0 * s
        q[i, 1] = b1 * s
        q[i, 2] = b2 * s
        q[i, 3] = b3 * s
        if f == FREE:
            g = 1.0 - I[i] / (m[i] * R * R)
            V[i, 0] = vx + dt * (F[i, 0] / m[i] + g * wz * vy)
            V[i, 1] = vy + dt * (F[i, 1] / m[i] - g * wz * vx)
            w[i] = wz + dt * T[i] / I[i]


class Euler(Integrator):
    """Forward Euler, 1st order: every update from the state at the start of the step.

    One force evaluation per step. For illustration and convergence tests only.
    """

    name = "euler"
    order = 1
    force_evaluations = 1

    def setup(self, ctx) -> None:
        self.radius = float(ctx.radius)

    def step(self, state, t, dt, forces):
        forces(t, state.q, state.V, state.w, state.F, state.T)
        _euler(state.q, state.V, state.w, state.F, state.T, state.m, state.I, state.flags,
               self.radius, dt)
