"""Quaternion and geographic helpers (numba, ``cache=True``).

Conventions (see ``docs/explanation/kinematics.md``):

* quaternions are scalar-first ``q = (w, x, y, z)``, unit norm;
* ``q`` rotates an element's *local* frame onto the *global* Earth-fixed frame (eq. 2):
  ``p_global = R(q) P_local``;
* the global frame is Cartesian on the unit sphere, ``z`` to the north pole, ``x`` through
  0° longitude (eq. 1);
* the local ``+z`` axis is the element centre; at creation local ``+x`` points east and ``+y``
  north. At a pole the azimuth is that of the longitude given (``lon = 0`` by default), i.e.
  local ``+x`` is the direction east would have at that longitude just off the pole.

Angles are in radians unless a name says ``_deg``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..parallel import chunk_bounds, chunks

# the point conversions live in .sphere; re-exported for callers that import them with the
# quaternion helpers
from .sphere import great_circle_distance, latlon_to_xyz, xyz_to_latlon

__all__ = [
    "cayley_step", "centers", "east_north_local", "east_north_row", "from_tangent",
    "great_circle_distance", "latlon_of", "latlon_to_xyz", "q_center", "q_from_latlon",
    "qmatrices", "qmatrix", "qmul", "qrotate", "qrotate_inv", "to_tangent", "xyz_to_latlon",
]


@njit(cache=True, inline="always")
def qmul(a, b):
    """Hamilton product ``a ∘ b`` of two scalar-first quaternions."""
    out = np.empty(4)
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]
    return out


@njit(cache=True, inline="always")
def qrotate(q, v):
    """Rotate the 3-vector ``v`` by unit quaternion ``q`` (local → global)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    # t = 2 (q_vec × v)
    tx = 2.0 * (y * v[2] - z * v[1])
    ty = 2.0 * (z * v[0] - x * v[2])
    tz = 2.0 * (x * v[1] - y * v[0])
    out = np.empty(3)
    out[0] = v[0] + w * tx + (y * tz - z * ty)
    out[1] = v[1] + w * ty + (z * tx - x * tz)
    out[2] = v[2] + w * tz + (x * ty - y * tx)
    return out


@njit(cache=True, inline="always")
def qrotate_inv(q, v):
    """Rotate the 3-vector ``v`` by the inverse of unit quaternion ``q`` (global → local)."""
    qc = np.empty(4)
    qc[0] = q[0]
    qc[1] = -q[1]
    qc[2] = -q[2]
    qc[3] = -q[3]
    return qrotate(qc, v)


@njit(cache=True)
def qmatrix(q):
    """Rotation matrix ``R(q)`` (columns are the local axes in the global frame)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    m = np.empty((3, 3))
    m[0, 0] = 1 - 2 * (y * y + z * z)
    m[0, 1] = 2 * (x * y - w * z)
    m[0, 2] = 2 * (x * z + w * y)
    m[1, 0] = 2 * (x * y + w * z)
    m[1, 1] = 1 - 2 * (x * x + z * z)
    m[1, 2] = 2 * (y * z - w * x)
    m[2, 0] = 2 * (x * z - w * y)
    m[2, 1] = 2 * (y * z + w * x)
    m[2, 2] = 1 - 2 * (x * x + y * y)
    return m


@njit(cache=True)
def q_from_latlon(lat, lon):
    """Quaternion placing an element at ``(lat, lon)`` (radians) with local x east, y north.

    ``q = Rz(lon) ∘ Ry(pi/2 - lat) ∘ Rz(pi/2)``.
    """
    a = 0.5 * lon
    b = 0.5 * (0.5 * math.pi - lat)
    c = 0.25 * math.pi
    qz1 = np.array([math.cos(a), 0.0, 0.0, math.sin(a)])
    qy = np.array([math.cos(b), 0.0, math.sin(b), 0.0])
    qz2 = np.array([math.cos(c), 0.0, 0.0, math.sin(c)])
    q = qmul(qmul(qz1, qy), qz2)
    return q / math.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)


@njit(cache=True, inline="always")
def q_center(q):
    """Element centre on the unit sphere: ``R(q) e_z``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    out = np.empty(3)
    out[0] = 2 * (x * z + w * y)
    out[1] = 2 * (y * z - w * x)
    out[2] = 1 - 2 * (x * x + y * y)
    return out


@njit(cache=True)
def centers(q):
    """Element centres ``(N, 3)`` on the unit sphere for quaternions ``q (N, 4)``."""
    n = q.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        c = q_center(q[i])
        out[i, 0] = c[0]
        out[i, 1] = c[1]
        out[i, 2] = c[2]
    return out


@njit(cache=True)
def farthest_moved2(q, rows, ref):
    """The largest squared distance (unit sphere, chord) of the centres of the elements
    ``rows`` of ``q (N, 4)`` from their places ``ref (len(rows), 3)``; 0 without rows (an MPI
    rank's test of whether its elements drifted: no copies of the rows)."""
    best = 0.0
    for k in range(rows.shape[0]):
        i = rows[k]
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        dx = 2 * (x * z + w * y) - ref[k, 0]  # (q_center, without its array)
        dy = 2 * (y * z - w * x) - ref[k, 1]
        dz = 1 - 2 * (x * x + y * y) - ref[k, 2]
        d2 = dx * dx + dy * dy + dz * dz
        best = d2 if d2 > best else best
    return best


