"""``thermodynamics``: zero-layer growth and melt of the ice (Semtner 1976).

Each element's ice (thickness ``h`` [m]; snow of fixed depth ``h_s`` [m] on top, if given)
conducts heat from its base, held at the freezing temperature of sea water ``T_f`` [°C], to its
surface at ``T_s`` [°C] (uniform, or a gridded air temperature, e.g. NCEP/NCAR ``air.sig995``,
read through the ``gridded`` reader). With no heat stored in the ice (zero layers) the
conductive flux ``Q = (T_f - T_s) / (h / k_i + h_s / k_s)`` [W/m²] freezes ice at the base and
an ocean heat flux ``F_w`` [W/m²] melts it:

    rho_i L_f dh/dt = (T_f - T_s) / (h / k_i + h_s / k_s) - F_w

(``k_i``, ``k_s`` conductivities [W/(m K)], ``rho_i`` the element's density [kg/m³], ``L_f``
latent heat of fusion [J/kg]). A surface warmer than ``T_f`` conducts nothing (the surface is
at the melting point; surface melt is not modelled). Over an interval ``dt`` the conduction
part is integrated exactly (Stefan's law: ``h²/(2 k_i) + h h_s/k_s`` grows by ``(T_f - T_s)
dt / (rho_i L_f)``) and the ocean flux part is linear; the two are combined by Strang splitting
(half the melt, the growth, half the melt: second order in ``dt``, exact when either part is
zero).

With thickness categories (``ctx.categories``, :mod:`siku_core.categories`) the law grows or
melts each category's ice ``h_k`` on its own (thin ice grows faster: the conductive flux goes as
``1/h_k``), a category that melts through stays at ``h_k = 0``, and the fractions ``a_k`` do not
change (zero-layer thermodynamics has no lateral growth or melt); the element's thickness is the
mean ``sum a_k h_k / sum a_k`` of the result. An element thinner than ``min_thickness`` (its
mean thickness, with categories) has melted away: the engine flags it
``melted`` (it stops, its joints break, it touches nothing) and its volume leaves the budget.

Lateral (open-water) growth (``lateral = true``, categories needed): the open water of an
element, the share ``o = 1 - sum a_k`` of its area ``A``, loses the heat
``Q_o = C_o (T_f - T_s) - F_w`` [W/m²] (``C_o`` a bulk transfer coefficient [W/(m² K)], the same
surface air temperature ``T_s``; nothing when ``Q_o <= 0``) and freezes new ice of thickness
``h_0`` [m] (Hibler's 1979 demarcation thickness) into the category ``n`` (``new_ice_category``):

    d(A o)/dt = -A o Q_o / (rho_i L_f h_0),    dV/dt = A o Q_o / (rho_i L_f)

integrated exactly over ``dt``: ``o`` falls to ``o exp(-dt / tau)``, ``tau = rho_i L_f h_0 /
Q_o``, the fraction ``a_n`` grows by the difference ``da`` (so the fractions never sum above 1)
and ``h_n`` becomes ``(a_n h_n + da h_0) / (a_n + da)``: the volume ``A da h_0`` is added. It
runs after the growth of the existing ice (ice formed in an interval grows from the next).

Declared per-element fields: ``grown_volume`` [m³], the ice volume this process added to the
element since the start (negative: melted; summed on grids), ``growth_rate`` [m/s], the ice
volume per element area grown per second over the last interval (the thickness change without
categories; a cell mean on grids) and, with ``lateral``, ``lateral_volume`` [m³], the part of
``grown_volume`` frozen in open water. Volumes count as the engine does:
``A sum_k a_k h_k`` (:func:`~siku_core.categories.element_volume`).

References: Semtner, A. J. (1976), A model for the thermodynamic growth of sea ice in numerical
investigations of climate, J. Phys. Oceanogr. 6, 379-389. Hibler, W. D. (1979), A dynamic
thermodynamic sea ice model, J. Phys. Oceanogr. 9, 815-846.
"""
from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from siku_core.categories import row_mean, row_sum
from siku_core.errors import DataError, SceneError
from siku_core.fields import ElementField
from siku_core.interfaces import Process
from siku_core.params import Param
from siku_core.records import record_type
from siku_core.state import MELTED

#: temperature units a file may declare, by what they mean
KELVIN = {"k", "kelvin", "degk", "deg_k", "degrees_k", "kelvins"}
CELSIUS = {"degc", "celsius", "deg_c", "degrees_c", "c", "degree_celsius", "degrees_celsius",
           "°c"}
