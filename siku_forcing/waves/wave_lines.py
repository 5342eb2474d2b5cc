"""The sea of a wave field tabulated along each of its directions and interpolated: ``method =
"lines"`` of the ``jonswap`` field.

All components ``j`` of one direction ``theta_d`` have phases ``psi_j = k_j s - omega_j t +
phi_j`` that depend on the point only through ``s = x sin(theta_d) + y cos(theta_d)``, so the
direction's share of every sum of :mod:`siku_forcing.waves.wave_field` is a function of one
variable:

    F_d(s) = sum_j a_j cos(psi_j)            (elevation),
    G_d(s) = -sum_j a_j k_j sin(psi_j)       (slope along the direction, dF_d/ds),
    U_d(s) = sum_j u_j cos(psi_j)            (orbital speed along it, u_j = a_j omega_j coth k_j h),
    K_d(s) = -sum_j a_j k_j² cos(psi_j)      (d²F_d/ds², for the curvature);

``eta = sum_d F_d``, slope east/north ``= sum_d (m sin, cos)(theta_d) G_d`` (``m`` the metric
factor of :mod:`siku_forcing.waves.wave_field`), orbital velocity ``= sum_d (m sin, cos)(theta_d)
U_d`` and
the curvature along ``(se, sn)`` is ``sum_d (m se sin + sn cos)² K_d``. At each evaluation time
the functions are tabulated on nodes ``s_p = s_0 + p h`` spanning the points (blocks of 64
nodes: ``exp(i k_j (s_b + q h)) = exp(i k_j s_b) exp(i k_j q h)``, a product of a row by a
matrix per block, the first factor by a recurrence over the blocks, the second computed once;
compiled, no BLAS, whose own threads would fight numba's on a busy machine), and
every point interpolates them with the Lagrange polynomial through the ``NODES = 8`` nodes
around it (the point in the central interval: four nodes on either side), compiled with
``fastmath`` (contracted and reordered sums: round-off only). Any dispersion relation: finite
depth too.

Error. For a function ``f`` interpolated on ``p`` equally spaced nodes, ``|f - I f| <= max
|f^(p)| / p! * prod_i |s - s_i| <= W_p h^p max |f^(p)|`` with ``W_p = max_(t in [0, 1]) prod_(i
= -p/2+1)^(p/2) |t - i| / p!`` (``W_8 = 1.07e-3``, at ``t = 1/2``), and ``|F_d^(p)| <= sum_j a_j
k_j^p``. Summed over directions, the elevation is off by at most ``W_p h^p sum_j a_j k_j^p``;
the slope by ``W_p h^p sum_j a_j k_j^(p+1)`` (times ``m`` east), the orbital velocity by ``W_p h^p
sum_j u_j k_j^p`` and the curvature by ``W_p h^p sum_j a_j k_j^(p+2)``. The node spacing is the
largest ``h`` that keeps each of these at most ``tolerance`` times the quantity's summed
amplitudes (``sum_j a_j``, ``sum_j a_j k_j``, ``sum_j u_j``, ``sum_j a_j k_j²``: the largest each
can be), so ``h = min_q (tolerance S_q / (W_p sum_j w_qj k_j^p))^(1/p)``: ``0.53 / k_max`` for
the default sea at ``tolerance = 1e-6`` (0.53 m at ``tp = 8 s``, a twelfth of the shortest
wavelength). The tables themselves carry round-off only (about ``N_f`` plus the number of blocks
ulps of the summed amplitudes).

The tables cost ``N_lines × N_f`` products per node, the direct sum ``N_points × N_components``:
when the tables would hold more node-components than the points hold point-components (a pack
spread far wider than its number of elements times ``h``), the direct sum is used.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .wave_kernels import local_plane, plane_curvature, plane_evaluate, wrap_phase

#: nodes of the interpolating polynomial (central interval: nodes -3 .. 4 around it)
NODES = 8
#: nodes per block of the tables (one matrix product per block and direction)
NODE_BLOCK = 64


def lagrange_constant(p: int = NODES, samples: int = 20001) -> float:
    """``W_p = max_(t in [0, 1]) prod_(i = -p/2+1)^(p/2) |t - i| / p!`` (sampled; the maximum
    of the even node set lies at ``t = 1/2``, which is a sample)."""
    t = np.linspace(0.0, 1.0, samples)
    i = np.arange(-(p // 2) + 1, p // 2 + 1)
    return float(np.max(np.prod(np.abs(t[:, None] - i[None, :]), axis=1)) / math.factorial(p))


W_P = lagrange_constant()


def spacing(amp, k, u_orbital, tolerance: float) -> float:
    """Node spacing [m] that bounds the interpolation error of the elevation, the slope, the
    orbital velocity and the curvature by ``tolerance`` times their summed amplitudes (module
    docstring)."""
    h = math.inf
    for w in (amp, amp * k, u_orbital, amp * k * k):
        top = W_P * float(np.sum(w * k**NODES))
        if top > 0:
            h = min(h, (tolerance * float(np.sum(w)) / top) ** (1.0 / NODES))
    return h


def error_bounds(amp, k, u_orbital, h: float) -> dict[str, float]:
    """The interpolation error bounds of the module docstring at node spacing ``h`` [m]:
    elevation [m], slope [1] (per unit metric factor), orbital speed [m/s], curvature [1/m]."""
    c = W_P * h**NODES
    return {"eta": c * float(np.sum(amp * k**NODES)),
            "slope": c * float(np.sum(amp * k ** (NODES + 1))),
            "u": c * float(np.sum(u_orbital * k**NODES)),
            "curvature": c * float(np.sum(amp * k ** (NODES + 2)))}


@njit(cache=True, inline="always", fastmath=True)
def _weights(t):
    """Lagrange weights of the nodes -3 .. 4 at ``t`` in [0, 1) (the denominators
    ``prod_(m != k) (k - m)``: -5040, 720, -240, 144, -144, 240, -720, 5040)."""
    d0, d1, d2, d3 = t + 3.0, t + 2.0, t + 1.0, t
    d4, d5, d6, d7 = t - 1.0, t - 2.0, t - 3.0, t - 4.0
    p01, p23, p45, p67 = d0 * d1, d2 * d3, d4 * d5, d6 * d7
    lo, hi = p01 * p23, p45 * p67
    return (d1 * p23 * hi * (-1.0 / 5040.0), d0 * p23 * hi * (1.0 / 720.0),
            p01 * d3 * hi * (-1.0 / 240.0), p01 * d2 * hi * (1.0 / 144.0),
            lo * d5 * p67 * (-1.0 / 144.0), lo * d4 * p67 * (1.0 / 240.0),
            lo * p45 * d7 * (-1.0 / 720.0), lo * p45 * d6 * (1.0 / 5040.0))


@njit(cache=True, inline="always", fastmath=True)
def _dot8(w, T, b, c, stride):
    """``sum_q w[q] T[b + q * stride + c]``, the eight terms written out."""
    return (w[0] * T[b + c] + w[1] * T[b + stride + c] + w[2] * T[b + 2 * stride + c]
            + w[3] * T[b + 3 * stride + c] + w[4] * T[b + 4 * stride + c]
            + w[5] * T[b + 5 * stride + c] + w[6] * T[b + 6 * stride + c]
            + w[7] * T[b + 7 * stride + c])


@njit(cache=True)
def line_range(lat, lon, lat0, lon0, R, sin_d, cos_d):
    """Least and greatest ``s = x sin + y cos`` of the points per direction."""
    nd = sin_d.shape[0]
    n = lat.shape[0]
    c0 = math.cos(lat0)
    lo = np.full(nd, np.inf)
    hi = np.full(nd, -np.inf)
    for d in range(nd):  # serial: a parallel region costs more than this on a busy machine
        a = np.inf
        b = -np.inf
        for i in range(n):
            s = R * c0 * wrap_phase(lon[i] - lon0) * sin_d[d] + R * (lat[i] - lat0) * cos_d[d]
            a = min(a, s)
            b = max(b, s)
        lo[d] = a
        hi[d] = b
    return lo, hi


@njit(cache=True, parallel=True, fastmath=True)
def _interpolate(lat, lon, lat0, lon0, R, sin_d, cos_d, s0, h, T, Q):
    """eta, slope east/north, orbital u east/north at the points from the tables ``T[d, Q p +
    c]`` (``c`` = 0, 1, 2: F, G, U of the module docstring) with nodes ``s0[d] + p h``."""
    n = lat.shape[0]
    out = np.empty((n, 5))
    c0 = math.cos(lat0)
    for i in prange(n):
        x, y, m = local_plane(lat[i], lon[i], lat0, lon0, c0, R)
        eta = 0.0
        gx = 0.0
        gy = 0.0
        ue = 0.0
        un = 0.0
        for d in range(sin_d.shape[0]):
            u = (x * sin_d[d] + y * cos_d[d] - s0[d]) / h
            fl = math.floor(u)
            w = _weights(u - fl)
            b = Q * (int(fl) - 3)
            row = T[d]
            g = _dot8(w, row, b, 1, Q)
            v = _dot8(w, row, b, 2, Q)
            eta += _dot8(w, row, b, 0, Q)
            gx += sin_d[d] * g
            gy += cos_d[d] * g
            ue += sin_d[d] * v
            un += cos_d[d] * v
        out[i, 0] = eta
        out[i, 1] = gx * m
        out[i, 2] = gy
        out[i, 3] = ue * m
        out[i, 4] = un
    return out


@njit(cache=True, parallel=True, fastmath=True)
def _interpolate_curvature(lat, lon, se, sn, lat0, lon0, R, sin_d, cos_d, s0, h, T):
    """Curvature along ``(se, sn)`` at the points from the tables ``T[d, 4 p + 3]`` (K)."""
    n = lat.shape[0]
    out = np.empty(n)
    c0 = math.cos(lat0)
    for i in prange(n):
        x, y, m = local_plane(lat[i], lon[i], lat0, lon0, c0, R)
        acc = 0.0
        for d in range(sin_d.shape[0]):
            u = (x * sin_d[d] + y * cos_d[d] - s0[d]) / h
            fl = math.floor(u)
            ks = sin_d[d] * m * se[i] + cos_d[d] * sn[i]
            acc += ks * ks * _dot8(_weights(u - fl), T[d], 4 * (int(fl) - 3), 3, 4)
        out[i] = acc
    return out


@njit(cache=True, parallel=True, fastmath=True)
def _tabulate(s0, k, phase, step, nb, Y):
    """The tables ``T[d, Q p + c]`` at nodes ``p = b NODE_BLOCK + q``: ``sum_j [cos, sin](psi_j at
    the block's first node) . Y[d, :, Q q + c]``, with ``exp(i psi)`` at the first node by the
    recurrence ``exp(i psi) <- exp(i psi) step_j`` over the blocks (``psi_j = k_j s + phase_j``;
    ``nb`` products: ``nb`` ulps). Parallel over the directions."""
    nd, J = k.shape
    W = Y.shape[2]  # NODE_BLOCK Q values a block
    T = np.zeros((nd, nb * W))
    for d in prange(nd):
        zr = np.empty(J)
        zi = np.empty(J)
        for j in range(J):
            a = k[d, j] * s0[d] + phase[d, j]
            zr[j] = math.cos(a)
            zi[j] = math.sin(a)
        for b in range(nb):
            base = b * W
            for j in range(J):
                xr = zr[j]
                xi = zi[j]
                for c in range(W):
                    T[d, base + c] += xr * Y[d, j, c] + xi * Y[d, J + j, c]
                sr = step[d, j].real
                si = step[d, j].imag
                zr[j] = xr * sr - xi * si
                zi[j] = xr * si + xi * sr
    return T


class LineSea:
    """The tables of one wave field (module docstring) with the node spacing of ``tolerance``
    (or ``h`` [m] as given); ``evaluate`` and ``curvature`` as the field's own."""

    def __init__(self, field, tolerance: float, h: float | None = None):
        self.f = field
        th = np.asarray(field.theta, float)
        dirs, group = np.unique(th, return_inverse=True)
        nd = len(dirs)
        J = int(np.bincount(group, minlength=nd).max())
        # components per direction, padded with zero amplitudes (they add nothing)
        shape = (nd, J)
        self.k, self.a, self.uo = np.zeros(shape), np.zeros(shape), np.zeros(shape)
        self.om, self.ph = np.zeros(shape), np.zeros(shape)
        fill = np.zeros(nd, int)
        for j, d in enumerate(group):
            c = fill[d]
            self.k[d, c], self.a[d, c], self.uo[d, c] = field.k[j], field.amp[j], \
                field.u_orbital[j]
            self.om[d, c], self.ph[d, c] = field.omega[j], field.phase[j]
            fill[d] += 1
        self.sin_d, self.cos_d = np.sin(dirs), np.cos(dirs)
        self.h = spacing(field.amp, field.k, field.u_orbital, tolerance) if h is None else h
        self.bounds = error_bounds(field.amp, field.k, field.u_orbital, self.h)
        # per quantity w_j and the table's row [cos, sin](psi_j at the block's first node):
        # Re(w e^(i psi) M) = cos w Mr - sin w Mi, -Im(...) = -cos w Mi - sin w Mr
        M = np.exp(1j * self.k[:, :, None] * (self.h * np.arange(NODE_BLOCK))[None, None, :])
        Mr, Mi = M.real, M.imag

        def Y(w, kind):
            w = w[:, :, None]
            return np.concatenate([w * Mr, -w * Mi] if kind == "cos" else [-w * Mi, -w * Mr],
                                  axis=1)  # (nd, 2J, NODE_BLOCK)

        ys = [Y(self.a, "cos"), Y(self.a * self.k, "sin"), Y(self.uo, "cos")]
        nd, J = self.k.shape
        # columns Q q + c: node q of a block, quantity c (F, G, U; and K)
        self.Y3 = np.ascontiguousarray(np.stack(ys, axis=3).reshape(nd, 2 * J, 3 * NODE_BLOCK))
        self.Y4 = np.ascontiguousarray(np.stack(ys + [Y(-self.a * self.k**2, "cos")],
                                                axis=3).reshape(nd, 2 * J, 4 * NODE_BLOCK))
        self.step = np.exp(1j * self.k * (NODE_BLOCK * self.h))  # from one block to the next
        self.n_components = len(field.amp)
        self._key = None

    def _tables(self, t, lat, lon, curvature):
        """Build (or reuse) the tables at time ``t`` spanning the points; False when the
        direct sum is the cheaper."""
        f = self.f
        lo, hi = line_range(lat, lon, f.lat0, f.lon0, f.radius, self.sin_d, self.cos_d)
        key = self._key
        if (key is not None and key[0] == t and (curvature <= key[1]) and np.all(lo >= key[2])
                and np.all(hi <= key[3])):
            return key[4]
        h = self.h
        s0 = lo - (NODES // 2 + 1) * h
        nb = int(np.max(np.ceil((hi - s0 + (NODES // 2 + 2) * h) / (NODE_BLOCK * h))))
        nd, J = self.k.shape
        if nd * nb * NODE_BLOCK * J > len(lat) * self.n_components:
            self._key = None
            return False
        Y = self.Y4 if curvature else self.Y3
        self.Q = Y.shape[2] // NODE_BLOCK
        self.T = _tabulate(s0, self.k, self.ph - self.om * t, self.step, nb, Y)
        self.s0 = s0
        self._key = (t, curvature, s0 + (NODES // 2) * h, s0 + (nb * NODE_BLOCK - NODES // 2 - 1)
                     * h, True)
        return True

    def evaluate(self, t, lat, lon):
        f = self.f
        lat = np.ascontiguousarray(lat, float)
        lon = np.ascontiguousarray(lon, float)
        t = float(t)
        if self._tables(t, lat, lon, False):
            r = _interpolate(lat, lon, f.lat0, f.lon0, f.radius, self.sin_d, self.cos_d,
                             self.s0, self.h, self.T, self.Q)
        else:
            r = plane_evaluate(t, lat, lon, f.plane_waves())
        return r

    def curvature(self, t, lat, lon, se, sn):
        f = self.f
        c = np.ascontiguousarray
        lat, lon, se, sn = (c(v, dtype=float) for v in (lat, lon, se, sn))
        t = float(t)
        if self._tables(t, lat, lon, True):
            return _interpolate_curvature(lat, lon, se, sn, f.lat0, f.lon0, f.radius,
                                          self.sin_d, self.cos_d, self.s0, self.h, self.T)
        return plane_curvature(t, lat, lon, se, sn, f.plane_waves())
