"""Analytic velocity fields: uniform, and a moving cyclone or anticyclone.

Fields return eastward and northward velocity [m/s] at geographic points; drags sample them.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numba import njit

from siku_core import Param, hookimpl
from siku_core.geometry.sphere import latlon_to_xyz
from siku_core.interfaces import Field


class Uniform(Field):
    """The same velocity everywhere and always: ``(u, v)`` east and north [m/s]."""

    name = "uniform"
    params: ClassVar[dict[str, Param]] = {
        "u": Param(0.0, "m/s", "eastward velocity"),
        "v": Param(0.0, "m/s", "northward velocity"),
    }

    def sample(self, t, lat, lon):
        n = np.shape(lat)[0]
        return np.full(n, float(self.p["u"])), np.full(n, float(self.p["v"]))

    def uniform(self, t):
        return float(self.p["u"]), float(self.p["v"])


@njit(cache=True)
def _vortex(lat, lon, clat, clon, vmax, rmax, sense, alpha, radius):
    n = lat.shape[0]
    u = np.empty(n)
    v = np.empty(n)
    c = latlon_to_xyz(clat, clon)
    ca, sa = math.cos(alpha), math.sin(alpha)
    for i in range(n):
        p = latlon_to_xyz(lat[i], lon[i])
        cp = np.cross(c, p)
        s = math.sqrt(cp[0] ** 2 + cp[1] ** 2 + cp[2] ** 2)
        if s < 1e-15:
            u[i] = 0.0
            v[i] = 0.0
            continue
        ang = math.atan2(s, c[0] * p[0] + c[1] * p[1] + c[2] * p[2])
        r = ang * radius / rmax
        speed = vmax * r * math.exp(1.0 - r)
        ephi = cp / s  # counter-clockwise about the centre, seen from above
        er = np.cross(ephi, p)  # away from the centre
        wv = sense * speed * (ephi * ca - er * sa)
        rho = math.sqrt(p[0] ** 2 + p[1] ** 2)
        if rho < 1e-15:  # at a pole: east/north undefined, use lon = 0 axes
            east = np.array([0.0, 1.0, 0.0])
        else:
            east = np.array([-p[1] / rho, p[0] / rho, 0.0])
        north = np.cross(p, east)
        u[i] = wv[0] * east[0] + wv[1] * east[1] + wv[2] * east[2]
        v[i] = wv[0] * north[0] + wv[1] * north[1] + wv[2] * north[2]
    return u, v


class Cyclone(Field):
    """A vortex moving at constant speed: a cyclone or anticyclone.

    Tangential speed ``vmax (r/rmax) exp(1 - r/rmax)`` (zero at the centre, ``vmax`` at
    ``rmax``, decaying beyond), turned by ``inflow_angle`` towards the centre for a cyclone and
    away from it for an anticyclone. A cyclone turns counter-clockwise in the northern hemisphere
    and clockwise in the southern (the hemisphere of the centre at ``t = 0``); an anticyclone the
    other way. The centre moves at ``(move_east, move_north)`` [m/s]:
    ``lat_c = lat + move_north t / R``, ``lon_c = lon + move_east t / (R cos lat)``.
    """

    name = "cyclone"
    params: ClassVar[dict[str, Param]] = {
        "kind": Param("cyclone", "", "cyclone or anticyclone", type=str,
                      choices=("cyclone", "anticyclone")),
        "lat": Param(75.0, "deg", "centre latitude at t = 0", min=-90, max=90),
        "lon": Param(-150.0, "deg", "centre longitude at t = 0", min=-360, max=360),
        "vmax": Param(15.0, "m/s", "maximum wind speed", min=0),
        "rmax": Param(500e3, "m", "radius of maximum wind", min=1.0),
        "inflow_angle": Param(20.0, "deg", "cross-isobar angle (in for cyclones)", min=0,
                              max=90),
        "move_east": Param(0.0, "m/s", "eastward speed of the centre"),
        "move_north": Param(0.0, "m/s", "northward speed of the centre"),
    }

    def setup(self, ctx):
        self.radius = float(ctx.radius)

    def center(self, t: float) -> tuple[float, float]:
        """Centre latitude and longitude [rad] at ``t`` [s]."""
        lat0 = math.radians(self.p["lat"])
        lat = lat0 + self.p["move_north"] * t / self.radius
        coslat = max(math.cos(lat0), 1e-6)
        lon = math.radians(self.p["lon"]) + self.p["move_east"] * t / (self.radius * coslat)
        lat = max(-math.pi / 2, min(math.pi / 2, lat))
        return lat, lon

    def sample(self, t, lat, lon):
        clat, clon = self.center(t)
        hemi = 1.0 if self.p["lat"] >= 0 else -1.0
        sense = hemi if self.p["kind"] == "cyclone" else -hemi
        return _vortex(np.ascontiguousarray(lat, dtype=np.float64),
                       np.ascontiguousarray(lon, dtype=np.float64), clat, clon,
                       float(self.p["vmax"]), float(self.p["rmax"]), sense,
                       math.radians(self.p["inflow_angle"]), getattr(self, "radius", 6371e3))


@hookimpl
def siku_register_fields():
    return [Uniform, Cyclone]