#: 0 °C in kelvin
T0 = 273.15


def stefan_thickness(h, hs, ki, ks, dT, dt, rho, L):
    """Thickness [m] after ``dt`` [s] of conduction-driven growth from ``h`` [m] under snow
    ``hs`` [m] (conductivities ``ki``, ``ks`` [W/(m K)]) with a temperature difference ``dT``
    [K] >= 0 across ice and snow: the exact solution of ``rho L dh/dt = dT / (h/ki + hs/ks)``."""
    a = 0.5 / ki
    b = hs / ks
    c = a * h * h + b * h + dT * dt / (rho * L)
    return (-b + np.sqrt(b * b + 4.0 * a * c)) / (2.0 * a)


@njit(cache=True, inline="always")
def _grow_one(h0, dT, dt, rho, F, L, hs, ki, ks):
    """Thickness [m] after ``dt`` [s] from ``h0`` (Strang splitting of the ocean melt around
    the exact conductive growth, module docstring), the arithmetic of
    :func:`stefan_thickness` for one value."""
    melt = 0.5 * F * dt / (rho * L)
    h = h0 - melt
    h = h if h > 0.0 else 0.0
    a = 0.5 / ki
    b = hs / ks
    c = a * h * h + b * h + dT * dt / (rho * L)
    return (-b + np.sqrt(b * b + 4.0 * a * c)) / (2.0 * a) - melt


#: the element data of the process (:meth:`Thermodynamics.apply`, their producer)
ThermoIce = record_type("ThermoIce", __name__, [
    ("h", "f", 1, "thickness [m] (updated)"),
    ("flags", "i", 1, "element flags (siku_core.state)"),
    ("area", "f", 1, "area [m^2]"),
    ("rho", "f", 1, "density [kg/m^3]"),
    ("fraction", "f", 2, "category fractions a_k [1], (n, K); K = 0: no categories "
                         "(updated by lateral growth)"),
    ("hk", "f", 2, "category thicknesses h_k [m], (n, K) (updated)"),
    ("grown", "f", 1, "ice volume grown since the start [m^3] (updated)"),
    ("rate", "f", 1, "growth rate of the last step [m/s] (written)"),
    ("lateral_volume", "f", 1, "ice volume grown in open water [m^3] (updated; empty "
                               "without lateral growth)"),
], "The per-element data the thermodynamics kernels read and write.")

#: the law's constants (scalars), :meth:`Thermodynamics.apply`
SemtnerParams = record_type("SemtnerParams", __name__, [
    ("F", "n", 0, "ocean heat flux F_w [W/m^2]"),
    ("L", "n", 0, "latent heat of fusion L_f [J/kg]"),
    ("hs", "n", 0, "snow depth h_s [m]"),
    ("ki", "n", 0, "ice conductivity k_i [W/(m K)]"),
    ("ks", "n", 0, "snow conductivity k_s [W/(m K)]"),
    ("hmin", "n", 0, "thickness below which an element has melted away [m]"),
], "The constants of zero-layer growth and melt.")

#: the kernels' scratch and results (allocated once by the process, their producer)
ThermoWork = record_type("ThermoWork", __name__, [
    ("gone", "i", 1, "the elements that melted away in the step, first ones (n)"),
    ("new", "f", 1, "a category row of new thicknesses [m] (K)"),
    ("scratch", "f", 1, "a category row [m] (K)"),
    ("grow", "f", 1, "new thickness of every element without categories [m] (n; K > 0: "
                     "empty)"),
], "The thermodynamics kernels' scratch.")


@njit(cache=True, error_model="numpy")
def _grow_all(ice, dT, dt, par, out):
    """Every element without categories in one pass without branches, on vectors of elements
    (the arithmetic of :func:`semtner_step` per element): thickness ``ice.h`` [m],
    ``ice.grown`` [m³] and ``ice.rate`` [m/s] of the elements that are not melted (``rate`` 0
    for those that are); an element thinner than ``par.hmin`` [m] after the step keeps its
    thickness and counts ``-A h`` as grown. ``out[e]``: the new thickness before that test.
    Returns how many melted away now."""
    h = ice.h
    flags = ice.flags
    area = ice.area
    rho = ice.rho
    grown = ice.grown
    rate = ice.rate
    F = par.F
    L = par.L
    hs = par.hs
    ki = par.ki
    ks = par.ks
    hmin = par.hmin
    ng = 0
    s = 1 if dT.shape[0] > 1 else 0  # dT per element, or one for all
    for e in range(h.shape[0]):
        h0 = h[e]
        hn = _grow_one(h0, dT[s * e], dt, rho[e], F, L, hs, ki, ks)
        out[e] = hn
        live = flags[e] != MELTED
        stay = not hn < hmin
        d = hn - h0 if stay else -h0  # melted away: its thickness as it was leaves the budget
        grown[e] = grown[e] + area[e] * d if live else grown[e]
        rate[e] = d / dt if live else 0.0
        h[e] = hn if live and stay else h0
        ng += 1 if live and not stay else 0
    return ng


