"""Elements of a saved or running state on the sphere: their outlines as lon/lat and their
local-frame vectors as east/north components (what the writers, the xarray backend, the gridding,
the coupling and the maps all need, so one copy)."""
from __future__ import annotations

import numpy as np

from siku_core.geometry.quat import qmatrices
from siku_core.geometry.sphere import xyz_to_lonlat


def polygons_lonlat(q: np.ndarray, offsets: np.ndarray, verts: np.ndarray, radius: float):
    """Vertices of every element as ``[lon, lat]`` degrees (list of ``(k, 2)`` arrays)."""
    owner = np.repeat(np.arange(len(q)), np.diff(offsets))
    loc = np.column_stack([verts[:, 0] / radius, verts[:, 1] / radius, np.ones(len(verts))])
    g = np.einsum("nij,nj->ni", qmatrices(q)[owner], loc)
    g /= np.linalg.norm(g, axis=1)[:, None]
    ll = np.column_stack(xyz_to_lonlat(g))
    return [ll[offsets[i]:offsets[i + 1]] for i in range(len(q))]


def east_north(q: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eastward and northward components [same unit as ``V``] of local-frame vectors ``V``
    (..., 2) of elements with quaternions ``q`` (..., 4) (as
    ``siku_core.geometry.quat.east_north_local``, vectorised)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    c0 = 2 * (x * z + w * y)
    c1 = 2 * (y * z - w * x)
    rho = np.hypot(c0, c1)
    pole = rho < 1e-14
    rho = np.where(pole, 1.0, rho)
    v0, v1 = -c1 / rho, c0 / rho
    # local components of the global east vector: R(q)^T (v0, v1, 0)
    ex = (1 - 2 * (y * y + z * z)) * v0 + 2 * (x * y + w * z) * v1
    ey = 2 * (x * y - w * z) * v0 + (1 - 2 * (x * x + z * z)) * v1
    ex = np.where(pole, 1.0, ex)
    ey = np.where(pole, 0.0, ey)
    u = V[..., 0] * ex + V[..., 1] * ey
    v = -V[..., 0] * ey + V[..., 1] * ex
    return u, v