@njit(cache=True, parallel=True)
def _latlon_chunks(q, lat, lon, nch):
    n = q.shape[0]
    for c in prange(nch):
        lo_, hi_ = chunk_bounds(c, nch, n)
        for i in range(lo_, hi_):
            w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
            cx = 2 * (x * z + w * y)  # q_center and xyz_to_latlon, without the arrays
            cy = 2 * (y * z - w * x)
            cz = 1 - 2 * (x * x + y * y)
            lat[i] = math.atan2(cz, math.hypot(cx, cy))
            lon[i] = math.atan2(cy, cx)


def latlon_of(q):
    """Latitude and longitude arrays (radians) of the element centres."""
    n = q.shape[0]
    lat = np.empty(n)
    lon = np.empty(n)
    _latlon_chunks(q, lat, lon, chunks(n))
    return lat, lon


@njit(cache=True, inline="always")
def east_north_local(q):
    """Local-frame components of the geographic east and north unit vectors at an element.

    Returns ``(ex, ey, nx, ny)``: east = ``(ex, ey)`` and north = ``(nx, ny)`` in the element's
    local tangent frame. Exactly at a pole (where east is undefined) the local axes are used.
    """
    c = q_center(q)
    rho = math.sqrt(c[0] * c[0] + c[1] * c[1])
    if rho < 1e-14:
        return 1.0, 0.0, 0.0, 1.0
    e = np.empty(3)
    e[0] = -c[1] / rho
    e[1] = c[0] / rho
    e[2] = 0.0
    el = qrotate_inv(q, e)
    # north = up x east, so in the local frame north = (-ey, ex)
    return el[0], el[1], -el[1], el[0]


@njit(cache=True, inline="always")
def east_north_row(q, i):
    """:func:`east_north_local` of ``q[i]`` without allocating (same arithmetic, bit for bit):
    for loops over many elements."""
    w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
    c0 = 2 * (x * z + w * y)
    c1 = 2 * (y * z - w * x)
    rho = math.sqrt(c0 * c0 + c1 * c1)
    if rho < 1e-14:
        return 1.0, 0.0, 0.0, 1.0
    v0 = -c1 / rho
    v1 = c0 / rho
    v2 = 0.0
    # qrotate((w, -x, -y, -z), v), as qrotate_inv does
    cx, cy, cz = -x, -y, -z
    tx = 2.0 * (cy * v2 - cz * v1)
    ty = 2.0 * (cz * v0 - cx * v2)
    tz = 2.0 * (cx * v1 - cy * v0)
    e0 = v0 + w * tx + (cy * tz - cz * ty)
    e1 = v1 + w * ty + (cz * tx - cx * tz)
    return e0, e1, -e1, e0


@njit(cache=True)
def to_tangent(q, p, radius):
    """Gnomonic projection of global unit vector ``p`` into the tangent plane of ``q`` (m)."""
    pl = qrotate_inv(q, p)
    return radius * pl[0] / pl[2], radius * pl[1] / pl[2]


@njit(cache=True)
def from_tangent(q, x, y, radius):
    """Inverse gnomonic projection: local tangent-plane point ``(x, y)`` in m → unit vector."""
    v = np.empty(3)
    v[0] = x / radius
    v[1] = y / radius
    v[2] = 1.0
    g = qrotate(q, v)
    return g / math.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])


def qmatrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(N, 3, 3)`` of quaternions ``q (N, 4)``: :func:`qmatrix` with NumPy,
    the same arithmetic element by element (for readers and plots, outside kernels)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    m = np.empty((len(q), 3, 3))
    m[:, 0, 0] = 1 - 2 * (y * y + z * z)
    m[:, 0, 1] = 2 * (x * y - w * z)
    m[:, 0, 2] = 2 * (x * z + w * y)
    m[:, 1, 0] = 2 * (x * y + w * z)
    m[:, 1, 1] = 1 - 2 * (x * x + z * z)
    m[:, 1, 2] = 2 * (y * z - w * x)
    m[:, 2, 0] = 2 * (x * z - w * y)
    m[:, 2, 1] = 2 * (y * z + w * x)
    m[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return m


@njit(cache=True, inline="always")
def cayley_step(q, ox, oy, oz, dt, out):
    """Report eq. (6) with ``dt²``: ``q ∘ p``, ``p = (1 - |Ω|²dt²/16 + dt/2 Ω)/(1 + |Ω|²dt²/16)``.

    ``(ox, oy, oz)`` is the body-frame angular velocity [rad/s]; ``|p| = 1`` exactly, so the step
    preserves the norm of ``q``; the result is written to ``out`` and renormalised against
    round-off.
    """
    s = (ox * ox + oy * oy + oz * oz) * dt * dt / 16.0
    inv = 1.0 / (1.0 + s)
    p0 = (1.0 - s) * inv
    h = 0.5 * dt * inv
    p1 = h * ox
    p2 = h * oy
    p3 = h * oz
    a0, a1, a2, a3 = q[0], q[1], q[2], q[3]
    r0 = a0 * p0 - a1 * p1 - a2 * p2 - a3 * p3
    r1 = a0 * p1 + a1 * p0 + a2 * p3 - a3 * p2
    r2 = a0 * p2 - a1 * p3 + a2 * p0 + a3 * p1
    r3 = a0 * p3 + a1 * p2 - a2 * p1 + a3 * p0
    nrm = 1.0 / math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
    out[0] = r0 * nrm
    out[1] = r1 * nrm
    out[2] = r2 * nrm
    out[3] = r3 * nrm
