"""Radiation memory of heave by the impulse response (Cummins 1962), for ``radiation =
"memory"`` of the ``floating`` process.

Cummins' equation for the heave ζ [m] of an element of mass ``m`` [kg] and stiffness ``C =
rho_w g A`` [N/m]:

    (m + A_inf) ζ'' + ∫_0^t K(t - τ) ζ'(τ) dτ + C ζ = F_exc(t),
    K(t) = (2/π) ∫_0^∞ B(ω) cos(ωt) dω                                [kg/s²]

with ``B(ω)`` capytaine's radiation damping on a band ``ω_j = j Δω`` (``j = 1..N``), taken
piecewise linear through ``B(0) = 0`` (deep water), the band and ``B = 0`` at ``ω_N + Δω``
(:func:`kernel`). For that ``B_lin`` the transform is exact (two integrations by parts):

    K(t) = -(2 / (π t²)) [s_0 + Σ_j Δs_j cos(ω_j t)],   K(0) = (2/π) ∫ B_lin dω,

``s_0`` the first slope and ``Δs_j`` the change of slope at node ``j``; so ``|K(t)| <= 2 S /
(π t²)``, ``S = |s_0| + Σ |Δs_j|``. The kernel is sampled on the process's sub-steps ``δt`` and
truncated after ``L`` samples, the fewest for which the tail ``δt Σ_{j>=L} |K_j|`` (summed to a
horizon beyond which the analytic bound takes over) is at most ``tol max B``: that tail bounds
the error of the back transform ``B_back(ω) = δt Σ_{j<L} w_j K_j cos(ω t_j)`` (``w_0 = 1/2``,
else 1) against ``B_lin`` at any ``ω < 2π/δt - ω_N - Δω`` (no aliasing: ``B_lin`` vanishes
beyond). The infinite-frequency added mass is Ogilvie's (1964) relation ``A_inf = A(ω) + (1/ω)
∫_0^∞ K(t) sin(ωt) dt`` averaged over the band (so that ``A(ω)`` of the model matches
capytaine's in the band in the mean; capytaine's own ``A(∞)`` differs by the band's missing
tail, ``docs/explanation/floating.md``).

The convolution is advanced on the sub-steps with a ring buffer of the last ``L`` heave rates
per element (:func:`advance_heave`; memory ``8 L`` bytes per element, work ``2 L`` flops per
element and sub-step), carried in restarts as the process's history.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core.errors import SceneError
from siku_core.geometry.quat import east_north_row

from .kernels import _attenuation, _excite


def taper_bins(n: int) -> int:
    """Bins over which ``B`` goes linearly from ``B(omega_N)`` to 0 above the band: a quarter
    of the band (a gentle end keeps the kernel short)."""
    return max(1, math.ceil(n / 4))


def kernel(omega, B, dt: float, tol: float):
    """``(K, bound)``: the retardation kernel ``K_j = K(j dt)`` [kg/s²] of ``B(omega)`` (module
    docstring; ``omega`` [rad/s] uniform ``j Δω``, ``B`` [kg/s]) truncated where the tail
    ``bound = dt Σ_{j>=L} |K_j|`` [kg/s] first drops to ``tol max|B|``."""
    omega = np.asarray(omega, dtype=float)
    B = np.asarray(B, dtype=float)
    dw = omega[1] - omega[0]
    nt = taper_bins(len(omega))
    w = np.concatenate([[0.0], omega, omega[-1] + dw * np.arange(1, nt + 1)])
    f = np.concatenate([[0.0], B, B[-1] * (1.0 - np.arange(1, nt + 1) / nt)])
    s = np.diff(f) / np.diff(w)
    ds = np.concatenate([np.diff(s), [-s[-1]]])   # at nodes 1.. and at the taper's end
    nodes = w[1:]
    S = abs(s[0]) + np.sum(np.abs(ds))
    target = tol * float(np.max(np.abs(B)))
    # beyond the horizon T_b the analytic tail 2 S / (pi T_b) is at most target / 2
    horizon = 4.0 * S / (math.pi * target)
    n = int(math.ceil(horizon / dt)) + 1
    t = dt * np.arange(n)
    K = np.empty(n)
    K[0] = (2 / math.pi) * np.trapezoid(f, w)
    tt = t[1:]
    acc = np.full(n - 1, s[0])
    for wj, dj in zip(nodes, ds):
        acc += dj * np.cos(wj * tt)
    K[1:] = -(2.0 / (math.pi * tt * tt)) * acc
    tail = dt * np.cumsum(np.abs(K[::-1]))[::-1] + 2.0 * S / (math.pi * t[-1])
    L = int(np.argmax(tail <= target)) if np.any(tail <= target) else n
    L = max(L, 2)
    bound = float(tail[L]) if L < n else 2.0 * S / (math.pi * t[-1])
    return K[:L].copy(), bound


def transform(K, dt: float, omega):
    """``(B_back, A_back - A_inf)`` [kg/s, kg] of a sampled kernel at ``omega`` [rad/s]: the
    discrete cosine and sine transforms with the convolution's weights (``w_0 = 1/2``)."""
    t = dt * np.arange(len(K))
    wts = np.ones(len(K))
    wts[0] = 0.5
    om = np.atleast_1d(np.asarray(omega, dtype=float))[:, None]
    Bb = dt * np.sum(wts * K * np.cos(om * t), axis=1)
    Ab = -dt * np.sum(wts * K * np.sin(om * t), axis=1) / om[:, 0]
    return Bb, Ab


