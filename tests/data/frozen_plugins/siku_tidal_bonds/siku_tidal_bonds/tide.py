"""Quadratic water drag of a uniform tidal current.

The current ``u(t) = (u_east, u_north) cos(2 pi t / tidal_period + tidal_phase)`` [m/s] drags
each element with ``F = rho_w C_d A |u - V| (u - V)`` [N] (``A`` the element's area [m²]); no
torque.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core import Param
from siku_core.geometry.quat import east_north_local
from siku_core.interfaces import ForcingSource


@njit(cache=True)
def _tidal_drag(q, V, area, ue, un, k, F):
    """Add ``k A |u - V| (u - V)`` [N] to ``F``, ``u = (ue, un)`` east and north [m/s]."""
    for i in range(q.shape[0]):
        ex, ey, nx, ny = east_north_local(q[i])
        rx = ue * ex + un * nx - V[i, 0]
        ry = ue * ey + un * ny - V[i, 1]
        s = k * area[i] * math.sqrt(rx * rx + ry * ry)
        F[i, 0] += s * rx
        F[i, 1] += s * ry


class TidalCurrent(ForcingSource):
    """Quadratic drag ``rho_w C_d A |u - V| (u - V)`` [N] of a tidally reversing current."""

    name = "tidal_current"
    params = {
        "u_east": Param(0.2, "m/s", "eastward amplitude of the current", min=-5.0, max=5.0),
        "u_north": Param(0.0, "m/s", "northward amplitude of the current", min=-5.0, max=5.0),
        "tidal_period": Param(44712.0, "s", "period of the current (M2 by default)", min=1.0),
        "tidal_phase": Param(0.0, "deg", "phase at t = 0", min=-360.0, max=360.0),
        "rho_water": Param(1026.0, "kg/m^3", "density of sea water", min=0.0),
        "drag_coefficient": Param(5.5e-3, "1", "water-ice drag coefficient C_d", min=0.0),
    }

    def setup(self, sim) -> None:
        self.area = sim.state.area

    def current(self, t: float) -> tuple[float, float]:
        """Eastward and northward current [m/s] at time ``t`` [s]."""
        p = self.p
        c = math.cos(2.0 * math.pi * t / p["tidal_period"] + math.radians(p["tidal_phase"]))
        return p["u_east"] * c, p["u_north"] * c

    def add(self, t, q, V, w, F, T):
        ue, un = self.current(t)
        _tidal_drag(q, V, self.area, ue, un, self.p["rho_water"] * self.p["drag_coefficient"], F)

    def py_add(self, t, q, V, w, F, T):
        """The drag in numpy, written apart from the kernel."""
        ue, un = self.current(t)
        k = self.p["rho_water"] * self.p["drag_coefficient"]
        en = np.array([east_north_local(qi) for qi in q])
        rel = ue * en[:, 0:2] + un * en[:, 2:4] - V
        F += k * self.area[:, None] * np.hypot(rel[:, 0], rel[:, 1])[:, None] * rel
