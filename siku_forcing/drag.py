"""Wind stress, water stress and Coriolis (report eqs. 18–21).

With ``U`` the ice velocity, ``k`` the local vertical and ``S`` the element area:

* air:   ``tau_a = rho_a C_a |U_a| (U_a cos th_a + k × U_a sin th_a)``            (eq. 19)
* water: ``tau_w = rho_w C_w |U_w - U| ((U_w - U) cos th_w + k × (U_w - U) sin th_w)`` (eq. 20)
* Coriolis: ``-m f k × U``, ``f = 2 Omega_E sin(lat)`` on the sphere.

``F = S (tau_a + tau_w) - m f k × U`` (eq. 18). Defaults are eq. 21 and
docs/explanation/physics.md §3.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numba import njit, prange

from siku_core import Param, hookimpl
from siku_core.geometry.quat import east_north_row, latlon_of
from siku_core.interfaces import ForcingSource
from siku_core.parallel import DRAG_NS, GRIDDED_DRAG_NS, alone, chunk_bounds, chunks
from siku_core.state import MELTED, STATIC

# ----------------------------------------------------------------- quadratic drag, shared
# The one drag kernel of the forcing sources (water_drag, air_drag, waves, the exchange grid).


@njit(cache=True, inline="always")
def drag_factor(area, coef, dx, dy):
    """``area coef |d|`` for the relative velocity ``d = (dx, dy)`` [m/s]: times ``d`` it is
    the quadratic drag force [N] on ``area`` [m²] with ``coef = rho C`` (or any split of the
    product: ``area`` may carry ``rho``; the products are taken left to right)."""
    return area * coef * math.sqrt(dx * dx + dy * dy)


@njit(cache=True, inline="always")
def quadratic_drag(area, coef, dx, dy):
    """Quadratic drag force ``area coef |d| d`` [N] (components along ``dx``, ``dy``), with
    ``coef = rho C`` [kg/m³]: :func:`drag_factor` times ``d``."""
    s = drag_factor(area, coef, dx, dy)
    return s * dx, s * dy


def drag_stability_limit(state, free: np.ndarray, rho: float, C: float, speed: float):
    """Explicit quadratic drag is stable for ``dt < m / (S rho C |dU|)`` (the drag's own time
    scale; ``m / S = rho_i h``): that bound for the free elements ``free`` (mask) at the
    relative speed ``speed`` [m/s], as ``(dt [s], element, m/S [kg/m²])`` of the element that
    sets it; ``None`` without free elements. The caller rules out ``rho C = 0``."""
    if not free.any():
        return None
    per_area = state.m[free] / state.area[free]
    i = int(np.argmin(per_area))
    return per_area[i] / (rho * C * speed), int(np.flatnonzero(free)[i]), per_area[i]


# ----------------------------------------------------------------- air and water drag
@njit(cache=True, inline="always")
def stress_one(q, V, i, ui, vi, area, rho, C, ct, st, subtract_ice, F):
    ex, ey, nx, ny = east_north_row(q, i)
    dx = ui * ex + vi * nx - subtract_ice * V[i, 0]
    dy = ui * ey + vi * ny - subtract_ice * V[i, 1]
    s = drag_factor(area[i] * rho, C, dx, dy)
    F[i, 0] += s * (dx * ct - dy * st)
    F[i, 1] += s * (dy * ct + dx * st)


@njit(cache=True, parallel=True)
def _stress(q, V, u, v, area, rho, C, theta, subtract_ice, F, nch=1):
    """Add ``S rho C |D| (D cos th + k × D sin th)``, ``D = U_field - subtract_ice U``, with the
    field velocity ``u, v`` [m/s] (east, north) per element."""
    ct, st = math.cos(theta), math.sin(theta)
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        for i in range(lo, hi):
            stress_one(q, V, i, u[i], v[i], area, rho, C, ct, st, subtract_ice, F)


@njit(cache=True, parallel=True)
def _stress_uniform(q, V, u, v, area, rho, C, theta, subtract_ice, F, nch=1):
    """:func:`_stress` for a field velocity ``(u, v)`` [m/s] that is the same everywhere."""
    ct, st = math.cos(theta), math.sin(theta)
    n = q.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        for i in range(lo, hi):
            stress_one(q, V, i, u, v, area, rho, C, ct, st, subtract_ice, F)


@njit(cache=True)
def _spin_drag(w, flags, coef, T):
    for i in range(w.shape[0]):
        if flags[i] != STATIC:
            T[i] -= coef[i] * w[i] * abs(w[i])


class _Drag(ForcingSource):
    uses_field = True
    field_required = True
    rho_default = 0.0
    C_default = 0.0

    def setup(self, ctx):
        self.st = ctx.state

    def _sample(self, t, q):
        lat, lon = latlon_of(q)
        return self.field.sample(t, lat, lon)

    def _add_stress(self, t, q, V, F, subtract_ice):
        """Stress from ``self.field`` (``None``: still air or water); a field that says it is
        uniform (``Field.uniform``) is not sampled per element, and one that has ``add_drag``
        (``gridded``) adds the stress itself in one pass instead of being sampled."""
        rho, C = float(self.p["rho"]), float(self.p["C"])
        theta = math.radians(self.p["turning_angle"])
        n = q.shape[0]
        if self.field is None:
            uv = (0.0, 0.0)
        else:
            uniform = getattr(self.field, "uniform", None)
            uv = uniform(t) if uniform is not None else None
        fused = getattr(self.field, "add_drag", None) if uv is None else None
        if fused is not None:  # the field interpolates and the drag follows in one pass
            nch = chunks(n, GRIDDED_DRAG_NS)
            with alone(nch):
                fused(t, q, V, self.st.area, rho, C, theta, subtract_ice, F, nch)
        elif uv is not None:
            nch = chunks(n, DRAG_NS)
            with alone(nch):
                _stress_uniform(q, V, float(uv[0]), float(uv[1]), self.st.area, rho, C, theta,
                                subtract_ice, F, nch)
        else:
            u, v = self._sample(t, q)
            nch = chunks(n, DRAG_NS)
            with alone(nch):
                _stress(q, V, np.ascontiguousarray(u, dtype=np.float64),
                        np.ascontiguousarray(v, dtype=np.float64), self.st.area, rho, C, theta,
                        subtract_ice, F, nch)


class AirDrag(_Drag):
    """Wind stress on each element (eq. 19) from a wind field; ``relative`` uses ``U_a - U``."""

    name = "air_drag"
    params: ClassVar[dict[str, Param]] = {
        "C": Param(0.0016, "1", "air–ice drag coefficient C_a (eq. 21)", min=0),
        "rho": Param(1.3, "kg/m^3", "air density rho_a", min=0),
        "turning_angle": Param(0.0, "deg", "turning angle th_a (CCW positive)", min=-90, max=90),
        "relative": Param(False, "", "use wind relative to the ice, U_a - U", type=bool),
    }

    def add(self, t, q, V, w, F, T):
        self._add_stress(t, q, V, F, 1.0 if self.p["relative"] else 0.0)


class WaterDrag(_Drag):
    """Water stress on each element (eq. 20) from a current field (still water if none).

    With ``spin_drag`` the quadratic drag of the rotational velocity is integrated over an
    equal-area disc: ``T = -rho_w C_w w|w| 2 pi r^5 / 5``, ``r = sqrt(S/pi)`` (an approximation
    that is exact for discs and within a few per cent for compact polygons).
    """

    name = "water_drag"
    field_required = False
    params: ClassVar[dict[str, Param]] = {
        "C": Param(0.0045, "1", "water–ice drag coefficient C_w (eq. 21)", min=0),
        "rho": Param(1026.0, "kg/m^3", "water density rho_w", min=0),
        "turning_angle": Param(0.0, "deg", "turning angle th_w (CCW positive)", min=-90, max=90),
        "spin_drag": Param(True, "", "damp spin by quadratic water drag", type=bool),
        "max_relative_speed": Param(
            1.0, "m/s", "largest expected ice–water speed, for the stable-time-step estimate",
            min=1e-6),
    }
    field = None

    def setup(self, ctx):
        super().setup(ctx)
        r = np.sqrt(self.st.area / math.pi)
        self.spin_coef = self.p["rho"] * self.p["C"] * 2.0 * math.pi * r**5 / 5.0

    def add(self, t, q, V, w, F, T):
        self._add_stress(t, q, V, F, 1.0)
        if self.p["spin_drag"]:
            _spin_drag(w, self.st.flags, self.spin_coef, T)

    def stability_limit(self, ctx):
        """Explicit drag is stable for ``dt < m / (S rho_w C_w |dU|)``.

        That is ``dt < rho_i h / (rho_w C_w |dU|)`` [s].
        """
        st = ctx.state
        if self.p["C"] == 0 or self.p["rho"] == 0:
            return None
        found = drag_stability_limit(st, (st.flags != STATIC) & (st.flags != MELTED),
                                     self.p["rho"], self.p["C"],
                                     self.p["max_relative_speed"])
        if found is None:
            return None
        dt, elem, per_area = found
        return dt, (f"water drag on element {elem} (mass per area {per_area:.4g} kg/m², "
                    f"|dU| = {self.p['max_relative_speed']:g} m/s)")


@njit(cache=True)
def _coriolis(q, V, m, omega, F):
    for i in range(q.shape[0]):
        z = 1.0 - 2.0 * (q[i, 1] * q[i, 1] + q[i, 2] * q[i, 2])  # sin(lat) of the centre
        f = 2.0 * omega * z
        # -m f k × U = m f (Vy, -Vx)
        F[i, 0] += m[i] * f * V[i, 1]
        F[i, 1] -= m[i] * f * V[i, 0]


class Coriolis(ForcingSource):
    """Coriolis force ``-m f k × U`` with ``f = 2 Omega sin(lat)`` at each element's centre.

    ``Omega`` is ``[planet] rotation_rate`` unless ``rotation_rate`` is given here.
    """

    name = "coriolis"
    params: ClassVar[dict[str, Param]] = {
        "rotation_rate": Param(-1.0, "rad/s", "planet rotation rate; -1: use [planet]", min=-1),
    }

    def setup(self, ctx):
        self.st = ctx.state
        r = self.p["rotation_rate"]
        self.omega = float(ctx.rotation_rate if r < 0 else r)

    def add(self, t, q, V, w, F, T):
        _coriolis(q, V, self.st.m, self.omega, F)


@hookimpl
def siku_register_forcing_sources():
    return [AirDrag, WaterDrag, Coriolis]