def a_infinity(omega, A, K, dt: float) -> float:
    """Ogilvie's ``A_inf = A(ω) + (1/ω) ∫ K sin(ωt) dt`` averaged over the band [kg]."""
    _, Ab = transform(K, dt, omega)
    return float(np.mean(np.asarray(A) - Ab))


@njit(cache=True, inline="always")
def _lagged(Ki, row, hp, L):
    """``Σ_{j=1}^{L-1} Ki[j] row[(hp + 1 - j) mod L]`` in two contiguous runs."""
    acc = 0.0
    top = min(hp + 1, L - 1)
    for j in range(1, top + 1):
        acc += Ki[j] * row[hp + 1 - j]
    for j in range(top + 1, L):
        acc += Ki[j] * row[hp + 1 - j + L]
    return acc


@njit(cache=True)
def advance_heave(n_sub, dt, t0, q, free, lat0, lon0, R, qoff, qa, qb, qu, qv, qw, amp, kx,
                  ky, om, ph, kk, depth, kap, ramp, rho_g, draft, h, area, M3, K, kidx, hist,
                  head, z, vz):
    """``n_sub`` sub-steps of ``dt`` [s] from ``t0`` of the heave of every free element with
    the memory force ``mu = dt Σ_j w_j K_j ζ'_{n-j}`` (velocity Verlet as
    ``siku_plugins.floating.kernels.advance``; ``mu`` explicit in the first half step, its
    ``K_0`` term implicit in the second). ``K (S, L)`` per shape, ``kidx`` each element's
    row; ``hist (n, L)`` the ring buffer of heave rates, ``hist[i, head]`` the latest."""
    L = K.shape[1]
    natt = amp.shape[0]
    wave = natt > 0
    c0 = math.cos(lat0)
    att = np.empty(natt)
    hd = 0.5 * dt
    for i in range(z.shape[0]):
        if not free[i]:
            continue
        xc = 0.0
        yc = 0.0
        e0 = 1.0
        e1 = 0.0
        if wave:
            zq = 1.0 - 2.0 * (q[i, 1] * q[i, 1] + q[i, 2] * q[i, 2])
            x3 = 2.0 * (q[i, 1] * q[i, 3] + q[i, 0] * q[i, 2])
            y3 = 2.0 * (q[i, 2] * q[i, 3] - q[i, 0] * q[i, 1])
            lat = math.asin(max(-1.0, min(1.0, zq)))
            lon = math.atan2(y3, x3)
            dl = lon - lon0
            if dl > math.pi:
                dl -= 2.0 * math.pi
            elif dl < -math.pi:
                dl += 2.0 * math.pi
            xc = R * c0 * dl
            yc = R * (lat - lat0)
            e0, e1, _, _ = east_north_row(q, i)
        d = draft[i]
        for j in range(natt):
            att[j] = _attenuation(kk[j], d, depth)
        lo, hi = qoff[i], qoff[i + 1]
        ka = rho_g * area[i]
        f, _, _ = _excite(t0, i, xc, yc, e0, e1, lo, hi, qa, qb, qu, qv, qw, amp, kx, ky, om,
                          ph, att, kap, ramp)
        Ki = K[kidx[i]]
        m3 = M3[i]
        zi, vzi = z[i], vz[i]
        hp = head
        mu = dt * (0.5 * Ki[0] * hist[i, hp] + _lagged(Ki, hist[i], (hp - 1) % L, L))
        den = 1.0 + hd * 0.5 * dt * Ki[0] / m3
        for k in range(n_sub):
            fh = ka * (min(max(d - zi + f / area[i], 0.0), h[i]) - d)
            vzh = vzi + hd * (fh - mu) / m3
            zi += dt * vzh
            if wave:
                f, _, _ = _excite(t0 + (k + 1) * dt, i, xc, yc, e0, e1, lo, hi, qa, qb, qu,
                                  qv, qw, amp, kx, ky, om, ph, att, kap, ramp)
            fh = ka * (min(max(d - zi + f / area[i], 0.0), h[i]) - d)
            rest = dt * _lagged(Ki, hist[i], hp, L)
            vzi = (vzh + hd * (fh - rest) / m3) / den
            mu = rest + 0.5 * dt * Ki[0] * vzi
            hp = (hp + 1) % L
            hist[i, hp] = vzi
        z[i] = zi
        vz[i] = vzi


