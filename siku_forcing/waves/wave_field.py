"""Surface gravity waves on the ice: linear waves, a directional JONSWAP sea, and their forces.

Linear (Airy) theory. A sea is a sum of components ``j`` with amplitude ``a_j`` [m], angular
frequency ``omega_j`` [rad/s], wavenumber ``k_j`` [rad/m] from the finite-depth dispersion relation
``omega² = g k tanh(k h)`` (:func:`wavenumber`), direction of travel ``theta_j`` (clockwise from
north: 90° travels east) and phase ``phi_j``:

* elevation ``eta = sum a_j cos(psi_j)``, ``psi_j = kx_j x + ky_j y - omega_j t + phi_j``;
* slope ``grad eta = -sum a_j (kx_j, ky_j) sin(psi_j)``;
* surface orbital velocity ``u = sum a_j omega_j coth(k_j h) cos(psi_j) (kx_j, ky_j) / k_j``;
* curvature along a unit direction ``s``: ``d²eta/ds² = -sum a_j (k_j · s)² cos(psi_j)``.

``(x, y)`` [m] are east and north distances from the field's ``origin`` on the model sphere,
``x = R cos(lat0) (lon - lon0)``, ``y = R (lat - lat0)``: the phases are exact plane waves in that
plane, and east derivatives carry the metric factor ``cos(lat0) / cos(lat)`` (1 to within ``(L /
R) tan(lat)`` over a domain of size ``L``).

Forces (:class:`Waves`, forcing source ``waves``) on each element, at its own centre:

* water drag on the velocity relative to the orbital velocity, ``S rho_w C_d |u - U| (u - U)``
  with the log-layer drag coefficient of Orzech et al. eq. 6, ``C_d = [kappa / ln(30 dz / K_s)]²``
  (``kappa = 0.41``, roughness ``K_s``, layer thickness ``dz``), unless ``C`` is given;
* the surface-slope force ``-m g grad eta``;
* with ``breaking = true``, the wave-induced flexural breaking of
  :mod:`siku_forcing.waves.wave_breaking`.

The fields also serve any drag as a current: ``sample`` returns the surface orbital velocity.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numba import njit

from siku_core import Param, SceneError, hookimpl
from siku_core.interfaces import Field, ForcingSource
from siku_core.records import record_type
from siku_core.state import FREE

from ..drag import drag_stability_limit
from .wave_kernels import (  # noqa: F401 - re-exported, as before
    local_plane, plane_coords, plane_curvature, plane_evaluate, wave_forces, wrap_phase,
)
from .wave_methods import LINES_PARAMS, LinesMixin

#: von Kármán constant of the log-layer drag coefficient (Orzech et al. eq. 6)
KAPPA = 0.41
#: a separate random stream for wave phases: ``default_rng([seed, PHASE_STREAM])``
PHASE_STREAM = 2004


def wavenumber(omega, depth, g: float = 9.81):
    """Wavenumber ``k`` [rad/m] of ``omega`` [rad/s] in water of ``depth`` [m]
    (``inf``: deep water), solving ``omega² = g k tanh(k h)`` by Newton's method on ``x = k h``
    from Eckart's approximation ``x = y / sqrt(tanh y)``, ``y = omega² h / g``, until the step is
    below 1e-15 relative (a few iterations; the relation then holds to round-off)."""
    omega = np.asarray(omega, dtype=float)
    depth = np.broadcast_to(np.asarray(depth, dtype=float), omega.shape)
    k = np.empty(omega.shape)
    deep = ~np.isfinite(depth)
    k[deep] = omega[deep] ** 2 / g
    fin = ~deep
    if fin.any():
        h = depth[fin]
        y = omega[fin] ** 2 * h / g
        x = y / np.sqrt(np.tanh(y))
        for _ in range(60):
            th = np.tanh(x)
            dx = (x * th - y) / (th + x * (1.0 - th * th))
            x = x - dx
            if np.all(np.abs(dx) <= 1e-15 * x):
                break
        k[fin] = x / h
    return k if k.ndim else float(k)


def log_layer_drag(dz: float, roughness: float) -> float:
    """Drag coefficient of a logarithmic boundary layer, Orzech et al. eq. 6:
    ``C_d = [kappa / ln(30 dz / K_s)]²`` for a layer ``dz`` [m] and roughness ``K_s`` [m]."""
    r = 30.0 * dz / roughness
    if r <= 1.0:
        raise ValueError(f"30 dz / K_s = {r:g} must exceed 1 (dz = {dz:g} m, K_s = "
                         f"{roughness:g} m)")
    return (KAPPA / math.log(r)) ** 2


#: parameters of a water drag with the log-layer coefficient (``waves``, ``exchange``)
WATER_DRAG_PARAMS = {
    "slope": Param(True, "", "surface-slope force -m g grad eta", type=bool),
    "rho": Param(1026.0, "kg/m^3", "water density rho_w", min=0.0),
    "C": Param(-1.0, "1", "drag coefficient; -1: log layer, Orzech et al. 2018 eq. 6", min=-1.0),
    "roughness": Param(0.001, "m", "roughness height K_s of eq. 6", min=1e-9),
    "layer": Param(1.0, "m", "thickness dz of the layer below the ice in eq. 6", min=1e-9),
}


def drag_coefficient(p, source: str) -> float:
    """``C`` of parameters ``p`` (:data:`WATER_DRAG_PARAMS`): as given, or eq. 6 when -1."""
    if p["C"] >= 0:
        return float(p["C"])
    try:
        return log_layer_drag(p["layer"], p["roughness"])
    except ValueError as exc:
        raise SceneError(f"forcing '{source}': {exc}") from None


def jonswap(f, hs: float, tp: float, gamma: float = 3.3, g: float = 9.81):
    """JONSWAP frequency spectrum ``S(f)`` [m²/Hz] of significant wave height ``hs`` [m] and
    peak period ``tp`` [s]: ``alpha g² (2 pi)^-4 f^-5 exp(-5/4 (fp/f)^4) gamma^r``, ``r =
    exp(-(f - fp)² / (2 sigma² fp²))``, ``sigma`` 0.07 below the peak and 0.09 above, with
    ``alpha`` set so that ``4 sqrt(integral of S over 0..inf) = hs`` (the integral by adaptive
    quadrature)."""
    from scipy.integrate import quad

    fp = 1.0 / tp

    def shape(x):
        x = np.asarray(x, dtype=float)
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            sig = np.where(x <= fp, 0.07, 0.09)
            r = np.exp(-((x - fp) ** 2) / (2.0 * sig**2 * fp**2))
            s = g**2 * (2 * np.pi) ** -4 * x**-5.0 * np.exp(-1.25 * (fp / x) ** 4) * gamma**r
        return np.where(x > 0, s, 0.0)

    m0 = sum(quad(lambda x: float(shape(x)), a, b, limit=200)[0]
             for a, b in ((0.0, fp), (fp, 3 * fp), (3 * fp, 30 * fp)))
    m0 += quad(lambda x: float(shape(x)), 30 * fp, np.inf)[0]
    return shape(f) * (hs / 4.0) ** 2 / m0


# ------------------------------------------------------- kernels: siku_forcing.waves.wave_kernels
#: a sea of plane waves as the kernels take it (:meth:`WaveField.plane_waves`)
PlaneWaves = record_type("PlaneWaves", __name__, [
    ("lat0", "n", 0, "latitude of the field's origin, where x = y = 0 [rad]"),
    ("lon0", "n", 0, "longitude of the origin [rad]"),
    ("R", "n", 0, "radius of the model sphere [m]"),
    ("depth", "n", 0, "water depth h [m] (inf: deep water)"),
    ("amp", "f", 1, "(M,) amplitude a_j of each component [m]"),
    ("kx", "f", 1, "(M,) wavenumber east [rad/m]"),
    ("ky", "f", 1, "(M,) wavenumber north [rad/m]"),
    ("omega", "f", 1, "(M,) angular frequency [rad/s]"),
    ("phase", "f", 1, "(M,) phase at the origin at t = 0 [rad]"),
    ("k", "f", 1, "(M,) wavenumber's magnitude [rad/m]"),
    ("uo", "f", 1, "(M,) surface orbital speed a omega coth(k h) [m/s]"),
], doc="A sea of plane waves: the field's plane and its components (module docstring).")


class WaveField(Field):
    """Base of wave fields: components ``amp, kx, ky, omega, phase`` (arrays) and the methods
    of the module docstring. Subclasses fill the components in :meth:`components`."""

    #: common parameters: where phases are measured from, gravity, depth
    common: ClassVar[dict[str, Param]] = {
        "origin": Param([0.0, 0.0], "deg", "[lon, lat] where x = y = 0 (phase reference)",
                        type=list),
        "depth": Param(-1.0, "m", "water depth h; -1: deep water", min=-1.0),
        "g": Param(9.81, "m/s^2", "gravitational acceleration", min=0.01, max=100.0),
    }
    radius = 6_371_000.0

    def where(self) -> str:
        """The scene file and table of this field, for messages (its name before set-up)."""
        return getattr(self, "_where", f"field '{self.name}'")

    def setup(self, ctx):
        if self.table:
            self._where = f"{ctx.where(self.table)} field '{self.name}'"
        self.radius = float(ctx.radius)
        self.seed = int(ctx.seed)
        self._build()

    def _build(self):
        o = self.p["origin"]
        if len(o) != 2 or not all(isinstance(v, (int, float)) for v in o) or abs(o[1]) >= 90:
            raise SceneError(f"{self.where()}: 'origin' must be [lon, lat] in degrees, off the "
                             "poles")
        self.lon0, self.lat0 = math.radians(o[0]), math.radians(o[1])
        amp, omega, direction, phase = self.components()
        depth = self.p["depth"]
        self.h = math.inf if depth < 0 else float(depth)
        if self.h == 0.0:
            raise SceneError(f"{self.where()}: depth must be positive (or -1 for deep water)")
        k = np.atleast_1d(wavenumber(omega, self.h, self.p["g"]))
        th = np.radians(direction)
        self.amp = np.ascontiguousarray(amp, dtype=float)
        self.omega = np.ascontiguousarray(omega, dtype=float)
        self.k = k
        self.theta = th
        self.kx = np.ascontiguousarray(k * np.sin(th))
        self.ky = np.ascontiguousarray(k * np.cos(th))
        self.phase = np.ascontiguousarray(phase, dtype=float)
        coth = 1.0 / np.tanh(k * self.h) if math.isfinite(self.h) else np.ones_like(k)
        self.u_orbital = np.ascontiguousarray(self.amp * self.omega * coth)

    def components(self):
        """``(amp [m], omega [rad/s], direction [deg clockwise from north], phase [rad])``."""
        raise NotImplementedError

    def _args(self):
        if not hasattr(self, "amp"):
            self._build()
        return (self.lat0, self.lon0, self.radius, self.amp, self.kx, self.ky, self.omega,
                self.phase)

    def plane_waves(self):
        """The sea now as the kernels take it: a :data:`PlaneWaves` record of this field's
        arrays (built first if need be; the record holds them, it copies nothing)."""
        self._args()
        return PlaneWaves(lat0=self.lat0, lon0=self.lon0, R=self.radius, depth=self.h,
                          amp=self.amp, kx=self.kx, ky=self.ky, omega=self.omega,
                          phase=self.phase, k=self.k, uo=self.u_orbital)

    def plane(self, lat, lon):
        """East and north distances [m] of points ``lat, lon`` [rad] from the origin."""
        a = self._args()
        return plane_coords(np.ascontiguousarray(lat, dtype=float),
                      np.ascontiguousarray(lon, dtype=float), a[0], a[1], a[2])

    def evaluate(self, t, lat, lon) -> dict[str, np.ndarray]:
        """``eta`` [m], slope ``eta_e``, ``eta_n`` [1] (east, north), orbital velocity ``u``,
        ``v`` [m/s] at ``lat, lon`` [rad] and time ``t`` [s]."""
        r = plane_evaluate(float(t), np.ascontiguousarray(lat, dtype=float),
                      np.ascontiguousarray(lon, dtype=float), self.plane_waves())
        return {"eta": r[:, 0], "eta_e": r[:, 1], "eta_n": r[:, 2], "u": r[:, 3], "v": r[:, 4]}

    def sample(self, t, lat, lon):
        r = self.evaluate(t, lat, lon)
        return r["u"], r["v"]

    def curvature(self, t, lat, lon, se, sn) -> np.ndarray:
        """Curvature ``d²eta/ds²`` [1/m] along unit directions ``(se, sn)`` (east, north)."""
        f = np.ascontiguousarray
        return plane_curvature(float(t), f(lat, dtype=float), f(lon, dtype=float),
                          f(se, dtype=float), f(sn, dtype=float), self.plane_waves())

    def variance(self) -> float:
        """Variance of the elevation [m²], ``sum a_j² / 2``."""
        self._args()
        return float(np.sum(self.amp**2) / 2.0)

    def shortest_period(self) -> float:
        self._args()
        return float(2 * np.pi / np.max(self.omega))


class LinearWave(WaveField):
    """A monochromatic linear wave: ``eta = a cos(k·x - omega t + phase)``, finite depth."""

    name = "linear_wave"
    params: ClassVar[dict[str, Param]] = {
        "amplitude": Param(0.5, "m", "amplitude a (half the height)", min=0.0),
        "period": Param(8.0, "s", "period T = 2 pi / omega", min=1e-3),
        "direction": Param(90.0, "deg", "direction of travel, clockwise from north (90: east)"),
        "phase": Param(0.0, "deg", "phase at the origin at t = 0"),
        **WaveField.common,
    }

    def components(self):
        p = self.p
        return (np.array([p["amplitude"]]), np.array([2 * math.pi / p["period"]]),
                np.array([p["direction"]]), np.array([math.radians(p["phase"])]))


class Jonswap(LinesMixin, WaveField):
    """A directional sea: JONSWAP spectrum, ``cos^2s`` spreading, random phases from the seed.

    ``n_frequencies`` bins of equal width over ``[f_low, f_high] × f_p`` and ``n_directions``
    over the whole circle; component amplitude ``a = sqrt(2 S(f) D(theta) df dtheta)`` at the
    bin centres, so the elevation variance is the spectrum's integral over the band (the tail
    above ``4 f_p`` holds 0.5 % of the variance: Hs 0.25 % low by default). Spreading ``D(theta)
    ∝ cos^2s((theta - theta_m) / 2)``, normalised over the discrete directions. Phases are
    uniform on ``[0, 2 pi)`` from ``seed`` (-1: the scene's ``[run] seed``).
    """

    name = "jonswap"
    params: ClassVar[dict[str, Param]] = {
        "hs": Param(1.0, "m", "significant wave height Hs = 4 sqrt(m0)", min=0.0),
        "tp": Param(8.0, "s", "peak period", min=1e-3),
        "gamma": Param(3.3, "1", "peak enhancement factor", min=1.0),
        "direction": Param(90.0, "deg", "mean direction of travel, clockwise from north"),
        "spreading": Param(10.0, "1", "directional spreading exponent s of cos^2s (at most 1e4: "
                           "a spread of 0.8 deg)", min=0.0, max=1e4),
        "n_frequencies": Param(48, "1", "frequency bins", type=int, min=1, max=4096),
        "n_directions": Param(16, "1", "direction bins (1: unidirectional)", type=int, min=1,
                              max=720),
        "f_low": Param(0.5, "1", "lowest frequency, in units of the peak frequency", min=0.01),
        "f_high": Param(4.0, "1", "highest frequency, in units of the peak frequency", min=1.0),
        "seed": Param(-1, "1", "random seed of the phases (-1: the scene's [run] seed)",
                      type=int, min=-1),
        **LINES_PARAMS,
        **WaveField.common,
    }
    seed = 0

    def components(self):
        p = self.p
        fp = 1.0 / p["tp"]
        if p["f_low"] >= p["f_high"]:
            raise SceneError(f"{self.where()}: f_low must be below f_high")
        nf, nd = p["n_frequencies"], p["n_directions"]
        edges = np.linspace(p["f_low"] * fp, p["f_high"] * fp, nf + 1)
        f = 0.5 * (edges[1:] + edges[:-1])
        S = jonswap(f, p["hs"], p["tp"], p["gamma"], p["g"]) * np.diff(edges)
        if nd == 1:
            th = np.array([p["direction"]])
            D = np.ones(1)
        else:
            dth = 360.0 / nd
            th = p["direction"] - 180.0 + dth * (np.arange(nd) + 0.5)
            D = np.cos(np.radians(th - p["direction"]) / 2.0) ** (2 * p["spreading"])
            D /= D.sum()
        amp = np.sqrt(2.0 * np.outer(S, D)).ravel()
        omega = np.repeat(2 * np.pi * f, len(th))
        direction = np.tile(th, nf)
        seed = self.seed if p["seed"] < 0 else p["seed"]
        phase = np.random.default_rng([seed, PHASE_STREAM]).uniform(0, 2 * np.pi, amp.size)
        keep = amp > 0
        return amp[keep], omega[keep], direction[keep], phase[keep]


# ----------------------------------------------------------------------------- forcing
class Waves(ForcingSource):
    """Wave forces on every element at its centre: drag on the velocity relative to the orbital
    velocity (log-layer ``C_d``, Orzech et al. eq. 6) and the slope force ``-m g grad eta``;
    optional wave-induced flexural breaking of joints (``siku_forcing.waves.wave_breaking``)."""

    name = "waves"
    uses_field = True
    field_required = True
    params: ClassVar[dict[str, Param]] = {
        "drag": Param(True, "", "water drag relative to the orbital velocity", type=bool),
        **WATER_DRAG_PARAMS,
        "breaking": Param(False, "", "break joints by wave-induced flexure", type=bool),
        "critical_strain": Param(3e-5, "1", "flexural strain that breaks a joint", min=0.0),
        "break_every": Param(0.0, "s", "interval between breaking checks (0: every step)",
                             min=0.0),
    }

    @classmethod
    def accepts_field(cls, field_cls):
        return issubclass(field_cls, WaveField)

    def zero_field(self):
        """A calm sea: a linear wave of zero amplitude."""
        return LinearWave({**{k: p.default for k, p in LinearWave.params.items()},
                           "amplitude": 0.0})

    def setup(self, ctx):
        self._setup(ctx)
        p = self.p
        if p["breaking"]:
            from .wave_breaking import FlexuralBreaking

            self.breaker = FlexuralBreaking(ctx, self.field, p["critical_strain"],
                                            p["break_every"], p["rho"])

    def setup_on_rank(self, ctx, run, link):
        """On an MPI rank: the forces as :meth:`setup` sets them up over the rank's elements;
        breaking is the run's check, made alike on every rank over the whole run (its floes
        span ranks: ``siku_forcing.waves.wave_breaking.RankBreaking``)."""
        self._setup(ctx)
        if run.breaker is not None:
            from .wave_breaking import RankBreaking

            self.breaker = RankBreaking(run.breaker, link, ctx.state)

    def _setup(self, ctx):
        self.ctx = ctx
        self.st = ctx.state
        p = self.p
        self.C = drag_coefficient(p, self.name)
        self.g = float(self.field.p["g"])
        self.free = self.st.flags == FREE
        self.breaker = None

    def add(self, t, q, V, w, F, T):
        f = self.field
        w = f.plane_waves()
        if self.breaker is not None and self.ctx.committing:
            self.breaker.check(t, q)
        drag = self.C * self.p["rho"] if self.p["drag"] else 0.0
        if hasattr(f, "add_forces"):  # a sea that varies in space (siku_forcing.waves.spectral)
            f.add_forces(t, q, V, self.st, self.free, self.g, bool(self.p["slope"]), drag, F)
            return
        if drag == 0.0 and not self.p["slope"]:
            return
        _wave_forces_t(float(t), q, V, self.st.m, self.st.area, self.free, tuple(w), self.g,
                       bool(self.p["slope"]), drag, F)

    def stability_limit(self, ctx):
        """Drag: ``dt < m / (S rho_w C_d |dU|)`` with ``|dU|`` the largest orbital speed plus
        1 m/s of drift; and a tenth of the shortest wave period at ``dt_safety = 0.5``, so that
        every wave is sampled at ten steps or more."""
        st = ctx.state
        limits = [(0.2 * self.field.shortest_period(),
                   f"the shortest wave period {self.field.shortest_period():.4g} s")]
        if self.p["drag"] and self.C * self.p["rho"] > 0:
            du = float(np.sum(self.field.u_orbital)) + 1.0
            found = drag_stability_limit(st, st.flags == FREE, self.p["rho"], self.C, du)
            if found is not None:
                limits.append((found[0],
                               f"wave drag (C_d = {self.C:.4g}, |dU| up to {du:.3g} m/s)"))
        return min(limits, key=lambda x: x[0])


@hookimpl
def siku_register_fields():
    return [LinearWave, Jonswap]


@hookimpl
def siku_register_forcing_sources():
    return [Waves]


@njit(cache=True)
def _wave_forces_t(t, q, V, m, area, free, w_t, g, slope, drag_coef, F):
    """:func:`~siku_forcing.waves.wave_kernels.wave_forces` with the sea ``w_t`` as a plain
    tuple, named again here (:mod:`siku_core.records`, "At the boundary")."""
    wave_forces(t, q, V, m, area, free, PlaneWaves(*w_t), g, slope, drag_coef, F)
