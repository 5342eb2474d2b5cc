"""Quadratic drag from a gridded velocity field in one pass over the elements.

The drag sources (``air_drag``, ``water_drag``; :mod:`siku_forcing.drag`) with a ``gridded``
field (:mod:`siku_forcing.gridded.gridded_field`) would otherwise make three passes: the element
centres'
latitude and longitude (``latlon_of``), the interpolated field at them (``interpolate``), and
the stress (``_stress``), with two pairs of temporary arrays between them. :func:`gridded_stress`
does the three for each element in turn, on the engine's chunks (``siku_core.parallel``): the
same arithmetic in the same order (every piece is the same inlined function), so the forces
are the same bit for bit, and the field is read where the element is.
"""
from __future__ import annotations

import math

from numba import njit, prange

from siku_core.parallel import chunk_bounds

from ..drag import stress_one
from .gridded_kernel import interpolate_one, interpolate_records, mix_records


@njit(cache=True, inline="always")
def centre_latlon(q, i):
    """Latitude and longitude [rad] of element ``i``'s centre (quaternion ``q[i]``), the
    arithmetic of :func:`siku_core.geometry.quat.latlon_of`."""
    w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    cx = 2 * (x * z + w * y)
    cy = 2 * (y * z - w * x)
    cz = 1 - 2 * (x * x + y * y)
    return math.atan2(cz, math.hypot(cx, cy)), math.atan2(cy, cx)


@njit(cache=True, parallel=True)
def gridded_stress(q, V, area, rho, C, theta, subtract_ice, g, F, nch, nout, first):
    """Add the drag ``S rho C |D| (D cos th + k × D sin th)``, ``D = U_field - subtract_ice U``
    [N], of the field interpolated at each element's centre (``g``: the grid and records
    ``U0, V0`` and ``U1, V1`` [m/s] with weights ``1 - alpha`` and ``alpha``, a
    :data:`siku_forcing.gridded.gridded_field.GridSample`; as :func:`interpolate_one`).

    ``nout[c]``, ``first[c]``: points of chunk ``c`` outside the grid (field zero there) and the
    first of them (-1: none).
    """
    ct, st = math.cos(theta), math.sin(theta)
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        no = 0
        fi = -1
        for i in range(lo, hi):
            lat, lon = centre_latlon(q, i)
            u, v, inside = interpolate_one(lat, lon, g)
            if not inside:
                if no == 0:
                    fi = i
                no += 1
            stress_one(q, V, i, u, v, area, rho, C, ct, st, subtract_ice, F)
        nout[c] = no
        first[c] = fi


@njit(cache=True, parallel=True)
def gridded_values(q, g, ab, nch, nout, first):
    """Both records of ``g`` interpolated in space at each element's centre into ``ab`` (``(n,
    4)``: east and north [m/s] of the first record, then of the second; zeros outside the
    grid), as :func:`gridded_stress` reads them (the same arithmetic); ``nout``, ``first``: as
    there. The cache of :func:`cached_stress`."""
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        no = 0
        fi = -1
        for i in range(lo, hi):
            lat, lon = centre_latlon(q, i)
            a0, b0, a1, b1, inside = interpolate_records(lat, lon, g)
            if not inside:
                if no == 0:
                    fi = i
                no += 1
            ab[i, 0] = a0
            ab[i, 1] = b0
            ab[i, 2] = a1
            ab[i, 3] = b1
        nout[c] = no
        first[c] = fi


@njit(cache=True, parallel=True)
def cached_stress(q, V, area, rho, C, theta, subtract_ice, ab, alpha, F, nch):
    """:func:`gridded_stress` with the field's two records at each element taken from ``ab``
    (:func:`gridded_values`) and weighed in time by ``alpha``: no position, no grid lookup.
    With ``ab`` from the same positions, the same forces bit for bit."""
    ct, st = math.cos(theta), math.sin(theta)
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        for i in range(lo, hi):
            u, v, _ = mix_records(ab[i, 0], ab[i, 1], ab[i, 2], ab[i, 3], alpha)
            stress_one(q, V, i, u, v, area, rho, C, ct, st, subtract_ice, F)
