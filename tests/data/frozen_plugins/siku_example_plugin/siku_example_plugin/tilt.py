"""Sea-surface tilt: the pressure-gradient force of a sloping sea surface on floating ice.

Ice floating on a sea surface of height ``eta`` feels the horizontal pressure gradient of the
water beneath it::

    F = -m g ∇eta,      ∇eta = (s_e, s_n) c(t),
    c(t) = cos(2 pi t / P + phi)   (P > 0: a tidal oscillation),   c = 1   (P = 0: steady)

with ``m`` the element mass [kg], ``g`` the gravitational acceleration [m/s²] and ``(s_e, s_n)``
the eastward and northward slope [m/m]. The slope is uniform over the domain. The force acts at
the centre of mass, so it exerts no torque. Typical ocean slopes are 1e-7 to 1e-5; a geostrophic
current ``U`` tilts the surface by ``f U / g`` (about 1.4e-6 for 0.1 m/s at 75°N).

The force is computed in geographic east/north and turned into each element's local frame with
:func:`siku_core.geometry.quat.east_north_local` (the local frame turns as the element spins).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core import Param
from siku_core.geometry.quat import east_north_local
from siku_core.interfaces import ForcingSource


@njit(cache=True)
def _tilt(q, m, ax, ay, F):
    """Add ``m (ax, ay)`` (east, north) [N] to ``F`` in each element's local frame."""
    for i in range(q.shape[0]):
        ex, ey, nx, ny = east_north_local(q[i])
        F[i, 0] += m[i] * (ax * ex + ay * nx)
        F[i, 1] += m[i] * (ax * ey + ay * ny)


class SeaSurfaceTilt(ForcingSource):
    """Pressure-gradient force ``F = -m g ∇eta`` of a uniformly tilted sea surface [N].

    ``∇eta = (slope_east, slope_north) cos(2 pi t / tidal_period + tidal_phase)``, or constant
    when ``tidal_period = 0``. No torque.
    """

    name = "sea_surface_tilt"
    params = {
        "slope_east": Param(0.0, "m/m", "eastward sea-surface slope d(eta)/dx", min=-1e-3,
                            max=1e-3),
        "slope_north": Param(0.0, "m/m", "northward sea-surface slope d(eta)/dy", min=-1e-3,
                             max=1e-3),
        "g": Param(9.81, "m/s^2", "gravitational acceleration", min=0.0),
        "tidal_period": Param(0.0, "s", "period P of the slope's oscillation; 0: steady",
                              min=0.0),
        "tidal_phase": Param(0.0, "deg", "phase phi of the oscillation at t = 0", min=-360.0,
                             max=360.0),
    }

    def setup(self, ctx) -> None:
        self.m = ctx.state.m

    def acceleration(self, t: float) -> tuple[float, float]:
        """Eastward and northward acceleration ``-g ∇eta`` [m/s²] at time ``t`` [s]."""
        p = self.p
        c = 1.0
        if p["tidal_period"] > 0:
            c = math.cos(2.0 * math.pi * t / p["tidal_period"] + math.radians(p["tidal_phase"]))
        return -p["g"] * p["slope_east"] * c, -p["g"] * p["slope_north"] * c

    def add(self, t, q, V, w, F, T):
        ax, ay = self.acceleration(t)
        _tilt(q, self.m, ax, ay, F)

    def py_add(self, t, q, V, w, F, T):
        """Pure-Python (numpy) reference of :meth:`add`, for the conformance suite.

        The local east and north axes come from the rotation matrix of ``q`` written out here,
        independently of the compiled helpers.
        """
        ax, ay = self.acceleration(t)
        a, b, c, d = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
        # columns of R(q): the local x, y, z axes in the global frame
        X = np.stack([1 - 2 * (c * c + d * d), 2 * (b * c + a * d), 2 * (b * d - a * c)], axis=1)
        Y = np.stack([2 * (b * c - a * d), 1 - 2 * (b * b + d * d), 2 * (c * d + a * b)], axis=1)
        Z = np.stack([2 * (b * d + a * c), 2 * (c * d - a * b), 1 - 2 * (b * b + c * c)], axis=1)
        rho = np.hypot(Z[:, 0], Z[:, 1])
        pole = rho < 1e-14
        safe = np.where(pole, 1.0, rho)
        east = np.stack([-Z[:, 1] / safe, Z[:, 0] / safe, np.zeros_like(rho)], axis=1)
        ex = np.where(pole, 1.0, (east * X).sum(axis=1))
        ey = np.where(pole, 0.0, (east * Y).sum(axis=1))
        # north = up × east: in the local frame (-ey, ex)
        F[:, 0] += self.m * (ax * ex - ay * ey)
        F[:, 1] += self.m * (ax * ey + ay * ex)
