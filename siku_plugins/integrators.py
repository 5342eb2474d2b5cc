"""Built-in integrators: the report's second-order scheme and classical RK4.

Both move the element on the sphere with the body-frame angular velocity
``Omega = (-Vy/R, Vx/R, w)`` (eq. 3) and include the frame-rotation (gyroscopic) term of
Euler's equations with inertia ``diag(mR², mR², I)``::

    dV/dt = F/m - g w k × V,    dw/dt = T/I,    g = 1 - I/(m R²)

so that a spinning element keeps its translation velocity fixed in a non-spinning frame and
stays on its great circle (the report's eq. 8 omits that term). Static elements never move;
steady elements keep their local ``V, w`` and ignore forces.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from siku_core import hookimpl
from siku_core.geometry.quat import cayley_step
from siku_core.interfaces import Integrator
from siku_core.parallel import INTEGRATOR_NS, alone, chunk_bounds, chunks
from siku_core.state import FREE, STATIC


@njit(cache=True, parallel=True)
def _siku2(q, V, w, F, T, m, I, flags, R, dt, nch=1):  # noqa: E741
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        tmp = np.empty(4)
        for i in range(lo, hi):
            _siku2_one(q, V, w, F, T, m, I, flags, R, dt, i, tmp)


@njit(cache=True, inline="always")
def _siku2_one(q, V, w, F, T, m, I, flags, R, dt, i, tmp):  # noqa: E741
    f = flags[i]
    if f == STATIC:
        return
    if f == FREE:
        # kick: body-frame angular momentum L_b = (-m R Vy, m R Vx, I w) gains dt * torque
        V[i, 0] += dt * F[i, 0] / m[i]
        V[i, 1] += dt * F[i, 1] / m[i]
        w[i] += dt * T[i] / I[i]
        k = I[i] / (m[i] * R * R)
        # drift 1: rotation about L_b (eq. 6 with Omega_L = L_b / (m R^2))
        cayley_step(q[i], -V[i, 1] / R, V[i, 0] / R, k * w[i], dt, tmp)
        # drift 2: spin about the local vertical by gamma; L_b precesses by -gamma
        gamma = (1.0 - k) * w[i] * dt
        c, s = math.cos(0.5 * gamma), math.sin(0.5 * gamma)
        q[i, 0] = tmp[0] * c - tmp[3] * s
        q[i, 1] = tmp[1] * c + tmp[2] * s
        q[i, 2] = tmp[2] * c - tmp[1] * s
        q[i, 3] = tmp[3] * c + tmp[0] * s
        cg, sg = math.cos(gamma), math.sin(gamma)
        vx, vy = V[i, 0], V[i, 1]
        V[i, 0] = cg * vx + sg * vy
        V[i, 1] = -sg * vx + cg * vy
    else:  # steady: prescribed local velocity and spin, forces ignored
        cayley_step(q[i], -V[i, 1] / R, V[i, 0] / R, w[i], dt, tmp)
        q[i, 0] = tmp[0]
        q[i, 1] = tmp[1]
        q[i, 2] = tmp[2]
        q[i, 3] = tmp[3]


class Siku2(Integrator):
    """Kulchitsky et al. (2017)'s scheme: semi-implicit V, w update, then the eq. (6) rotation.

    One force evaluation per step. Kick: ``V += dt F/m``, ``w += dt T/I`` (the body-frame
    angular momentum ``L_b = (-m R Vy, m R Vx, I w)`` gains ``dt`` times the torque about the
    planet centre). Drift, split exactly for the symmetric inertia ``diag(mR², mR², I)``:
    ``q ∘ p(Omega_L) ∘ rz(gamma)`` with ``p`` the norm-preserving step of eq. (6) (with ``dt²``)
    about ``Omega_L = L_b/(m R²) = (-Vy/R, Vx/R, w I/(m R²))`` and ``rz`` a turn by
    ``gamma = (1 - I/(m R²)) w dt`` about the local vertical, while ``V`` turns by ``-gamma``
    (the frame-rotation term). Both drift rotations leave the global angular momentum
    unchanged, so pairwise-balanced contact torques conserve the angular momentum about the
    planet centre to round-off. Free motion (great circles, spin) is second order: only the
    angle of eq. (6) is approximate (``4 atan(|Omega| dt / 4)``); with forces the velocity
    update is first order (symplectic Euler).
    """

    name = "siku2"
    order = 2
    order_with_forces = 1
    force_evaluations = 1

    def step(self, state, t, dt, forces):
        forces(t, state.q, state.V, state.w, state.F, state.T)
        nch = chunks(state.n, INTEGRATOR_NS)
        with alone(nch):
            _siku2(state.q, state.V, state.w, state.F, state.T, state.m, state.I, state.flags,
                   self.radius, dt, nch)

    def setup(self, ctx):
        self.radius = float(ctx.radius)


@njit(cache=True)
def _rhs(q, V, w, F, T, m, I, flags, R, dq, dV, dw):  # noqa: E741
    for i in range(q.shape[0]):
        f = flags[i]
        if f == STATIC:
            dq[i, :] = 0.0
            dV[i, :] = 0.0
            dw[i] = 0.0
            continue
        ox, oy, oz = -V[i, 1] / R, V[i, 0] / R, w[i]
        a0, a1, a2, a3 = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        # dq/dt = 1/2 q ∘ (0, Omega)
        dq[i, 0] = 0.5 * (-a1 * ox - a2 * oy - a3 * oz)
        dq[i, 1] = 0.5 * (a0 * ox + a2 * oz - a3 * oy)
        dq[i, 2] = 0.5 * (a0 * oy - a1 * oz + a3 * ox)
        dq[i, 3] = 0.5 * (a0 * oz + a1 * oy - a2 * ox)
        if f == FREE:
            g = 1.0 - I[i] / (m[i] * R * R)
            dV[i, 0] = F[i, 0] / m[i] + g * w[i] * V[i, 1]
            dV[i, 1] = F[i, 1] / m[i] - g * w[i] * V[i, 0]
            dw[i] = T[i] / I[i]
        else:
            dV[i, :] = 0.0
            dw[i] = 0.0


@njit(cache=True)
def _axpy_state(q0, V0, w0, dq, dV, dw, h, q, V, w):
    """``y = y0 + h k`` with the quaternion projected back to unit norm."""
    for i in range(q0.shape[0]):
        s = 0.0
        for k in range(4):
            q[i, k] = q0[i, k] + h * dq[i, k]
            s += q[i, k] * q[i, k]
        s = 1.0 / math.sqrt(s)
        for k in range(4):
            q[i, k] *= s
        V[i, 0] = V0[i, 0] + h * dV[i, 0]
        V[i, 1] = V0[i, 1] + h * dV[i, 1]
        w[i] = w0[i] + h * dw[i]


class RK4(Integrator):
    """Classical 4th-order Runge–Kutta on ``(q, V, w)``, quaternion renormalised each stage.

    Four force evaluations per step (about four times the cost of ``siku2``). Contact laws that
    keep history update it on the first evaluation of each step only.
    """

    name = "rk4"
    order = 4
    order_with_forces = 4
    force_evaluations = 4

    def setup(self, ctx):
        self.radius = float(ctx.radius)
        n = ctx.state.n
        self.k = [(np.empty((n, 4)), np.empty((n, 2)), np.empty(n)) for _ in range(4)]
        self.y = (np.empty((n, 4)), np.empty((n, 2)), np.empty(n))
        self.FT = (np.empty((n, 2)), np.empty(n))

    def step(self, state, t, dt, forces):
        st = state
        R = self.radius
        q0, V0, w0 = st.q.copy(), st.V.copy(), st.w.copy()
        yq, yV, yw = self.y
        Fs, Ts = self.FT
        # stage 1 forces land in state.F/T, so the NaN guard and writers see them
        forces(t, q0, V0, w0, st.F, st.T)
        _rhs(q0, V0, w0, st.F, st.T, st.m, st.I, st.flags, R, *self.k[0])
        for s, (h, tc) in enumerate(((0.5 * dt, t + 0.5 * dt), (0.5 * dt, t + 0.5 * dt),
                                     (dt, t + dt)), start=1):
            _axpy_state(q0, V0, w0, *self.k[s - 1], h, yq, yV, yw)
            forces(tc, yq, yV, yw, Fs, Ts)
            _rhs(yq, yV, yw, Fs, Ts, st.m, st.I, st.flags, R, *self.k[s])
        dq = (self.k[0][0] + 2 * self.k[1][0] + 2 * self.k[2][0] + self.k[3][0]) / 6.0
        dV = (self.k[0][1] + 2 * self.k[1][1] + 2 * self.k[2][1] + self.k[3][1]) / 6.0
        dw = (self.k[0][2] + 2 * self.k[1][2] + 2 * self.k[2][2] + self.k[3][2]) / 6.0
        _axpy_state(q0, V0, w0, dq, dV, dw, dt, st.q, st.V, st.w)


@hookimpl
def siku_register_integrators():
    return [Siku2, RK4]
