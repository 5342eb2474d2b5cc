"""The compiled kernels of the plane-wave fields (:mod:`siku_forcing.waves.wave_field`) that the
sea-state modules share: the local plane about a field's reference point, the surface and
orbital velocity of a sum of plane waves and its curvature along a direction, and the slope
force and drag on the free elements (:func:`wave_forces`, from the wave sums;
:func:`add_slope_drag`, from per-element sums). Here, below the fields and the spectral sea
that use them, so that neither imports the other for a kernel.

Units: latitudes, longitudes and phases in radians, lengths in metres, times in seconds,
forces in newtons. A sea reaches the kernels as one record, ``w``: a
:data:`siku_forcing.waves.wave_field.PlaneWaves` (the field's origin, the model sphere's radius and
its
components), built by the field (``WaveField.plane_waves``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core.geometry.quat import east_north_row

from ..drag import quadratic_drag


@njit(cache=True, inline="always")
def wrap_phase(d):
    """A longitude difference [rad] into [-pi, pi] (unchanged, bit for bit, when inside)."""
    if d > math.pi:
        return d - 2.0 * math.pi
    if d < -math.pi:
        return d + 2.0 * math.pi
    return d


@njit(cache=True, inline="always")
def local_plane(lat, lon, lat0, lon0, c0, R):
    """A point's plane coordinates ``x`` east, ``y`` north [m] about ``(lat0, lon0)`` [rad]
    (``c0 = cos(lat0)``), and ``m = c0 / cos(lat)``, which turns a plane ``x`` derivative into
    one per metre east at the point."""
    x = R * c0 * wrap_phase(lon - lon0)
    y = R * (lat - lat0)
    m = c0 / max(math.cos(lat), 1e-12)
    return x, y, m


@njit(cache=True)
def plane_coords(lat, lon, lat0, lon0, R):
    n = lat.shape[0]
    x = np.empty(n)
    y = np.empty(n)
    c0 = math.cos(lat0)
    for i in range(n):
        d = wrap_phase(lon[i] - lon0)
        x[i] = R * c0 * d
        y[i] = R * (lat[i] - lat0)
    return x, y


@njit(cache=True, inline="always")
def _at(t, lat, lon, w, out):
    """eta, d eta/d east, d eta/d north, u east, u north at one point of the sea ``w``
    (``PlaneWaves``) into ``out[0:5]``."""
    amp, kx, ky, om, ph, uo = w.amp, w.kx, w.ky, w.omega, w.phase, w.uo
    x, y, m = local_plane(lat, lon, w.lat0, w.lon0, math.cos(w.lat0), w.R)
    eta = 0.0
    gx = 0.0
    gy = 0.0
    ue = 0.0
    un = 0.0
    for j in range(amp.shape[0]):
        psi = kx[j] * x + ky[j] * y - om[j] * t + ph[j]
        c = math.cos(psi)
        s = math.sin(psi)
        eta += amp[j] * c
        gx -= amp[j] * kx[j] * m * s
        gy -= amp[j] * ky[j] * s
        k = math.sqrt(kx[j] * kx[j] + ky[j] * ky[j])
        ue += uo[j] * c * kx[j] * m / k
        un += uo[j] * c * ky[j] / k
    out[0] = eta
    out[1] = gx
    out[2] = gy
    out[3] = ue
    out[4] = un


@njit(cache=True)
def plane_evaluate(t, lat, lon, w):
    """:func:`_at` of the sea ``w`` at every point ``(lat, lon)``: an ``(n, 5)`` array."""
    n = lat.shape[0]
    res = np.empty((n, 5))
    for i in range(n):
        _at(t, lat[i], lon[i], w, res[i])
    return res


@njit(cache=True)
def plane_curvature(t, lat, lon, se, sn, w):
    """d²eta/ds² [1/m] of the sea ``w`` (``PlaneWaves``) at points along unit directions
    ``(se, sn)`` (east, north)."""
    lat0, lon0, R = w.lat0, w.lon0, w.R
    amp, kx, ky, om, ph = w.amp, w.kx, w.ky, w.omega, w.phase
    n = lat.shape[0]
    out = np.zeros(n)
    c0 = math.cos(lat0)
    for i in range(n):
        x, y, m = local_plane(lat[i], lon[i], lat0, lon0, c0, R)
        acc = 0.0
        for j in range(amp.shape[0]):
            ks = kx[j] * m * se[i] + ky[j] * sn[i]
            acc -= amp[j] * ks * ks * math.cos(kx[j] * x + ky[j] * y - om[j] * t + ph[j])
        out[i] = acc
    return out


@njit(cache=True)
def wave_forces(t, q, V, m, area, free, w, g, slope, drag_coef, F):
    """Add ``-m g grad eta`` (if ``slope``) and ``S drag_coef |u - U| (u - U)`` with
    ``drag_coef = rho_w C_d`` of the sea ``w`` (``PlaneWaves``) to the free elements (local
    frames)."""
    buf = np.empty(5)
    for i in range(q.shape[0]):
        if not free[i]:
            continue
        z = 1.0 - 2.0 * (q[i, 1] * q[i, 1] + q[i, 2] * q[i, 2])
        x3 = 2.0 * (q[i, 1] * q[i, 3] + q[i, 0] * q[i, 2])
        y3 = 2.0 * (q[i, 2] * q[i, 3] - q[i, 0] * q[i, 1])
        lat = math.asin(max(-1.0, min(1.0, z)))
        lon = math.atan2(y3, x3)
        _at(t, lat, lon, w, buf)
        ex, ey, nx, ny = east_north_row(q, i)
        fe = 0.0
        fn = 0.0
        if slope:
            fe -= m[i] * g * buf[1]
            fn -= m[i] * g * buf[2]
        if drag_coef > 0.0:
            ue = V[i, 0] * ex + V[i, 1] * ey
            un = V[i, 0] * nx + V[i, 1] * ny
            de = buf[3] - ue
            dn = buf[4] - un
            drag_e, drag_n = quadratic_drag(area[i], drag_coef, de, dn)
            fe += drag_e
            fn += drag_n
        F[i, 0] += fe * ex + fn * nx
        F[i, 1] += fe * ey + fn * ny


# ----------------------------------------------------------------------------- fields


@njit(cache=True)
def add_slope_drag(q, V, m, area, free, r, g, slope, drag, F, power):
    """Slope force and drag from the sums ``r`` (:func:`_cell_sums`) on the free elements;
    ``power[i]``: the rate of work of the drag against the orbital flow, ``F_drag · u`` [W]."""
    for i in range(q.shape[0]):
        power[i] = 0.0
        if not free[i]:
            continue
        ex, ey, nx, ny = east_north_row(q, i)
        fe = 0.0
        fn = 0.0
        if slope:
            fe -= m[i] * g * r[i, 1]
            fn -= m[i] * g * r[i, 2]
        if drag > 0.0:
            ue = V[i, 0] * ex + V[i, 1] * ey
            un = V[i, 0] * nx + V[i, 1] * ny
            de, dn = quadratic_drag(area[i], drag, r[i, 3] - ue, r[i, 4] - un)
            fe += de
            fn += dn
            power[i] = de * r[i, 3] + dn * r[i, 4]
        F[i, 0] += fe * ex + fn * nx
        F[i, 1] += fe * ey + fn * ny
