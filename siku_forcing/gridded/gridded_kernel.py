"""Interpolation kernels of gridded velocity fields (numba): bilinear in space on a sorted
lon/lat grid with longitude wrap-around and vector-consistent pole caps, linear in time, and
the least-squares pole vector of a latitude row. See :mod:`siku_forcing.gridded.gridded_field`."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: points this close [rad] outside the grid edge (about 6 mm) count as on it
_EDGE = 1e-9


@njit(cache=True)
def locate(a, x):
    """Largest ``i`` in ``[0, len(a) - 2]`` with ``a[i] <= x`` (``a`` ascending).

    Starts from the guess of a regular grid and walks: O(1) on regular and Gaussian grids.
    """
    n = a.shape[0]
    i = int((x - a[0]) / (a[n - 1] - a[0]) * (n - 1))
    if i < 0:
        i = 0
    elif i > n - 2:
        i = n - 2
    while i > 0 and a[i] > x:
        i -= 1
    while i < n - 2 and a[i + 1] <= x:
        i += 1
    return i


@njit(cache=True, inline="always")
def interpolate_one(y, lon_k, g):
    """The field at one point, latitude ``y`` and longitude ``lon_k`` [rad]: ``(u, v, inside)``
    (``0, 0, False`` outside the grid). ``g``: the grid and records, as :func:`interpolate`."""
    a0, b0, a1, b1, inside = interpolate_records(y, lon_k, g)
    if not inside:
        return 0.0, 0.0, False
    return mix_records(a0, b0, a1, b1, g.alpha)


@njit(cache=True, inline="always")
def mix_records(a0, b0, a1, b1, alpha):
    """``(u, v, True)`` [m/s] at weight ``alpha`` of the second record, from one point's values
    ``(a0, b0)`` of the first record and ``(a1, b1)`` of the second (the time interpolation of
    :func:`interpolate_one`, the same arithmetic)."""
    if alpha == 0.0:
        return a0, b0, True
    return (1.0 - alpha) * a0 + alpha * a1, (1.0 - alpha) * b0 + alpha * b1, True


@njit(cache=True, inline="always")
def interpolate_records(y, lon_k, g):
    """Both records of ``g`` interpolated in space at latitude ``y`` and longitude ``lon_k``
    [rad]: ``(a0, b0, a1, b1, inside)`` [m/s], the east and north components of the first
    record and of the second (zeros and ``False`` outside the grid); :func:`mix_records`
    weighs them in time."""
    ylat, xoff, lon0, periodic, cap_s, cap_n = (g.ylat, g.xoff, g.lon0, g.periodic, g.cap_s,
                                                g.cap_n)
    U0, V0, P0, U1, V1, P1 = g.U0, g.V0, g.P0, g.U1, g.V1, g.P1
    twopi = 2.0 * math.pi
    halfpi = 0.5 * math.pi
    ny = ylat.shape[0]
    nx = xoff.shape[0]
    x = lon_k - lon0
    x = x - twopi * math.floor(x / twopi)
    if x >= twopi:
        x = 0.0
    # ---- longitude cell j0, j1 and weight fx
    inside = True
    j0 = 0
    j1 = 1
    fx = 0.0
    xl = xoff[nx - 1]
    if x > xl and periodic:  # the wrap-around cell: last column -> first column + 2 pi
        j0 = nx - 1
        j1 = 0
        fx = (x - xl) / (twopi - xl)
    else:
        if x > xl:  # regional grid: on its edge or outside
            if x - xl <= _EDGE:
                x = xl
            elif twopi - x <= _EDGE:
                x = 0.0
            else:
                inside = False
        if inside:
            j0 = locate(xoff, x)
            j1 = j0 + 1
            fx = (x - xoff[j0]) / (xoff[j1] - xoff[j0])
    # ---- latitude: interior cell, polar cap or outside
    cap = 0  # -1 south cap, +1 north cap
    if inside:
        if y < ylat[0]:
            if cap_s:
                cap = -1
            elif ylat[0] - y <= _EDGE:
                y = ylat[0]
            else:
                inside = False
        elif y > ylat[ny - 1]:
            if cap_n:
                cap = 1
            elif y - ylat[ny - 1] <= _EDGE:
                y = ylat[ny - 1]
            else:
                inside = False
    if not inside:
        return 0.0, 0.0, 0.0, 0.0, False
    if cap == 0:
        i0 = locate(ylat, y)
        fy = (y - ylat[i0]) / (ylat[i0 + 1] - ylat[i0])
        w00 = (1.0 - fy) * (1.0 - fx)
        w01 = (1.0 - fy) * fx
        w10 = fy * (1.0 - fx)
        w11 = fy * fx
        a0 = w00 * U0[i0, j0] + w01 * U0[i0, j1] + w10 * U0[i0 + 1, j0] + w11 * U0[i0 + 1, j1]
        b0 = w00 * V0[i0, j0] + w01 * V0[i0, j1] + w10 * V0[i0 + 1, j0] + w11 * V0[i0 + 1, j1]
        a1 = w00 * U1[i0, j0] + w01 * U1[i0, j1] + w10 * U1[i0 + 1, j0] + w11 * U1[i0 + 1, j1]
        b1 = w00 * V1[i0, j0] + w01 * V1[i0, j1] + w10 * V1[i0 + 1, j0] + w11 * V1[i0 + 1, j1]
    else:
        r = 0 if cap < 0 else ny - 1
        side = 0 if cap < 0 else 1
        sp = float(cap)
        s = (y - ylat[r]) / (sp * halfpi - ylat[r])
        s = min(s, 1.0)
        sl = math.sin(lon_k)
        cl = math.cos(lon_k)
        # pole vector W in the east/north frame of this longitude at the pole
        pu0 = -P0[side, 0] * sl + P0[side, 1] * cl
        pv0 = -sp * (P0[side, 0] * cl + P0[side, 1] * sl)
        pu1 = -P1[side, 0] * sl + P1[side, 1] * cl
        pv1 = -sp * (P1[side, 0] * cl + P1[side, 1] * sl)
        a0 = (1.0 - s) * ((1.0 - fx) * U0[r, j0] + fx * U0[r, j1]) + s * pu0
        b0 = (1.0 - s) * ((1.0 - fx) * V0[r, j0] + fx * V0[r, j1]) + s * pv0
        a1 = (1.0 - s) * ((1.0 - fx) * U1[r, j0] + fx * U1[r, j1]) + s * pu1
        b1 = (1.0 - s) * ((1.0 - fx) * V1[r, j0] + fx * V1[r, j1]) + s * pv1
    return a0, b0, a1, b1, True


@njit(cache=True)
def interpolate(lat, lon, g, u, v):
    """Bilinear-in-space, linear-in-time interpolation at the points ``lat, lon`` [rad] into
    ``u, v`` [m/s]; returns (points outside, first one).

    ``g``: a :data:`siku_forcing.gridded.gridded_field.GridSample` record: ``ylat (ny)`` ascending
    latitudes
    [rad]; ``xoff (nx)`` ascending longitude offsets from ``lon0`` in ``[0, 2 pi)`` [rad];
    ``U0, V0 (ny, nx)`` / ``U1, V1`` the two records, weights ``1 - alpha`` and ``alpha``;
    ``P0, P1 (2, 2)`` pole vectors ``(W_x, W_y)`` south [0], north [1]. Each point is
    :func:`interpolate_one` (inlined: the same arithmetic as the fused drag kernel of
    :mod:`siku_forcing.gridded.gridded_drag`, bit for bit).
    """
    nout = 0
    first = -1
    for k in range(lat.shape[0]):
        a, b, inside = interpolate_one(lat[k], lon[k], g)
        u[k] = a
        v[k] = b
        if not inside:
            if nout == 0:
                first = k
            nout += 1
    return nout, first


def pole_vector(u_row: np.ndarray, v_row: np.ndarray, lat_row: float, lon: np.ndarray) -> tuple[
        float, float]:
    """Least-squares pole vector ``(W_x, W_y)`` [m/s] from one latitude row (see module doc).

    ``u_row, v_row`` east and north components on the row at latitude ``lat_row`` and
    longitudes ``lon`` [rad]. Fits ``u = -W_x sin(lon) + W_y cos(lon)`` and
    ``v = -sin(lat_row) (W_x cos(lon) + W_y sin(lon))``: the east/north components of the
    horizontal vector ``W`` tangent at the pole, seen from the row.
    """
    sl, cl, sg = np.sin(lon), np.cos(lon), math.sin(lat_row)
    A = np.concatenate([np.stack([-sl, cl], axis=1), np.stack([-sg * cl, -sg * sl], axis=1)])
    b = np.concatenate([u_row, v_row])
    w = np.linalg.lstsq(A, b, rcond=None)[0]
    return float(w[0]), float(w[1])
