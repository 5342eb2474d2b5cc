"""Radiation memory of heave, roll and pitch by the impulse response (Cummins 1962), for
``radiation = "memory"`` of the ``floating`` process.

Cummins' equation for each mode ``x`` (heave ζ [m] with mass ``m`` [kg] and stiffness ``C =
rho_w g A`` [N/m]; the slopes along the principal axes with inertia ``I_k`` [kg m²] and
stiffness ``C_k`` [N m], ``siku_plugins.floating.process``):

    (m + A_inf) x'' + ∫_0^t K(t - τ) x'(τ) dτ + C x = F_exc(t),
    K(t) = (2/π) ∫_0^∞ B(ω) cos(ωt) dω                          [kg/s² or kg m²/s²]

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

The convolution is advanced on the sub-steps with a ring buffer of the last ``L`` rates of
each mode per element (:func:`advance_modes`; memory ``24 L`` bytes per element, work ``6 L``
flops per element and sub-step), carried in restarts as the process's history. Modes are
decoupled (the diagonal of capytaine's matrices: a prism in its principal axes couples none of
the three to another).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core.errors import SceneError
from siku_core.records import record_type

from .kernels import attenuation, excite, wave_frame

#: the kernels and ring buffers of the memory force (:meth:`Memory.kernels`)
RadiationMemory = record_type("RadiationMemory", __name__, [
    ("K", "f", 3, "(S, 3, L) retardation kernel per shape and mode, sampled on the sub-steps "
     "[kg/s², kg m²/s²]"),
    ("kidx", "i", 1, "(n,) each element's shape"),
    ("hist", "f", 3, "(n, 3, L) ring buffers of the modes' rates [m/s, 1/s]"),
    ("head", "n", 0, "where the latest rates are in the ring buffers"),
], doc="Cummins' memory force of ``radiation = \"memory\"`` (empty arrays without it).")


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
def lagged(Ki, row, hp, L):
    """``Σ_{j=1}^{L-1} Ki[j] row[(hp + 1 - j) mod L]`` in two contiguous runs."""
    acc = 0.0
    top = min(hp + 1, L - 1)
    for j in range(1, top + 1):
        acc += Ki[j] * row[hp + 1 - j]
    for j in range(top + 1, L):
        acc += Ki[j] * row[hp + 1 - j + L]
    return acc


@njit(cache=True, error_model="numpy")
def advance_modes(n_sub, dt, t0, q, bod, pts, wav, mem, mot):
    """``n_sub`` sub-steps of ``dt`` [s] from ``t0`` of heave and the two principal slopes of
    every free element, each mode with its memory force ``mu = dt Σ_j w_j K_j x'_{n-j}``
    (velocity Verlet as ``siku_plugins.floating.kernels.advance``, whose records ``bod, pts,
    wav, mot`` it takes; ``mu`` explicit in the first half kick, its ``K_0`` term implicit in
    the second). ``mem`` (:data:`RadiationMemory`): ``K (S, 3, L)`` per shape and mode (heave,
    slope 1, slope 2), ``kidx`` each element's shape; ``hist (n, 3, L)`` the ring buffers of
    the rates, ``hist[i, k, head]`` the latest. ``mot.power`` [W m-2] receives the memory
    force's power per area averaged over the sub-steps (trapezoid of ``mu x'``). Element ``i``
    feels the amplitudes ``wav.acell[wav.cell[i]]`` [m] (``kernels.advance``)."""
    lat0, lon0, R, depth, rho_g = wav.lat0, wav.lon0, wav.R, wav.depth, bod.rho_g
    free, cphi, sphi, draft, h, area = bod.free, bod.cphi, bod.sphi, bod.draft, bod.h, bod.area
    M3, M1, C1, M2, C2 = bod.M3, bod.M1, bod.C1, bod.M2, bod.C2
    kx, kk, acell, cell = wav.kx, wav.k, wav.acell, wav.cell
    K, kidx, hist, head = mem.K, mem.kidx, mem.hist, mem.head
    z, vz, roll, roll_rate = mot.heave, mot.heave_rate, mot.roll, mot.roll_rate
    pitch, pitch_rate, pw = mot.pitch, mot.pitch_rate, mot.power
    L = K.shape[2]
    natt = kx.shape[0]
    wave = natt > 0
    c0 = math.cos(lat0)
    att = np.empty(natt)
    hd = 0.5 * dt
    x = np.empty(3)
    v = np.empty(3)
    vh = np.empty(3)
    mu = np.empty(3)
    mm = np.empty(3)
    cc = np.empty(3)
    fk = np.empty(3)
    den = np.empty(3)
    for i in range(z.shape[0]):
        if not free[i]:
            continue
        xc, yc, e0, e1 = wave_frame(q, i, wave, R, c0, lat0, lon0)
        d = draft[i]
        for j in range(natt):
            att[j] = attenuation(kk[j], d, depth)
        ka = rho_g * area[i]
        amp = acell[cell[i]]
        f, g1, g2 = excite(t0, i, xc, yc, e0, e1, pts, amp, att, wav)
        c = cphi[i]
        s = sphi[i]
        sx = -pitch[i]
        sy = roll[i]
        wx = -pitch_rate[i]
        wy = roll_rate[i]
        x[0] = z[i]
        v[0] = vz[i]
        x[1] = sx * c + sy * s
        x[2] = -sx * s + sy * c
        v[1] = wx * c + wy * s
        v[2] = -wx * s + wy * c
        mm[0] = M3[i]
        mm[1] = M1[i]
        mm[2] = M2[i]
        cc[0] = 0.0
        cc[1] = C1[i]
        cc[2] = C2[i]
        Ki = K[kidx[i]]
        hp = head
        for m in range(3):
            mu[m] = dt * (0.5 * Ki[m, 0] * hist[i, m, hp]
                          + lagged(Ki[m], hist[i, m], (hp - 1) % L, L))
            den[m] = 1.0 + hd * 0.5 * dt * Ki[m, 0] / mm[m]
        e = -0.5 * (mu[0] * v[0] + mu[1] * v[1] + mu[2] * v[2])   # the memory force's work
        for k in range(n_sub):
            e += mu[0] * v[0] + mu[1] * v[1] + mu[2] * v[2]
            # heave: buoyancy and wave load saturate out of and under the water
            fk[0] = ka * (min(max(d - x[0] + f / area[i], 0.0), h[i]) - d)
            fk[1] = -cc[1] * x[1] + rho_g * g1
            fk[2] = -cc[2] * x[2] + rho_g * g2
            for m in range(3):
                vh[m] = v[m] + hd * (fk[m] - mu[m]) / mm[m]
                x[m] += dt * vh[m]
            if wave:
                f, g1, g2 = excite(t0 + (k + 1) * dt, i, xc, yc, e0, e1, pts, amp, att, wav)
            fk[0] = ka * (min(max(d - x[0] + f / area[i], 0.0), h[i]) - d)
            fk[1] = -cc[1] * x[1] + rho_g * g1
            fk[2] = -cc[2] * x[2] + rho_g * g2
            for m in range(3):
                rest = dt * lagged(Ki[m], hist[i, m], hp, L)
                v[m] = (vh[m] + hd * (fk[m] - rest) / mm[m]) / den[m]
                mu[m] = rest + 0.5 * dt * Ki[m, 0] * v[m]
            hp = (hp + 1) % L
            for m in range(3):
                hist[i, m, hp] = v[m]
        e += 0.5 * (mu[0] * v[0] + mu[1] * v[1] + mu[2] * v[2])
        pw[i] = e / (n_sub * area[i])
        z[i] = x[0]
        vz[i] = v[0]
        pitch[i] = -(x[1] * c - x[2] * s)
        roll[i] = x[1] * s + x[2] * c
        pitch_rate[i] = -(v[1] * c - v[2] * s)
        roll_rate[i] = v[1] * s + v[2] * c


#: the model's modes and capytaine's degrees of freedom (``siku_plugins.floating.hydro``)
MODES = (("heave", "Heave"), ("slope1", "Pitch"), ("slope2", "Roll"))


def shape_band(poly, h, d, rho, g, size, omega, cache_dir, where):
    """``(A, B)`` arrays ``(3, N)`` [kg, kg/s; kg m², kg m²/s] of capytaine's heave, slope 1
    and slope 2 coefficients of one shape (principal axes) at the band ``omega`` [rad/s],
    cached with the other hydro results (``siku_plugins.floating.hydro``)."""
    from . import hydro

    key = {**hydro.shape_key(poly, h, d, rho, g, size), "band": [float(w) for w in omega],
           "modes": [dof for _, dof in MODES]}

    def compute():
        bod = hydro.body(poly, d, h, size, where)
        out = []
        for _, dof in MODES:
            ab = [hydro.radiation(bod, dof, float(w), rho, g, where) for w in omega]
            out.append([[a for a, _ in ab], [b for _, b in ab]])
        return out

    vals = np.array(hydro.cached_value(cache_dir, "hydro-band", key, compute, where))
    return vals[:, 0], vals[:, 1]


class Memory:
    """The per-shape kernels, each element's shape and the ring buffers of the ``floating``
    process with ``radiation = "memory"`` (module docstring)."""

    def __init__(self, p, bodies, ctx, masses, stiffnesses, where):
        """``p``: the process's parameters; ``bodies``: its ``FloatingBodies``; ``masses``,
        ``stiffnesses``: the modes' masses without added mass and their stiffnesses."""
        from . import hydro

        st = ctx.state
        if p["coefficients"] != "capytaine":
            raise SceneError(f"{where}: radiation = 'memory' needs coefficients = 'capytaine' "
                             "(its B(omega) on a band gives the kernel)")
        hydro.capytaine_module(where)
        cache_dir = hydro.hydro_cache_dir(p["hydro_cache"], ctx.scene.base_dir, where)
        n = st.n
        self.kidx = np.zeros(n, dtype=np.int64)
        shapes: dict[tuple, int] = {}
        bands = []
        for i in np.flatnonzero(bodies.free):
            c, s = math.cos(bodies.phi[i]), math.sin(bodies.phi[i])
            poly = st.polygon(i) @ np.array([[c, -s], [s, c]])
            width = 2 * float(np.min(np.abs(poly).max(axis=0)))
            sz = p["mesh_size"] if p["mesh_size"] > 0 else width / 16.0
            key = (tuple(np.round(poly, 3).ravel()), round(bodies.h[i], 6),
                   round(bodies.draft[i], 6))
            if key not in shapes:
                wmax = p["memory_omega_max"] or math.sqrt(2 * math.pi * float(p["g"]) /
                                                          (6 * sz))
                nb = int(p["memory_bins"])
                omega = wmax * np.arange(1, nb + 1) / nb
                try:
                    A, B = shape_band(poly, bodies.h[i], bodies.draft[i], float(p["rho_water"]),
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
        #: ``(3, n)`` the modes' masses without added mass and their stiffnesses
        self.m, self.C = np.array(masses), np.array(stiffnesses)

    def build(self, bodies, dt_sub: float, tol: float, where: str):
        """Kernels at the sub-step ``dt_sub`` [s], ``A_inf (S, 3)``, the modes' masses
        ``bodies.M3, M1, M2`` (in place) and the ring buffers."""
        S = len(self.bands)
        Ks, self.a_inf, self.bound = [], np.zeros((S, 3)), np.zeros((S, 3))
        masses = (bodies.M3, bodies.M1, bodies.M2)
        for s, (omega, A, B, i) in enumerate(self.bands):
            sel = (self.kidx == s) & bodies.free
            row = []
            for k, (mode, _) in enumerate(MODES):
                K, bound = kernel(omega, B[k], dt_sub, tol)
                ainf = a_infinity(omega, A[k], K, dt_sub)
                wn = math.sqrt(self.C[k, i] / (self.m[k, i] + ainf))
                if not omega[-1] > wn:
                    raise SceneError(f"{where}: radiation = 'memory': the band up to "
                                     f"{omega[-1]:.3g} rad/s does not cover element {i}'s "
                                     f"{mode} natural frequency {wn:.3g} rad/s; raise "
                                     "memory_omega_max")
                row.append(K)
                self.a_inf[s, k] = ainf
                self.bound[s, k] = bound
                masses[k][sel] = self.m[k, sel] + ainf
            Ks.append(row)
            if not math.pi / dt_sub > 2 * omega[-1]:
                raise SceneError(f"{where}: radiation = 'memory': sub-steps of {dt_sub:.3g} s "
                                 f"alias the band up to {omega[-1]:.3g} rad/s; raise "
                                 "steps_per_period")
        L = max(len(k) for row in Ks for k in row)
        self.K = np.zeros((S, 3, L))
        for s, row in enumerate(Ks):
            for k, K in enumerate(row):
                self.K[s, k, :len(K)] = K
        self.dt = dt_sub
        self.hist = np.zeros((len(bodies.M3), 3, L))
        self.head = 0

    def kernels(self) -> tuple:
        """The :data:`RadiationMemory` record now (the ring buffers' head moves each step)."""
        return RadiationMemory(self.K, self.kidx, self.hist, self.head)
