"""Points on the sphere: geographic coordinates ↔ unit vectors, great-circle angles.

The one home of these conversions (docs/explanation/physics.md eq. 1): the global frame is
Cartesian on the unit sphere, ``z`` to the north pole, ``x`` through 0° longitude. Two forms of
each conversion, with the same arithmetic:

* :func:`latlon_to_xyz`, :func:`xyz_to_latlon`: one point, radians, compiled (numba, for use
  inside kernels);
* :func:`lonlat_to_xyz`, :func:`xyz_to_lonlat`: arrays of points, degrees, NumPy (``lon``
  first, as in files and scene tables).

Latitudes come from ``atan2(z, hypot(x, y))``, exact to round-off at every latitude;
``asin(z / r)`` would lose the colatitude near the poles (``z / r = 1 - colat²/2``: error
``eps / colat``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def xyz_to_latlon(p):
    """Latitude and longitude (radians, lon in (-pi, pi]) of a vector (eq. 1; any length)."""
    lat = math.atan2(p[2], math.hypot(p[0], p[1]))
    lon = math.atan2(p[1], p[0])
    return lat, lon


@njit(cache=True, inline="always")
def latlon_to_xyz(lat, lon):
    """Unit vector of geographic ``(lat, lon)`` in radians (eq. 1)."""
    out = np.empty(3)
    cl = math.cos(lat)
    out[0] = cl * math.cos(lon)
    out[1] = cl * math.sin(lon)
    out[2] = math.sin(lat)
    return out


def lonlat_to_xyz(lon, lat) -> np.ndarray:
    """Unit vectors ``(..., 3)`` of longitudes and latitudes in degrees (float64)."""
    lo = np.radians(np.asarray(lon, dtype=float))
    la = np.radians(np.asarray(lat, dtype=float))
    cl = np.cos(la)
    return np.stack([cl * np.cos(lo), cl * np.sin(lo), np.sin(la)], axis=-1)


def xyz_to_lonlat(p) -> tuple[np.ndarray, np.ndarray]:
    """Longitude in ``[-180, 180]`` and latitude (degrees) of vectors ``(..., 3)`` (any length)."""
    p = np.asarray(p, dtype=float)
    lon = np.degrees(np.arctan2(p[..., 1], p[..., 0]))
    lat = np.degrees(np.arctan2(p[..., 2], np.hypot(p[..., 0], p[..., 1])))
    return lon, lat


def great_circle_distance(p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Angle (radians) between unit vectors, robust for tiny and near-antipodal angles."""
    cross = np.linalg.norm(np.cross(p1, p2), axis=-1)
    dot = np.sum(p1 * p2, axis=-1)
    return np.arctan2(cross, dot)
