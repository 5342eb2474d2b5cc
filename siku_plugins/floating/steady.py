"""The linear steady state of a bending floe in a monochromatic sea, and a thin plate's.

With ``bending = true`` (``siku_plugins.floating.bending``) and constant added mass and damping
the ``floating`` process integrates, inside its clamp (no element out of the water or under
it), the linear system

    M u'' + B u' + (K + C) u = r(t) Re[F e^{-i omega t}]

over the ``3 n`` degrees of freedom ``u`` (heave [m], slopes along the principal axes) of ``n``
elements: ``M``, ``B``, ``C`` diagonal (inertia with added mass, damping, hydrostatic
restoring), ``K`` the beams' stiffness, ``F`` the Froude–Krylov loads of the wave component
(``rho_w g a e^{-k d} ∫ (1, u, v) e^{i (k·x + phi)} dA`` over each element's bottom, on the
process's own quadrature points) and ``r(t) = (1 - cos(pi t / T_r)) / 2`` the ramp. Its steady
state is ``u = Re[H(omega) F e^{-i omega t}]``, ``H = (K + C - omega² M - i omega B)^{-1}``.
For the slowly rising amplitude of the ramp, expanding ``H(omega + delta)`` about ``omega``
(``delta`` acts on the envelope as ``i d/dt``):

    u(t) = Re[e^{-i omega t} sum_m i^m r^(m)(t) H^(m) F / m!]
         = Re[e^{-i omega t} (r H F + i r' H' F - r'' H'' F / 2 - i r''' H''' F / 6 + ...)]

with ``Z = K + C - omega² M - i omega B`` and ``Z H^(m) F = -(m Z' H^(m-1) F + m (m - 1) / 2
Z'' H^(m-2) F)``, ``Z' = -2 omega M - i B``, ``Z'' = -2 M`` (:class:`Steady` keeps ``m <= 4``:
the prediction to ``m = 3``, the next term its error). The bending stress at a joint is linear
in ``u``, so it is the same series of complex amplitudes per joint. The series is not at rest
at ``t = 0`` (``r''(0) = (pi / T_r)² / 2``): the start leaves a free oscillation of at most
``r''(0) |H'' F| / 2``, which decays at least as ``e^{-gamma t}``, ``gamma = min B / (2 M)``
over the degrees of freedom (with ``u = e^{-gamma t} y`` the free motion's ``y`` has the
damping ``B - 2 gamma M >= 0`` and the stiffness ``K + C - gamma B + gamma² M``, positive while
``gamma B < C``, so its energy does not grow).

For an infinite plate of thickness ``h`` (flexural rigidity ``D = E h³ / (12 (1 - nu²))``,
characteristic length ``l = (D / rho_w g)^{1/4}``) the same equations, with ``mu = (m +
A33) / (rho_w g A)`` [s²] and ``beta = B33 / (rho_w g A)`` [s] per unit area, give the bending
stress of a wave of amplitude ``a`` and wavenumber ``k`` as :func:`thin_plate`: the stress of a
plate that follows the wave, ``E h a k² e^{-k d} / (2 (1 - nu²))``, times ``|H|``, ``H = 1 / (1
+ (k l)^4 - omega² mu - i omega beta)``; its envelope lags the load's by the group delay
``tau = d arg H / d omega = beta (1 + (k l)^4 + omega² mu) |H|²`` (to first order in the ramp's
rate the ``i r' H'`` term above is ``r(t - tau) H``, the rest of it changing the amplitude only
at second order). Elements of side ``s`` along the wave average the load over their length and
the joint's curvature is the difference of the two elements' slopes over ``s``: each a factor
``sin(k s / 2) / (k s / 2)``, to ``O((k s)^4)``; the moment of the weight of a tilted element
about its centre of buoyancy (the ``A d (h - d) / 2`` of its restoring, which a thin plate does
not have) changes the stress by about ``k² d (h - d) / 2`` more.
"""
from __future__ import annotations

import math

import numpy as np

#: derivatives in omega that :class:`Steady` keeps
ORDERS = 4


def ramp(t, T_r: float, order: int = 0):
    """The ramp ``r(t) = (1 - cos(pi t / T_r)) / 2`` (1 after ``T_r``) or its derivative of
    ``order`` [1/s^order] (from ``t = 0`` on, 0 after ``T_r``), at times ``t`` [s]."""
    t = np.asarray(t, dtype=float)
    w = math.pi / T_r
    x = w * np.clip(t, 0.0, T_r)
    if order == 0:
        return np.where(t >= T_r, 1.0, 0.5 * (1 - np.cos(x)))
    # d^m/dt^m of -cos(w t) / 2 is -w^m cos(w t + m pi / 2) / 2
    return np.where((t >= 0) & (t < T_r), -0.5 * w**order * np.cos(x + order * math.pi / 2),
                    0.0)


