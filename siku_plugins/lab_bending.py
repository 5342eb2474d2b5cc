"""The vertical three-point bending test of a bonded beam (the flexural test of Orzech et al.
(the coupled NHWAVE–LIGGGHTS wave–ice model), §3a), with the bonds that bend of the
``floating`` process (:mod:`siku_plugins.floating.bending`), beside the in-plane tests of
:mod:`siku_plugins.lab`.

The beam is a ``nx × ny`` grid of square elements of side ``a`` (``nx`` odd), jointed, ``h``
thick: span ``L = (nx - 1) a`` between the centres of the two end columns, width ``b = ny a``.
In air (no buoyancy), the end columns rest on rollers (heave 0, slopes free), and a force
``F`` pushes the middle column down, shared equally by its ``ny`` elements. The static
deflection ``u`` solves ``K u = F`` with ``K`` the beams' stiffness of the intact joints (least
squares of minimum norm: across a beam one element wide no joint holds the slope).

Beam theory (Euler–Bernoulli, simply supported, central load) gives the deflection under the
load ``delta = F L³ / (48 E_f I)``, ``I = b h³ / 12``, and the outer-fibre stress ``sigma = 3 F
L / (2 b h²)`` under the load. The macro flexural modulus and strength of the test are those
two formulas solved for ``E_f`` and ``sigma`` at the measured deflection and at the force
``F_b`` at which the first joint reaches the bonds' ``flexural_strength`` (it breaks there).

What the bonds' law predicts (the bounds ``tests/test_lab_bending.py`` checks):

* each joint is a cubic Hermite beam of rigidity ``D w``, ``D = E h³ / (12 (1 - ν²))``: exact
  for an Euler–Bernoulli beam loaded at its nodes, so ``E_f = E / (1 - ν²)`` (the plate
  modulus) to rounding;
* the joints nearest the load lie half an element from it, where the moment is ``F (L - a) /
  4``, so the first joints break when ``sigma`` reaches ``sigma_crit L / (L - a)``: the macro
  strength lies between ``sigma_crit`` and ``sigma_crit L / (L - a)`` (equal to the upper
  bound for these linear beams), and the joints that break are the ``2 ny`` beside the load.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

M_DEG = 1.0 / 111194.92664455873   # degrees of latitude per metre on siku's sphere


@dataclass
class VerticalFlexure:
    """One vertical three-point bending test (module docstring)."""

    sigma_crit: float        # the bonds' flexural strength [Pa]
    E: float                 # the material's Young's modulus [Pa]
    nu: float
    span: float              # L [m]
    width: float             # b [m]
    thickness: float         # h [m]
    element_size: float      # a [m]
    modulus: float           # E_f [Pa]
    strength: float          # macro flexural strength [Pa]
    broken_at: np.ndarray    # distance of the first broken joints from the load [m]

    @property
    def modulus_bounds(self) -> tuple[float, float]:
        e = self.E / (1.0 - self.nu**2)
        return e, e

    @property
    def strength_bounds(self) -> tuple[float, float]:
        return self.sigma_crit, self.sigma_crit * self.span / (self.span - self.element_size)

    def rows(self) -> list[str]:
        lo, hi = self.strength_bounds
        return [
            f"vertical three-point bending (bonds that bend): span {self.span:g} m, width "
            f"{self.width:g} m, {self.thickness:g} m thick, elements {self.element_size:g} m",
            f"  bond strength {self.sigma_crit / 1e6:.3f} MPa | macro strength "
            f"{self.strength / 1e6:.4f} MPa (beam theory {lo / 1e6:.4f}–{hi / 1e6:.4f}) | "
            f"modulus {self.modulus / 1e9:.4f} GPa (E / (1 − ν²) = "
            f"{self.modulus_bounds[0] / 1e9:.4f}) | first joints broken "
            f"{len(self.broken_at)}, {np.max(self.broken_at):g} m from the load"]


def beam_scene(nx: int, ny: int, a: float, h: float, E: float, nu: float,
               strength: float) -> str:
    """The scene of the bonded beam (module docstring), with the ``floating`` process's bonds
    that bend."""
    lon, lat = nx * a * M_DEG / 2, ny * a * M_DEG / 2
    return f"""