def shape_band(poly, h, d, rho, g, size, omega, cache_dir, where):
    """``(A, B)`` lists [kg, kg/s] of capytaine's heave coefficients of one shape at the band
    ``omega`` [rad/s], cached with the other hydro results (``siku_plugins.floating.hydro``)."""
    from . import hydro

    key = {**hydro._shape_key(poly, h, d, rho, g, size), "band": [float(w) for w in omega]}

    def compute():
        bod = hydro.body(poly, d, h, size, where)
        ab = [hydro.radiation(bod, "Heave", float(w), rho, g, where) for w in omega]
        return [[a for a, _ in ab], [b for _, b in ab]]

    A, B = hydro._cached(cache_dir, "hydro-band", key, compute, where)
    return np.array(A), np.array(B)


class Memory:
    """The per-shape kernels, each element's shape and the ring buffer of the ``floating``
    process with ``radiation = "memory"`` (module docstring)."""

    def __init__(self, proc, ctx, m, C3, where):
        from . import hydro

        p = proc.p
        st = ctx.state
        if p["coefficients"] != "capytaine":
            raise SceneError(f"{where}: radiation = 'memory' needs coefficients = 'capytaine' "
                             "(its B(omega) on a band gives the kernel)")
        if proc.beams is not None or proc.load.any():
            raise SceneError(f"{where}: radiation = 'memory' is for elements that float "
                             "alone (not with bending = true or loads)")
        hydro._cpt(where)
        cache_dir = hydro._cache_dir(p["hydro_cache"], ctx.scene.base_dir, where)
        n = st.n
        self.kidx = np.zeros(n, dtype=np.int64)
        shapes: dict[tuple, int] = {}
        bands = []
        for i in np.flatnonzero(proc.free):
            c, s = math.cos(proc.phi[i]), math.sin(proc.phi[i])
            poly = st.polygon(i) @ np.array([[c, -s], [s, c]])
            width = 2 * float(np.min(np.abs(poly).max(axis=0)))
            sz = p["mesh_size"] if p["mesh_size"] > 0 else width / 16.0
            key = (tuple(np.round(poly, 3).ravel()), round(proc.h[i], 6),
                   round(proc.draft[i], 6))
            if key not in shapes:
                wmax = p["memory_omega_max"] or math.sqrt(2 * math.pi * float(p["g"]) /
                                                          (6 * sz))
                nb = int(p["memory_bins"])
                omega = wmax * np.arange(1, nb + 1) / nb
                try:
                    A, B = shape_band(poly, proc.h[i], proc.draft[i], float(p["rho_water"]),
                                      float(p["g"]), sz, omega, cache_dir, where)
                except SceneError:
                    raise
                except Exception as exc:  # noqa: BLE001 - capytaine's own failures
                    raise SceneError(f"{where}: capytaine could not solve element {i}'s "
                                     f"prism ({type(exc).__name__}: {exc})") from None
                shapes[key] = len(bands)
                bands.append((omega, A, B, i))
            self.kidx[i] = shapes[key]
        self.bands = bands
        self.m, self.C3 = m, C3

    def build(self, proc, dt_sub: float, tol: float, where: str):
        """Kernels at the sub-step ``dt_sub`` [s], ``A_inf`` per shape, the heave masses
        ``proc.M3`` and the ring buffer."""
        Ks, self.a_inf, self.bound = [], [], []
        M3 = proc.M3
        for s, (omega, A, B, i) in enumerate(self.bands):
            K, bound = kernel(omega, B, dt_sub, tol)
            ainf = a_infinity(omega, A, K, dt_sub)
            wn = math.sqrt(self.C3[i] / (self.m[i] + ainf))
            if not omega[-1] > wn:
                raise SceneError(f"{where}: radiation = 'memory': the band up to "
                                 f"{omega[-1]:.3g} rad/s does not cover element {i}'s heave "
                                 f"natural frequency {wn:.3g} rad/s; raise memory_omega_max")
            if not math.pi / dt_sub > 2 * omega[-1]:
                raise SceneError(f"{where}: radiation = 'memory': sub-steps of {dt_sub:.3g} s "
                                 f"alias the band up to {omega[-1]:.3g} rad/s; raise "
                                 "steps_per_period")
            Ks.append(K)
            self.a_inf.append(ainf)
            self.bound.append(bound)
            sel = self.kidx == s
            M3[sel & proc.free] = self.m[sel & proc.free] + ainf
        L = max(len(k) for k in Ks)
        self.K = np.zeros((len(Ks), L))
        for s, k in enumerate(Ks):
            self.K[s, :len(k)] = k
        self.dt = dt_sub
        self.hist = np.zeros((len(M3), L))
        self.head = 0