class Steady:
    """The linear steady state of the ``floating`` process ``proc`` (``bending = true``,
    constant coefficients) in its scene's monochromatic wave field (module docstring): complex
    amplitudes per joint of the bending stress [Pa] of ``H F`` and of its first three
    derivatives in ``omega`` (``S[0..3]``), for the elements where they are now."""

    def __init__(self, proc, ctx):
        from scipy.sparse import csr_matrix, diags
        from scipy.sparse.linalg import splu

        from .kernels import attenuation, centres_and_frames

        fld = proc.field
        bod, pts = proc.bodies, proc.points
        if (fld is None or len(fld.amp) != 1 or proc.beams is None or proc.memory is not None
                or proc.kap.shape[0] or getattr(fld, "local_sea", False)):
            raise ValueError("Steady needs a floating process with bending = true, constant "
                             "coefficients, no diffraction and a uniform one-component wave "
                             "field (not a spectral sea that the ice damps)")
        st = ctx.state
        n = st.n
        lat, lon, e0, e1 = centres_and_frames(st.q)
        xc, yc = fld.plane(lat, lon)
        self.omega = w = float(fld.omega[0])
        self.k = float(fld.k[0])
        att = np.array([attenuation(self.k, d, float(fld.h)) for d in bod.draft])
        F = np.zeros(3 * n, dtype=complex)
        for i in np.flatnonzero(bod.free):
            lo, hi = pts.qoff[i], pts.qoff[i + 1]
            qa, qb = pts.qa[lo:hi], pts.qb[lo:hi]
            xe = xc[i] + qa * e0[i] + qb * e1[i]
            yn = yc[i] - qa * e1[i] + qb * e0[i]
            wz = pts.qw[lo:hi] * np.exp(1j * (fld.kx[0] * xe + fld.ky[0] * yn + fld.phase[0]))
            s = bod.rho_g * fld.amp[0] * att[i]
            F[3 * i:3 * i + 3] = s * np.array([wz.sum(), (pts.qu[lo:hi] * wz).sum(),
                                               (pts.qv[lo:hi] * wz).sum()])
        M = np.column_stack([bod.M3, bod.M1, bod.M2]).ravel()
        B = np.column_stack([bod.B3, bod.B1, bod.B2]).ravel()
        C = np.column_stack([bod.C3, bod.C1, bod.C2]).ravel()
        bm = proc.beams
        K = csr_matrix((bm.data, bm.indices, bm.indptr), shape=(3 * n, 3 * n))
        keep = np.repeat(bod.free, 3)
        Z = (K + diags(C - w * w * M - 1j * w * B)).tocsc()[keep][:, keep]
        lu = splu(Z.tocsc())
        z1 = (-2 * w * M - 1j * B)[keep]
        z2 = -2 * M[keep]
        # H^(m) F from Z u = F: u^(m) = -H (m Z' u^(m-1) + m (m - 1) / 2 Z'' u^(m-2))
        us = [lu.solve(F[keep])]
        for m in range(1, ORDERS + 1):
            rhs = m * z1 * us[-1] + (m * (m - 1) / 2 * z2 * us[-2] if m > 1 else 0)
            us.append(-lu.solve(rhs))
        u0 = us[0]
        hv = np.zeros(n, dtype=complex)
        hv[bod.free] = u0[0::3]
        #: complex heave [m] of the steady state and the wave's head ∫ eta_d dA / A [m] per
        #: element: the buoyancy's clamp is not reached while |heave - head| < min(d, h - d)
        self.heave, self.head = hv, F[0::3] / (bod.rho_g * bod.area)
        self.S = []
        for v in us:
            full = np.zeros(3 * n, dtype=complex)
            full[keep] = v
            self.S.append(bm.stress(full.real) + 1j * bm.stress(full.imag))
        self.x_joint = 0.5 * (xc[bm.ji] + xc[bm.jj])     # east [m] of the joints' midpoints

    def stress(self, t: float, T_r: float, order: int = 3) -> np.ndarray:
        """Bending stress [Pa] at every joint at time ``t`` [s] under the ramp ``T_r`` [s],
        with the adiabatic series to ``order`` (0: the steady state times ``r(t)``)."""
        z = sum((1j ** m / math.factorial(m)) * ramp(t, T_r, m) * self.S[m]
                for m in range(order + 1))
        return (z * np.exp(-1j * self.omega * t)).real

    def first_break(self, strength: float, T_r: float, dt: float, t_max: float,
                    order: int = 3) -> tuple[int, int, float, float]:
        """The first step ``n`` (time ``n dt``, ``n dt <= t_max``) whose end sees a joint's
        ``|stress|`` above ``strength`` [Pa], as the process checks it, the joint, and the
        margins ``max |sigma| / strength - 1`` at steps ``n - 1`` and ``n``; ``(-1, -1, nan,
        nan)`` if none."""
        prev = -math.inf
        for n in range(1, int(math.floor(t_max / dt + 1e-9)) + 1):
            s = np.abs(self.stress(n * dt, T_r, order))
            j = int(np.argmax(s))
            if s[j] > strength:
                return n, j, prev, s[j] / strength - 1
            prev = s[j] / strength - 1
        return -1, -1, math.nan, math.nan


def thin_plate(E, nu, h, a, omega, k, rho_w, g, rho_i, mu, beta):
    """An infinite floating thin plate (module docstring) in a deep-water wave of amplitude
    ``a`` [m], frequency ``omega`` [rad/s], wavenumber ``k`` [1/m]: ``(sigma_follow, H, tau)``,
    the bending stress [Pa] of a plate that follows the wave, the complex response ``H`` (the
    plate's stress is ``|H| sigma_follow``) and its group delay ``tau`` [s]; ``mu``, ``beta``
    [s², s] its inertia with added mass and damping per unit hydrostatic stiffness."""
    d = h * rho_i / rho_w
    D = E * h**3 / (12 * (1 - nu**2))
    kl4 = D * k**4 / (rho_w * g)
    H = 1.0 / (1 + kl4 - omega**2 * mu - 1j * omega * beta)
    sigma = E * h * a * k * k * math.exp(-k * d) / (2 * (1 - nu**2))
    tau = beta * (1 + kl4 + omega**2 * mu) * abs(H) ** 2
    return sigma, H, tau