title = "vertical three-point bending"
[time]
duration = 1e-3
dt = 1e-3
[materials.ice]
youngs_modulus = {E}
poisson_ratio = {nu}
[elements]
thickness = {h}
[[elements.pack]]
lon = [{-lon}, {lon}]
lat = [{-lat}, {lat}]
nx = {nx}
ny = {ny}
[contact]
law = "distributed_spring"
[run]
allow_unstable_dt = true
[[process]]
name = "floating"
params = {{ bending = true, flexural_strength = {strength} }}
"""


def vertical_flexure(sigma_crit: float = 1e6, *, element_size: float = 1.0,
                     length: float = 30.0, width: float = 2.0, thickness: float = 1.0,
                     E: float = 1e9, nu: float = 0.3) -> VerticalFlexure:
    """Run the vertical three-point bending test (module docstring) of a beam about
    ``length`` × ``width`` [m] (rounded to an odd number of elements along, at least 3, and a
    whole number across) at the bonds' flexural strength ``sigma_crit`` [Pa]."""
    from scipy.sparse import csr_matrix

    from siku_core.errors import SikuError
    from siku_core.geometry.quat import centers
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    a = float(element_size)
    nx = max(3, int(round(length / a)))
    nx += 1 - nx % 2
    ny = max(1, int(round(width / a)))
    with warnings.catch_warnings():     # never stepped: the scene's dt does not matter
        warnings.simplefilter("ignore")
        sim = Simulation(scene_from_text(beam_scene(nx, ny, a, thickness, E, nu, sigma_crit),
                                         "<vertical three-point bending>"),
                         out=False, progress=False)
    proc = next(p for p in sim.processes if p.name == "floating")
    bm = proc.beams
    n = sim.state.n
    xy = centers(sim.state.q) * sim.radius
    x = np.round((xy[:, 1] - xy[:, 1].mean()) / a).astype(int)   # column, 0 at the load
    if sorted(set(x.tolist())) != list(range(-(nx // 2), nx // 2 + 1)):
        raise SikuError("vertical three-point bending: the beam's elements are not in columns")
    K = csr_matrix((bm.data, bm.indices, bm.indptr), shape=(3 * n, 3 * n))
    F = np.zeros(3 * n)
    load = 1.0                                      # [N]; linear, scaled to the break below
    F[3 * np.flatnonzero(x == 0)] = -load / ny
    keep = np.ones(3 * n, dtype=bool)
    keep[3 * np.flatnonzero(np.abs(x) == nx // 2)] = False     # rollers: heave 0 at the ends
    u = np.zeros(3 * n)
    # least squares, minimum norm: a slope no beam holds (across a 1-wide beam) stays 0
    Kk = K.tocsr()[keep][:, keep].toarray()
    u[keep] = np.linalg.lstsq(Kk, F[keep], rcond=1e-12)[0]
    span, b, h = (nx - 1) * a, ny * a, thickness
    delta = -float(np.mean(u[3 * np.flatnonzero(x == 0)]))
    modulus = load * span**3 / (48.0 * delta * b * h**3 / 12.0)
    sig = np.abs(bm.stress(u))
    f_break = load * sigma_crit / float(np.max(sig))
    # the first joints to break: load the beam just past f_break (1e-6: the joints whose
    # stress equals the largest to rounding) and let the law break them
    cm = sim.context.contacts
    bm.break_overstressed(proc, u * (f_break / load) * (1 + 1e-6), sigma_crit, 0.0)
    gone = np.flatnonzero(~cm.intact)
    dist = np.abs(0.5 * (x[cm.ji[gone]] + x[cm.jj[gone]])) * a
    return VerticalFlexure(sigma_crit, E, nu, span, b, h, a, modulus,
                           3.0 * f_break * span / (2.0 * b * h**2), dist)
