"""Attenuation laws: how fast sea ice damps surface waves (plugin kind ``attenuation_law``,
interface ``siku_core.interfaces.AttenuationLaw``; ``docs/explanation/attenuation.md``).

Each law gives the spatial decay rate of the wave amplitude ``k_i`` [1/m] under a complete ice
cover, ``a(x) = a0 exp(-k_i x)``; the energy decays at ``alpha = 2 k_i`` [1/m]. The spectral
wave field (``siku_forcing.waves.spectral``) applies ``S_ice = -2 c_g k_i C E`` with the cell's ice
concentration ``C``, the form of WAVEWATCH III's ice source terms (``S/E = -2 c_g k_i``).

Shipped laws:

* ``constant``: ``k_i = alpha`` (WAVEWATCH III IC1);
* ``meylan2014``: the polynomial in frequency of Meylan, Bennetts & Kohout (2014, Geophys. Res.
  Lett. 41, 5046-5051, eq. 3), ``alpha = c0 + c1 f + c2 f² + c3 f³ + c4 f⁴`` with their fit
  ``c2 = 2.12e-3 s² m⁻¹``, ``c4 = 4.59e-2 s⁴ m⁻¹`` (``alpha = 2.12e-3 T⁻² + 4.59e-2 T⁻⁴``),
  ``k_i = alpha / 2`` (WAVEWATCH III IC4 method 2);
* ``doble2015``: the frequency-thickness law of Doble et al. (2015, Geophys. Res. Lett. 42,
  4473-4481, eq. 3) for pancake ice, ``alpha = 0.2 f^2.13 h`` (``f`` in Hz, ``h`` in m),
  ``k_i = alpha / 2`` (WAVEWATCH III IC4 method 7);
* ``viscous_layer``: a laminar viscous boundary layer under a rigid ice cover (Liu &
  Mollo-Christensen 1988, J. Phys. Oceanogr. 18, 1702-1712; WAVEWATCH III IC2 in the laminar
  regime, Stopa et al. 2016, The Cryosphere 10, 1605-1629): the energy decays in time at
  ``k sqrt(nu omega / 2)``, so ``k_i = k sqrt(nu omega / 2) / (2 c_g)`` with the open-water
  wavenumber ``k`` and group velocity ``c_g`` at the depth; in deep water ``k_i = sqrt(nu / 2)
  omega^(7/2) / g²``.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from siku_core import Param, hookimpl
from siku_core.interfaces import AttenuationLaw

from .wave_field import wavenumber


def group_velocity(omega, depth, g: float = 9.81):
    """Group velocity ``c_g = (omega / k) (1/2 + k h / sinh(2 k h))`` [m/s] of ``omega``
    [rad/s] in water of ``depth`` [m] (``inf``: ``g / (2 omega)``)."""
    omega = np.asarray(omega, float)
    k = np.asarray(wavenumber(omega, depth, g), float)
    if not math.isfinite(depth):
        return g / (2.0 * omega) + 0.0 * k
    kh = k * depth
    return omega / k * (0.5 + kh / np.sinh(2.0 * kh))


class Constant(AttenuationLaw):
    """Constant rate: ``k_i = alpha`` [1/m] at every frequency and thickness (IC1).

    WAVEWATCH III's IC1 form; the energy decays at ``2 alpha``."""

    name = "constant"
    params: ClassVar[dict[str, Param]] = {
        "alpha": Param(1e-5, "m-1", "amplitude attenuation rate k_i (energy: 2 alpha)",
                       min=0.0),
    }

    def rate(self, frequency, thickness, depth):
        f, h = np.broadcast_arrays(np.asarray(frequency, float), np.asarray(thickness, float))
        return np.full(f.shape, float(self.p["alpha"]))


class Meylan2014(AttenuationLaw):
    """Polynomial in frequency of Meylan et al. (2014), WAVEWATCH III IC4 method 2.

    Energy rate ``alpha = c0 + c1 f + c2 f² + c3 f³ + c4 f⁴`` [1/m] (Meylan, Bennetts & Kohout
    2014, eq. 3: ``c2 = 2.12e-3``, ``c4 = 4.59e-2``), ``k_i = alpha / 2``."""

    name = "meylan2014"
    params: ClassVar[dict[str, Param]] = {
        "c0": Param(0.0, "m-1", "constant term of the energy attenuation rate"),
        "c1": Param(0.0, "s m-1", "coefficient of f"),
        "c2": Param(2.12e-3, "s2 m-1", "coefficient of f^2 (Meylan et al. 2014: 2.12e-3)"),
        "c3": Param(0.0, "s3 m-1", "coefficient of f^3"),
        "c4": Param(4.59e-2, "s4 m-1", "coefficient of f^4 (Meylan et al. 2014: 4.59e-2)"),
    }

    def rate(self, frequency, thickness, depth):
        f, _ = np.broadcast_arrays(np.asarray(frequency, float), np.asarray(thickness, float))
        p = self.p
        alpha = p["c0"] + f * (p["c1"] + f * (p["c2"] + f * (p["c3"] + f * p["c4"])))
        return 0.5 * np.maximum(alpha, 0.0)


class Doble2015(AttenuationLaw):
    """Frequency and thickness law of Doble et al. (2015), WAVEWATCH III IC4 method 7.

    Pancake ice: energy rate ``alpha = c h f^n`` [1/m] with ``c = 0.2``, ``n = 2.13`` (their
    eq. 3), ``k_i = alpha / 2``."""

    name = "doble2015"
    params: ClassVar[dict[str, Param]] = {
        "c": Param(0.2, "s^n m-2", "coefficient (Doble et al. 2015: 0.2)", min=0.0),
        "n": Param(2.13, "1", "power of the frequency (Doble et al. 2015: 2.13)", min=0.0),
    }

    def rate(self, frequency, thickness, depth):
        f, h = np.broadcast_arrays(np.asarray(frequency, float), np.asarray(thickness, float))
        return 0.5 * self.p["c"] * np.maximum(h, 0.0) * f ** self.p["n"]


class ViscousLayer(AttenuationLaw):
    """Viscous boundary layer under the ice (Liu & Mollo-Christensen 1988; IC2 laminar).

    ``k_i = k sqrt(nu omega / 2) / (2 c_g)`` [1/m] with open-water ``k`` and ``c_g`` (Stopa et
    al. 2016); independent of the thickness."""

    name = "viscous_layer"
    params: ClassVar[dict[str, Param]] = {
        "viscosity": Param(1.83e-6, "m2 s-1", "kinematic (or eddy) viscosity nu of the layer "
                           "(1.83e-6: molecular, sea water at freezing)", min=0.0),
        "g": Param(9.81, "m s-2", "gravitational acceleration", min=0.0),
    }

    def rate(self, frequency, thickness, depth):
        f, _ = np.broadcast_arrays(np.asarray(frequency, float), np.asarray(thickness, float))
        om = 2.0 * math.pi * f
        g = float(self.p["g"])
        d = float(depth)
        k = np.asarray(wavenumber(om, d, g), float)
        cg = group_velocity(om, d, g)
        return k * np.sqrt(self.p["viscosity"] * om / 2.0) / (2.0 * cg)


@hookimpl
def siku_register_attenuation_laws():
    return [Constant, Meylan2014, Doble2015, ViscousLayer]
