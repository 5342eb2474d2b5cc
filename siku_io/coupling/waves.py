"""The ``spectral`` wave field behind the Basic Model Interface (``siku_io.coupling.bmi``):
another model sets the incident spectrum and reads what the ice does to the waves per cell.

In a scene whose ``waves`` forcing takes the field ``spectral`` (``siku_forcing.waves.spectral``)
the
BMI has two more grids. Grid 1 is the field's own grid: ``uniform_rectilinear``, ``(ny, nx)``
nodes at the cell centres, spacing and origin in metres east (``x``) and north (``y``) of the
field's ``origin``, values row by row (``y`` slowest). Grid 2 holds the components of the sea:
``uniform_rectilinear`` of rank 1, node ``j`` is component ``j`` (spacing 1, origin 0).

Input (grid 2): ``sea_surface_wave__incident_energy`` [m²], the variance ``E_j = a_j²/2`` of each
component of the incident sea, which enters the grid across its open edges from the next
sub-step on (the sea already on the grid is left as it is). Outputs: the components' frequency
[Hz] and direction of travel [degree clockwise from north] (grid 2); per cell (grid 1) the ice's
energy attenuation rate of the incident sea ``sum_j 2 k_i,j C E_j / sum_j E_j`` [m-1] (``k_i``
of the scene's attenuation law, ``C`` the cell's ice concentration; with no incident energy the
mean over the components), the wave power the ice absorbs [W m-2] and the significant wave
height [m] (those of ``siku_forcing.waves.spectral``).
"""
from __future__ import annotations

import numpy as np

#: the steepest periodic wave, amplitude times wavenumber (Stokes' limit, H / L = 0.141)
STEEPEST = 0.443
#: name -> (key, units, "in"/"out", description, grid)
WAVE_VARIABLES: dict[str, tuple[str, str, str, str, int]] = {
    "sea_surface_wave__incident_energy": (
        "E_in", "m2", "in", "variance a_j^2/2 of each component of the incident sea, entering "
        "across the open edges of the spectral grid", 2),
    "sea_surface_wave__frequency": ("f", "Hz", "out", "frequency of each component", 2),
    "sea_surface_wave__direction": (
        "direction", "degree", "out", "direction of travel of each component, clockwise from "
        "north", 2),
    "sea_ice__wave_energy_attenuation_rate": (
        "attenuation", "m-1", "out", "energy attenuation rate of the incident sea by the ice "
        "of the cell, sum 2 k_i C E_in / sum E_in", 1),
    "sea_ice__absorbed_wave_power": (
        "dissipation", "W m-2", "out", "wave power absorbed by the ice per unit area of the "
        "cell, rho g sum 2 c_g k_i C E", 1),
    "sea_surface_wave__significant_height": (
        "height", "m", "out", "significant wave height 4 sqrt(sum E) of the cell", 1),
}


def spectral_field(sim):
    """The ``spectral`` wave field of a simulation's forcing, or None."""
    from siku_forcing.waves.spectral import Spectral

    for f in sim.forcing:
        if isinstance(f.field, Spectral):
            return f.field
    return None


class WaveCoupling:
    """Grids 1 and 2 and the variables of :data:`WAVE_VARIABLES` for a spectral field."""

    def __init__(self, field):
        self.field = field

    # ------------------------------------------------------------------ grids
    def shape(self, grid: int) -> tuple[int, ...]:
        f = self.field
        return (f.ny, f.nx) if grid == 1 else (len(f.E_in),)

    def spacing(self, grid: int) -> tuple[float, ...]:
        return (self.field.dy, self.field.dx) if grid == 1 else (1.0,)

    def origin(self, grid: int) -> tuple[float, ...]:
        f = self.field
        return (f.y0 + 0.5 * f.dy, f.x0 + 0.5 * f.dx) if grid == 1 else (0.0,)

    def x(self, grid: int) -> np.ndarray:
        f = self.field
        if grid == 1:
            return f.x0 + f.dx * (np.arange(f.nx) + 0.5)
        return np.arange(len(f.E_in), dtype=float)

    def y(self, grid: int) -> np.ndarray:
        f = self.field
        if grid != 1:
            raise NotImplementedError("grid 2 (the wave components) has rank 1: no y")
        return f.y0 + f.dy * (np.arange(f.ny) + 0.5)

    # ------------------------------------------------------------------ values
    def input(self, key: str) -> np.ndarray:
        """The incident energy the transport reads (writing into it sets it)."""
        return self.field.E_in

    def set_input(self, name: str, a: np.ndarray, where=slice(None)) -> None:
        """Refuse energies no sea holds: negative, or of a component steeper than a Stokes
        wave's limit ``a k = 0.443`` (``E = a² / 2``; a wave breaks beyond it)."""
        from siku_core.errors import InputError

        if (a < 0).any():
            j = int(np.flatnonzero(a < 0)[0])
            raise InputError(f"{name}: component {j} has {a[j]:g} m2: a sea holds no negative "
                             "energy")
        top = 0.5 * (STEEPEST / np.asarray(self.field.k, float)[where].reshape(-1)) ** 2
        if (a > top).any():
            j = int(np.flatnonzero(a > top)[0])
            j_grid = int(np.arange(len(self.field.E_in))[where].reshape(-1)[j])
            raise InputError(f"{name}: component {j_grid} has {a[j]:g} m2, above the "
                             f"{top[j]:.4g} m2 of the steepest wave of its length (a k = "
                             f"{STEEPEST}: it would break); give at most that")

    def output(self, key: str) -> np.ndarray:
        f = self.field
        if key == "f":
            out = f.f
        elif key == "direction":
            out = np.degrees(f.theta) % 360.0
        elif key == "attenuation":
            w = f.E_in if f.E_in.sum() > 0 else np.ones(len(f.E_in))
            rate = 2.0 * np.tensordot(w, f.ki, axes=(0, 0)) * f.C / w.sum()
            out = rate
        elif key == "dissipation":
            out = f.dissipation()
        else:
            out = f.height()
        return np.ascontiguousarray(np.asarray(out, float).ravel())
