"""``fast_jonswap``: the ``jonswap`` sea in deep water, summed by recurrences instead of a sine
and a cosine per element and component.

The ``jonswap`` field's components lie on a regular grid: frequencies ``f_n = f_0 + n Δf``
(equal bins) times directions ``theta_d``, component ``j = n N_d + d``. In deep water ``k_n =
(2 pi f_n)² / g = K0 + K1 n + K2 n²`` is a quadratic in ``n``, and the phase of component ``j``
at a point is ``psi_j = k_n s_d - omega_n t + phi_j`` with ``s_d = x sin(theta_d) + y
cos(theta_d)``. So per point and direction

    exp(i k_n s) = Z_n,   Z_{n+1} = Z_n R_n,   R_{n+1} = R_n Q,
    Z_0 = exp(i K0 s),  R_0 = exp(i (K1 + K2) s),  Q = exp(2 i K2 s),

three complex exponentials per direction and two complex products per component, and
``exp(i psi_j) = Z_n exp(i (phi_j - omega_n t))`` with the second factor computed once per
evaluation for all points. The sums (elevation, slope, orbital velocity, curvature) are those of
:mod:`siku_forcing.waves.wave_field`, with the same components and phases as ``jonswap`` of the same
parameters and seed: the two fields agree to round-off (the recurrence over ``N_f`` frequencies
loses about ``N_f`` ulps; tested to 1e-12 of the summed amplitudes at every point). Deep water
only (``depth = -1``). The elements' loop runs in parallel (numba threads).
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numba import njit, prange

from siku_core import Param, SceneError, hookimpl
from siku_core.records import record_type

from .wave_kernels import add_slope_drag, local_plane, wrap_phase
from .wave_field import Jonswap


#: points per block of the sums: the innermost loops run over a block's points, which the
#: compiler can vectorise (the points are independent; the order of every sum is unchanged)
BLOCK = 64

#: the regular grid of the components and their recurrences (:meth:`FastJonswap.grid`);
#: component ``j = n N_d + d``
FastGrid = record_type("FastGrid", __name__, [
    ("GX", "f", 1, "(M,) amplitude times kx [1]"),
    ("GY", "f", 1, "(M,) amplitude times ky [1]"),
    ("UE", "f", 1, "(M,) orbital speed times sin(direction) [m/s]"),
    ("UN", "f", 1, "(M,) orbital speed times cos(direction) [m/s]"),
    ("nf", "n", 0, "frequencies N_f"),
    ("nd", "n", 0, "directions N_d"),
    ("sin_d", "f", 1, "(N_d,) sin of each direction of travel [1]"),
    ("cos_d", "f", 1, "(N_d,) cos of each direction [1]"),
    ("K0", "n", 0, "k_n = K0 + K1 n + K2 n²: K0 [rad/m]"),
    ("K1", "n", 0, "K1 [rad/m]"),
    ("K2", "n", 0, "K2 [rad/m]"),
], doc="The ``fast_jonswap`` sea's grid of components (module docstring).")


@njit(cache=True, parallel=True)
def _sums(lat, lon, w, fg, pc, ps):
    """Per point: eta, slope east/north, orbital u east/north of the sea ``w``
    (:data:`siku_forcing.waves.wave_field.PlaneWaves`: its plane and amplitudes ``A``) on the grid
    ``fg``
    (:data:`FastGrid`). Per component ``j``: ``GX``, ``GY`` = amplitude times ``kx``, ``ky``,
    ``UE``, ``UN`` = orbital speed times ``sin``, ``cos`` of the direction; ``pc + i ps =
    exp(i (phi_j - omega_j t))``."""
    lat0, lon0, R, A = w.lat0, w.lon0, w.R, w.amp
    GX, GY, UE, UN, nf, nd = fg.GX, fg.GY, fg.UE, fg.UN, fg.nf, fg.nd
    sin_d, cos_d, K0, K1, K2 = fg.sin_d, fg.cos_d, fg.K0, fg.K1, fg.K2
    n = lat.shape[0]
    nb = (n + BLOCK - 1) // BLOCK
    out = np.zeros((n, 5))
    c0 = math.cos(lat0)
    for b in prange(nb):
        i0 = b * BLOCK
        L = min(n, i0 + BLOCK) - i0
        x = np.empty(L)
        y = np.empty(L)
        m = np.empty(L)
        for q in range(L):
            x[q] = R * c0 * wrap_phase(lon[i0 + q] - lon0)
            y[q] = R * (lat[i0 + q] - lat0)
            m[q] = c0 / max(math.cos(lat[i0 + q]), 1e-12)
        eta, gx, gy, ue, un = np.zeros(L), np.zeros(L), np.zeros(L), np.zeros(L), np.zeros(L)
        zr, zi, rr, ri = np.empty(L), np.empty(L), np.empty(L), np.empty(L)
        qr, qi = np.empty(L), np.empty(L)
        for d in range(nd):
            for q in range(L):
                s = x[q] * sin_d[d] + y[q] * cos_d[d]
                zr[q] = math.cos(K0 * s)
                zi[q] = math.sin(K0 * s)
                rr[q] = math.cos((K1 + K2) * s)
                ri[q] = math.sin((K1 + K2) * s)
                qr[q] = math.cos(2.0 * K2 * s)
                qi[q] = math.sin(2.0 * K2 * s)
            for f in range(nf):
                j = f * nd + d
                a = A[j]
                g1 = GX[j]
                g2 = GY[j]
                u1 = UE[j]
                u2 = UN[j]
                p1 = pc[j]
                p2 = ps[j]
                for q in range(L):
                    c = zr[q] * p1 - zi[q] * p2  # cos(psi_j)
                    sv = zr[q] * p2 + zi[q] * p1  # sin(psi_j)
                    eta[q] += a * c
                    gx[q] -= g1 * sv
                    gy[q] -= g2 * sv
                    ue[q] += u1 * c
                    un[q] += u2 * c
                    t1 = zr[q] * rr[q] - zi[q] * ri[q]
                    zi[q] = zr[q] * ri[q] + zi[q] * rr[q]
                    zr[q] = t1
                    t2 = rr[q] * qr[q] - ri[q] * qi[q]
                    ri[q] = rr[q] * qi[q] + ri[q] * qr[q]
                    rr[q] = t2
        for q in range(L):
            out[i0 + q, 0] = eta[q]
            out[i0 + q, 1] = gx[q] * m[q]
            out[i0 + q, 2] = gy[q]
            out[i0 + q, 3] = ue[q] * m[q]
            out[i0 + q, 4] = un[q]
    return out


@njit(cache=True, parallel=True)
def _curvature(lat, lon, se, sn, w, fg, pc, ps):
    """Curvature ``d²eta/ds²`` [1/m] of the sea ``w`` on the grid ``fg`` (as :func:`_sums`)
    along unit directions ``(se, sn)`` at the points."""
    lat0, lon0, R, A, k = w.lat0, w.lon0, w.R, w.amp, w.k
    nf, nd, sin_d, cos_d, K0, K1, K2 = fg.nf, fg.nd, fg.sin_d, fg.cos_d, fg.K0, fg.K1, fg.K2
    n = lat.shape[0]
    out = np.zeros(n)
    c0 = math.cos(lat0)
    for i in prange(n):
        x, y, m = local_plane(lat[i], lon[i], lat0, lon0, c0, R)
        acc = 0.0
        for d in range(nd):
            s = x * sin_d[d] + y * cos_d[d]
            zr, zi = math.cos(K0 * s), math.sin(K0 * s)
            rr, ri = math.cos((K1 + K2) * s), math.sin((K1 + K2) * s)
            qr, qi = math.cos(2.0 * K2 * s), math.sin(2.0 * K2 * s)
            ks_dir = sin_d[d] * m * se[i] + cos_d[d] * sn[i]
            for f in range(nf):
                j = f * nd + d
                ks = k[j] * ks_dir
                acc -= A[j] * ks * ks * (zr * pc[j] - zi * ps[j])
                zr, zi = zr * rr - zi * ri, zr * ri + zi * rr
                rr, ri = rr * qr - ri * qi, rr * qi + ri * qr
        out[i] = acc
    return out


class FastJonswap(Jonswap):
    """The ``jonswap`` sea in deep water, summed by recurrences over frequency (module
    docstring): the same components, phases and forces, far fewer sines and cosines."""

    name = "fast_jonswap"
    params: ClassVar[dict[str, Param]] = {k: v for k, v in Jonswap.params.items()
                                           if k not in ("method", "tolerance")}

    def _build(self):
        if self.p["depth"] >= 0:
            raise SceneError(f"{self.where()}: deep water only (depth = -1); use jonswap for "
                             "finite depth")
        super()._build()
        p = self.p
        fp = 1.0 / p["tp"]
        nf, nd = p["n_frequencies"], p["n_directions"]
        edges = np.linspace(p["f_low"] * fp, p["f_high"] * fp, nf + 1)
        f = 0.5 * (edges[1:] + edges[:-1])
        if len(self.amp) != nf * nd:  # components of zero energy were dropped: no grid
            raise SceneError(f"{self.where()}: every component must carry energy (narrow the "
                             "band f_low..f_high or lower the spreading exponent)")
        th = np.radians(self.components()[2][:nd])
        c = 4.0 * math.pi**2 / p["g"]
        df = f[1] - f[0] if nf > 1 else 0.0
        self.nf, self.nd = nf, nd
        self.K = (c * f[0] ** 2, 2.0 * c * f[0] * df, c * df * df)
        self.sin_d, self.cos_d = np.sin(th), np.cos(th)

    def _phasors(self, t):
        a = self.phase - self.omega * float(t)
        return np.cos(a), np.sin(a)

    def grid(self):
        """The components' grid and recurrences as the kernels take them, a
        :data:`FastGrid` record (built once)."""
        w = self.plane_waves()
        fg = getattr(self, "_grid", None)
        if fg is None:
            sd, cd = np.tile(self.sin_d, self.nf), np.tile(self.cos_d, self.nf)
            fg = self._grid = FastGrid(
                GX=w.amp * w.k * sd, GY=w.amp * w.k * cd, UE=w.uo * sd, UN=w.uo * cd,
                nf=self.nf, nd=self.nd, sin_d=self.sin_d, cos_d=self.cos_d, K0=self.K[0],
                K1=self.K[1], K2=self.K[2])
        return w, fg

    def evaluate(self, t, lat, lon):
        w, fg = self.grid()
        pc, ps = self._phasors(t)
        r = _sums(np.ascontiguousarray(lat, float), np.ascontiguousarray(lon, float), w, fg,
                  pc, ps)
        return {"eta": r[:, 0], "eta_e": r[:, 1], "eta_n": r[:, 2], "u": r[:, 3], "v": r[:, 4]}

    def curvature(self, t, lat, lon, se, sn):
        w, fg = self.grid()
        pc, ps = self._phasors(t)
        f = np.ascontiguousarray
        return _curvature(f(lat, dtype=float), f(lon, dtype=float), f(se, dtype=float),
                          f(sn, dtype=float), w, fg, pc, ps)

    def add_forces(self, t, q, V, st, free, g, slope, drag, F) -> None:
        """The ``waves`` forcing with this sum: slope force and drag on the free elements."""
        from siku_core.geometry.quat import latlon_of

        lat, lon = latlon_of(q)
        e = self.evaluate(t, lat, lon)
        r = np.column_stack([e[k] for k in ("eta", "eta_e", "eta_n", "u", "v")])
        add_slope_drag(q, V, st.m, st.area, free, r, g, slope, drag, F, np.zeros(len(q)))


@hookimpl
def siku_register_fields():
    return [FastJonswap]