@njit(cache=True, error_model="numpy")
def semtner_step(ice, dT, dt, par, lateral, work):
    """One application of the process (module docstring) to every element of ``ice``
    (:data:`ThermoIce`), in place: thickness ``ice.h`` [m], category thicknesses ``ice.hk``
    (``(n, K)``; ``(n, 0)``: no categories), ``ice.grown`` [m³] and ``ice.rate`` [m/s]; ``dT``
    [K] per element (or one for all); ``dt`` [s]; ``par``: the constants
    (:data:`SemtnerParams`); ``work.gone`` (:data:`ThermoWork`) gets the elements that melted
    away, their number returned. ``lateral``: ``(C_o, h_0, n)`` of the open-water growth
    (empty: none), which changes ``ice.fraction`` and adds to ``ice.lateral_volume`` [m³].
    """
    h = ice.h
    flags = ice.flags
    area = ice.area
    rho = ice.rho
    fraction = ice.fraction
    hk = ice.hk
    grown = ice.grown
    rate = ice.rate
    lateral_volume = ice.lateral_volume
    gone = work.gone
    new = work.new
    scratch = work.scratch
    grow = work.grow
    F = par.F
    L = par.L
    hs = par.hs
    ki = par.ki
    ks = par.ks
    hmin = par.hmin
    K = hk.shape[1]
    if K == 0:
        ng = _grow_all(ice, dT, dt, par, grow)
        if ng:  # the elements that melted away, in order
            ng = 0
            for e in range(h.shape[0]):
                if flags[e] != MELTED and grow[e] < hmin:
                    gone[ng] = e
                    ng += 1
        return ng
    ng = 0
    for e in range(h.shape[0]):
        if flags[e] == MELTED:
            rate[e] = 0.0
            continue
        dTe = dT[e] if dT.shape[0] > 1 else dT[0]
        a = fraction[e]
        for k in range(K):  # the ice volume per area before, sum a_k h_k [m]
            scratch[k] = a[k] * hk[e, k]
        v0 = row_sum(scratch)
        for k in range(K):  # each category on its own, the fractions unchanged
            x = _grow_one(hk[e, k], dTe, dt, rho[e], F, L, hs, ki, ks)
            new[k] = 0.0 if x < 0.0 else x
        hn = row_mean(a, new, scratch)
        if hn < hmin:  # melted away: thickness and categories as they were
            grown[e] += -area[e] * v0
            rate[e] = -v0 / dt
            gone[ng] = e
            ng += 1
            continue
        if lateral.shape[0]:
            Q = lateral[0] * dTe - F  # open-water heat loss [W/m²]
            if Q > 0.0:
                hnew = lateral[1]
                n = int(lateral[2])
                o = 1.0 - row_sum(a)
                if o > 0.0:
                    da = -o * math.expm1(-Q * dt / (rho[e] * L * hnew))
                    an = a[n]
                    a[n] = an + da
                    new[n] = (an * new[n] + da * hnew) / a[n]
                    over = row_sum(a) - 1.0
                    if over > 0.0:  # round-off: the fractions never sum above 1
                        a[n] -= over
                    lateral_volume[e] += area[e] * (a[n] - an) * hnew
                    hn = row_mean(a, new, scratch)
        for k in range(K):
            hk[e, k] = new[k]
            scratch[k] = a[k] * new[k]
        v1 = row_sum(scratch)
        grown[e] += area[e] * (v1 - v0)
        rate[e] = (v1 - v0) / dt
        h[e] = hn
    return ng


class Thermodynamics(Process):
    """Zero-layer growth and melt of the ice (Semtner 1976).

    Conduction through ice and snow, an ocean heat flux, elements that melt away (module
    docstring)."""

    name = "thermodynamics"
    #: each element grows or melts by itself (its thickness, categories, fields and surface
    #: temperature at its centre): each rank applies it to the elements it holds
    runs_on_ranks = True
    params: ClassVar[dict[str, Param]] = {
        "surface_temperature": Param(-20.0, "degC", "ice (or snow) surface temperature, uniform "
                                     "(without temperature_file)", min=-100.0, max=50.0),
        "temperature_file": Param("", "", "NetCDF file of the surface air temperature (relative "
                                  "to the scene; glob patterns join files along time)", type=str),
        "temperature_variable": Param("air", "", "name of the temperature variable", type=str),
        "temperature_units": Param("", "", "units of the file's temperature: 'K' or 'degC'; "
                                   "empty: from the variable's units attribute", type=str,
                                   choices=("", "K", "degC")),
        "freezing_temperature": Param(-1.8, "degC", "temperature of the ice base (freezing "
                                      "point of sea water)", min=-10.0, max=0.0),
        "conductivity": Param(2.03, "W m-1 K-1", "thermal conductivity of the ice k_i (fresh "
                              "ice 2.2, brine lowers it)", min=1e-3, max=10.0),
        "snow_thickness": Param(0.0, "m", "snow depth on the ice h_s (fixed)", min=0.0,
                                max=10.0),
        "snow_conductivity": Param(0.31, "W m-1 K-1", "thermal conductivity of snow k_s",
                                   min=1e-3, max=10.0),
        "latent_heat": Param(3.34e5, "J kg-1", "latent heat of fusion of the ice L_f (sea "
                             "ice: 2e5 to 3.34e5)", min=1e4, max=1e6),
        "ocean_heat_flux": Param(0.0, "W m-2", "heat flux from the ocean into the ice base F_w "
                                 "(positive: melts; 1e7 melts 3 cm of ice a second, a rate "
                                 "only accelerated tests use)", min=-1e7, max=1e7),
        "min_thickness": Param(0.05, "m", "an element thinner than this has melted away",
                               min=0.0),
        "lateral": Param(False, "", "open water freezes new ice (lateral growth; needs "
                         "thickness categories)", type=bool),
        "open_water_transfer": Param(13.0, "W m-2 K-1", "open-water heat loss per kelvin "
                                     "below freezing C_o (lateral)", min=0.0, max=1000.0),
        "new_ice_thickness": Param(0.5, "m", "thickness h_0 of the ice that forms in open "
                                   "water (lateral; Hibler 1979)", min=1e-3, max=10.0),
        "new_ice_category": Param(0, "1", "category (0-based) that receives the new ice "
                                  "(lateral)", type=int, min=0),
    }
    owned_fields = (
        ElementField("grown_volume", "m3", "ice volume added by thermodynamics since the start "
                     "(negative: melted)", grid="sum"),
        ElementField("growth_rate", "m s-1", "ice volume per element area grown by "
                     "thermodynamics per second over its last interval (the thickness change, "
                     "without thickness categories)", grid="mean"),
    )

    #: fields declared by some parameters (``siku plugins`` lists them): ``lateral = true``
    optional_fields = (
        ElementField("lateral_volume", "m3", "ice volume frozen in open water by "
                     "thermodynamics since the start (part of grown_volume)", grid="sum"),
    )

    def __init__(self, params=None):
        super().__init__(params)
        if self.p["lateral"]:
            self.owned_fields = type(self).owned_fields + self.optional_fields

    def setup(self, ctx) -> None:
        self.ctx = ctx
        st = ctx.state
        mats = list(ctx.scene.cfg.materials.values())
        #: element density [kg/m³]
        self.rho = np.array([mats[k].density for k in st.material], dtype=float)
        self.air = None
        if self.p["temperature_file"]:
            self.air = self._temperature_field(ctx)
        # the kernel's scratch, allocated once
        K = 0 if ctx.categories is None else ctx.categories.K
        self._none = np.zeros((st.n, 0))
        self._empty = np.zeros(0)
        self._dT = np.zeros(1)
        self._lateral = self._lateral_vector(ctx, K)
        self._work = ThermoWork(gone=np.empty(st.n, dtype=np.int64), new=np.empty(K),
                                scratch=np.empty(K), grow=np.empty(st.n if K == 0 else 0))
        bad = st.thickness < self.p["min_thickness"]
        if bad.any():
            i = int(np.argmax(bad))
            raise SceneError(f"{ctx.where(self.table)}: element {i} starts {st.thickness[i]:g} m "
                             f"thick, below min_thickness = {self.p['min_thickness']:g} m")

    def _lateral_vector(self, ctx, K: int) -> np.ndarray:
        """``(C_o, h_0, n)`` of the open-water growth, empty without (module docstring)."""
        p = self.p
        if not p["lateral"]:
            return np.zeros(0)
        where = ctx.where(self.table)
        if K == 0:
            raise SceneError(f"{where}: lateral = true needs thickness categories (an "
                             "[elements.mesh.cover] with category): without, an element "
                             "has no open water")
        if p["new_ice_category"] >= K:
            raise SceneError(f"{where}: new_ice_category = {p['new_ice_category']}; the scene "
                             f"has {K} categories (0 to {K - 1})")
        if p["new_ice_thickness"] < p["min_thickness"]:
            raise SceneError(f"{where}: new_ice_thickness = {p['new_ice_thickness']:g} m is "
                             f"below min_thickness = {p['min_thickness']:g} m")
        return np.array([float(p["open_water_transfer"]), float(p["new_ice_thickness"]),
                         float(p["new_ice_category"])])

    def _temperature_field(self, ctx) -> Any:
        """The gridded air temperature, read as the first component of a ``gridded`` field,
        and the scale that turns its values into °C (from its units)."""
        p = self.p
        var = p["temperature_variable"]
        field = ctx.component("field", "gridded", {"file": p["temperature_file"], "u": var,
                                                   "v": var, "quantity": "temperature"},
                              self.table)
        field.setup(ctx)
        found = str(field.cu.arrays[0].attrs.get("units", "")).strip()
        key = found.lower().replace(" ", "_")
        found_as = "K" if key in KELVIN else "degC" if key in CELSIUS else ""
        declared = p["temperature_units"]
        where = f"{ctx.where(self.table)}: {field.cu.label()} ('{var}')"
        if found and not found_as:
            raise DataError(f"{where}: units '{found}' are not a temperature siku reads; "
                            "K or degC")
        if declared and found_as and declared != found_as:
            raise DataError(f"{where}: the file's units are '{found}' but temperature_units = "
                            f"'{declared}' is declared; fix the file's units or the declaration")
        units = declared or found_as
        if not units:
            raise DataError(f"{where}: the variable has no units attribute; declare "
                            "temperature_units = 'K' or 'degC'")
        self.offset = -T0 if units == "K" else 0.0
        return field

    def surface_temperature(self, t: float) -> np.ndarray | float:
        """Surface temperature [°C] of every element at model time ``t`` [s]."""
        if self.air is None:
            return float(self.p["surface_temperature"])
        from siku_core.geometry.quat import latlon_of

        lat, lon = latlon_of(self.ctx.state.q)
        T, _ = self.air.sample(t, lat, lon)
        return T + self.offset

    def apply(self, ctx, dt: float) -> None:
        st = ctx.state
        p = self.p
        if dt <= 0.0:  # no time: no change
            return
        # the temperature at the middle of the interval (exact for a constant one)
        Ts = self.surface_temperature(ctx.time - 0.5 * dt)
        if np.ndim(Ts):
            dT = np.maximum(p["freezing_temperature"] - Ts, 0.0)
        else:
            dT = self._dT
            dT[0] = max(p["freezing_temperature"] - Ts, 0.0)
        cats = ctx.categories
        a, hk = (self._none, self._none) if cats is None else (cats.fraction, cats.thickness)
        ice = ThermoIce(
            h=st.thickness, flags=st.flags, area=st.area, rho=self.rho, fraction=a, hk=hk,
            grown=ctx.fields["grown_volume"], rate=ctx.fields["growth_rate"],
            lateral_volume=ctx.fields["lateral_volume"] if len(self._lateral) else self._empty)
        par = SemtnerParams(
            F=float(p["ocean_heat_flux"]), L=float(p["latent_heat"]),
            hs=float(p["snow_thickness"]), ki=float(p["conductivity"]),
            ks=float(p["snow_conductivity"]), hmin=float(p["min_thickness"]))
        ng = semtner_step(ice, dT, float(dt), par, self._lateral, self._work)
        if ng:
            ctx.melt(self._work.gone[:ng])

    def budget(self, ctx) -> float:
        return math.fsum(ctx.fields["grown_volume"])

    def close(self) -> None:
        if self.air is not None:
            self.air.close()
