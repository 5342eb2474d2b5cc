"""Virtual ice tests (Orzech et al. §3a): tension, compression and in-plane three-point bending of a
bonded block, as a Python function and as ``siku lab``.

The block is a rectangle filled with bonded Voronoi elements of mean size ``D`` (element source
``lab_block``, a :class:`~siku_plugins.floes.Floe` with handles), on the equator at 0°E, long
axis east. Handles are groups of elements that the engine holds or moves at a steady velocity
(docs/explanation/physics.md §2: ``static`` and ``steady`` elements), bonded to the block like any
neighbour:

* **tension / compression**: the elements whose centres lie within ``1.5 D`` of the west end are
  static, those within ``1.5 D`` of the east end move east (tension) or west (compression) at
  ``v = strain_rate × gauge``; ``gauge`` is the distance between the two handles' mean centres.
  Macro stress ``sigma = F / (W h)`` with ``F`` the force the block exerts on the moving handle
  along the load (tension and compression positive), macro strain ``v t / gauge``;
* **flexure** (three-point bending in the plane): the whole block is free; two static pads
  (trapezoids with a flat face ``D/2`` wide touching the south edge at ``x = ±(L/2 - D)``, span
  ``S = L - 2D``) and a steady pad touching the middle of the north edge, moving south at
  ``v``. They share no edge with the beam, so they are not bonded: they push
  through the collision law along the beam's normal only (frictionless rollers, as a bending
  test needs; bonded supports would clamp the beam and carry an axial tie). Flexural stress
  ``sigma = 3 F S / (2 h W²)`` (the outer-fibre stress of an elastic beam of depth ``W``),
  strain ``6 W delta / S²`` with ``delta = v t``, the load point's travel: it includes the
  indentation of the three pads, so the flexural modulus is an apparent one, below the
  material's, while the strength (the peak force) is not affected.

The loading is quasi-static when the time to failure is long against the time a stress wave
takes to cross the block, ``L / c`` with ``c = sqrt(E / rho)``: by default the strain rate brings
the block to the bond's failure strain ``sigma_crit / E`` in ``30 L / c``. A run stops when the
stress has fallen below half its peak once bonds have broken (beyond a fifth of the bond's
failure strain), or at ``max_strain`` (default four times the bond's failure strain).

Results: the stress–strain curve, the macro modulus (least-squares slope between 10 % and 50 %
of the peak on the rising branch), the macro strength (the peak stress), the broken bonds by
mode, the stress before the first bond broke and the modes and orientations of the bonds broken
up to the peak (docs/explanation/lab.md §3.1); :func:`strength_table` repeats a test over a
list of bond strengths and fits the strength linearly (Orzech et al. Fig. 3).

What the tests report: strength against bond
strength (Orzech et al. 2018, Fig. 3), the stress–strain pictures, and the calibration of
``siku lab calibrate``.

**Calibration.** The macro strength of every test is proportional to the bond strength
(``sigma_crit = tau_crit``): the model is linear elastic up to brittle failure and the bond
strength is its only stress scale (docs/explanation/lab.md §3; the lines through four bond
strengths have R² = 1.0000). So one run of each test at a reference bond strength ``b0`` gives
its ratio ``r = S / b0``, and a wanted range ``[lo, hi]`` of the macro strength ``S`` is met by
the bond strengths ``[lo / r, hi / r]``. :func:`calibrate` intersects these intervals over the
tests given, takes their geometric middle (the bond strength furthest, in ratio, from both
ends) and runs every test again at it to show the macro strengths it gives. When the intervals
do not meet, no bond strength of this law and packing satisfies all ranges: the error names the
two tests whose ranges conflict and the bond strengths each needs.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from siku_core import hookimpl
from siku_core.errors import SikuError
from siku_core.geometry.polygon import area_centroid_moment
from siku_core.interfaces import ElementSpec
from siku_core.params import Param

from .floes import Floe, outline_polygon, to_lonlat

TESTS = ("tension", "compression", "flexure")


def block_layout(test: str, length: float, width: float, D: float, rng) -> tuple[
        list[np.ndarray], np.ndarray]:
    """Planar cells [m] of the block and each cell's role: 0 block, 1 fixed handle, 2 moving
    handle."""
    from .floes import fill_outline

    cells = fill_outline(outline_polygon("rectangle", length, width, 0.0, D), D, rng)
    cen = np.array([area_centroid_moment(c)[1] for c in cells])
    role = np.zeros(len(cells), dtype=np.int8)
    if test in ("tension", "compression"):
        role[cen[:, 0] < -0.5 * length + 1.5 * D] = 1
        role[cen[:, 0] > 0.5 * length - 1.5 * D] = 2
    else:
        # rollers: pads (trapezoids, flat face D/2 wide, base D, height D) face-on with the
        # beam's edges; they must share no edge with it (no bond: they push along the beam's
        # normal only), so a pad is moved along the beam until no boundary vertex of the beam
        # lies near its face's corners (joint detection matches corners within 10 %)
        h2 = 0.5 * width
        verts = np.concatenate(cells[: len(role)])

        def pad(x, y, down):
            for shift in (0.0, 0.2, -0.2, 0.4, -0.4, 0.6, -0.6):
                xc = x + shift * D
                face = np.array([[xc - 0.25 * D, y], [xc + 0.25 * D, y]])
                near = min(float(np.hypot(*(verts - f).T).min()) for f in face)
                if near > 0.1 * D:
                    break
            s_ = -1.0 if down else 1.0
            p = np.array([[xc - 0.25 * D, y], [xc + 0.25 * D, y],
                          [xc + 0.5 * D, y + s_ * D], [xc - 0.5 * D, y + s_ * D]])
            return p if down else p[::-1]

        xs = 0.5 * length - D
        cells = cells + [pad(-xs, -h2, True), pad(xs, -h2, True), pad(0.0, h2, False)]
        role = np.concatenate([role, np.array([1, 1, 2], dtype=np.int8)])
    return cells, role


class LabBlock(Floe):
    """A bonded rectangular block with handles for a virtual tension, compression or flexure
    test (``siku lab``)."""

    name = "lab_block"
    params = {
        "test": Param("tension", "", "which handles: tension, compression or flexure",
                      type=str, choices=TESTS),
        "length": Param(24.0, "m", "block length (east)", min=0),
        "width": Param(12.0, "m", "block width (north)", min=0),
        "element_size": Param(1.0, "m", "mean element size D", min=1e-3),
        "speed": Param(0.01, "m/s", "speed of the moving handle", min=0),
        "seed": Param(-1, "1", "random seed of the packing (-1: the scene's [run] seed)",
                      type=int, min=-1),
    }

    def build(self, scene, seed, where):
        p = self.p
        R = scene.cfg.planet.radius
        D = p["element_size"]
        cells, role = block_layout(p["test"], p["length"], p["width"], D,
                                   np.random.default_rng(seed))
        if not (role == 1).any() or not (role == 2).any():
            raise SikuError(f"{where}: the block is too small for its handles; make it at "
                            "least 6 elements long and 3 wide")
        v = p["speed"]
        vel = {"tension": (v, 0.0), "compression": (-v, 0.0), "flexure": (0.0, -v)}[p["test"]]
        out = []
        for k, c in enumerate(cells):
            ll = to_lonlat(c, 0.0, 0.0, R)
            if role[k] == 1:
                out.append(ElementSpec(ll, "static", label=f"element {k} (fixed handle)",
                                       floe=0))
            elif role[k] == 2:
                out.append(ElementSpec(ll, "steady", vel, label=f"element {k} (moving handle)",
                                       floe=0))
            else:
                out.append(ElementSpec(ll, "free", label=f"element {k}", floe=0))
        return out


@dataclass
class LabResult:
    """One virtual test: the curve and what it gives."""

    test: str
    sigma_crit: float  # bond normal strength [Pa]
    tau_crit: float  # bond shear strength [Pa]
    element_size: float  # [m]
    strain: np.ndarray  # macro strain [1]
    stress: np.ndarray  # macro stress [Pa]
    modulus: float  # macro elastic modulus [Pa]
    strength: float  # macro failure stress [Pa]
    strain_at_peak: float  # [1]
    broken: dict[str, int] = field(default_factory=dict)  # bonds broken by mode
    n_elements: int = 0
    n_bonds: int = 0
    steps: int = 0
    dt: float = 0.0
    affine_modulus: float = math.nan  # E_2D of the bond network under affine strain [Pa]
    affine_c11: float = math.nan  # C_1111 of the network (no lateral contraction) [Pa]
    first_break: float = math.nan  # the largest stress before the first bond broke [Pa]
    # the bonds broken up to the peak: their break modes (BREAK_* codes) and the squared
    # cosine of the angle between each one's normal and the block's long axis (east)
    peak_modes: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))
    peak_cos2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cos2_mean: float = math.nan  # the same squared cosine averaged over all the block's bonds

    @property
    def ratio(self) -> float:
        """Macro strength / bond strength."""
        return self.strength / self.sigma_crit


def _scene_text(test, length, width, D, speed, dt, duration, thickness, E, nu, density, law,
                params, seed, touching="contact", jointed="collide") -> str:
    from siku_core.testing.scenes import toml_value

    block = {"test": test, "length": length, "width": width, "element_size": D, "speed": speed}
    return f"""title = "virtual {test} test"
[time]
dt = {dt!r}
duration = {duration!r}
[materials.ice]
youngs_modulus = {E!r}
poisson_ratio = {nu!r}
density = {density!r}
[elements]
thickness = {thickness!r}
[[elements.source]]
name = "lab_block"
params = {toml_value(block)}
[contact]
law = "{law}"
params = {toml_value(params)}
touching = "{touching}"
jointed = "{jointed}"
[run]
seed = {seed}
progress = false
max_speed = 1e6
"""


def affine_tensor(sim, shear_ratio: float | None = None) -> np.ndarray:
    """The affine stiffness tensor ``C_ijkl`` [Pa] (east, north) of the bond network
    (:func:`affine_moduli`)."""
    cm = sim.context.contacts
    st = sim.state
    from siku_core.geometry.quat import centers

    c = centers(st.q) * sim.radius
    C = np.zeros((2, 2, 2, 2))
    nu = cm.poisson_ratio[cm.ji]
    free = st.flags == 0
    use = free[cm.ji] | free[cm.jj]
    for k in np.flatnonzero(use):
        i, j = cm.ji[k], cm.jj[k]
        d = c[j] - c[i]
        # east/north components near 0°E on the equator: x ~ y (global), y ~ z (global)
        dv = np.array([d[1], d[2]])
        L = float(np.hypot(*dv))
        n = dv / L
        t = np.array([-n[1], n[0]])
        kn = cm.joint_stiffness[k] * cm.width[k]  # k_n A = K w [N/m]
        ks = kn * (1.0 / (2.0 * (1.0 + nu[k])) if shear_ratio is None else shear_ratio)
        C += L * L * (kn * np.einsum("i,j,k,l->ijkl", n, n, n, n)
                      + ks * np.einsum("i,j,k,l->ijkl", t, n, t, n))
    area = float(st.area[free].sum() + 0.5 * st.area[~free].sum())
    C /= area * float(np.mean(st.thickness))
    return C


def affine_moduli(sim, shear_ratio: float | None = None) -> tuple[float, float]:
    """``(E_2D, C_1111)`` [Pa] of the bond network for a uniform strain in which every element
    translates with its centre (the affine, or Voigt, estimate of a lattice): the stiffness
    tensor ``C_ijkl = 1/(A h) sum_b L² (k_N n_i n_j n_k n_l + k_S t_i n_j t_k n_l)`` over the
    bonds (``L`` centre distance, ``n`` along it, ``t`` across it, ``k_N = K w`` the bond's normal
    stiffness [N/m], ``k_S = shear_ratio k_N``, by default ``k_N / (2 (1 + nu))`` as in
    ``bonded_particle`` and ``mohr_coulomb``; 1 for ``distributed_spring``), ``A`` the block's
    area (handles counted half), ``E_2D = (C11 C22 - C12²)/C22`` along the load (east, free to
    contract across) and ``C11`` with the contraction held (as near glued handles).

    For an isotropic network ``sum_b L k_N = 2 A h E`` (on a Voronoi packing the rhombi ``w L /
    2`` of the bonds tile the area), so ``C11 = E (3 + r)/4``, ``C12 = E (1 - r)/4`` and
    ``E_2D = E`` for ``r = 1``, ``0.818 E`` for ``r = 1/2.6``."""
    C = affine_tensor(sim, shear_ratio)
    c11, c22, c12 = C[0, 0, 0, 0], C[1, 1, 1, 1], C[0, 0, 1, 1]
    return (c11 * c22 - c12 * c12) / c22, c11


def affine_first_break(sim, sigma_crit: float, tau_crit: float, sign: float) -> float:
    """Macro stress [Pa] at which the first bond of the network reaches its strength under a
    uniform (affine) uniaxial stress along the long axis, tension ``sign = 1`` or compression
    ``-1``, free across (docs/explanation/lab.md §3.1): the strain ``eps = S sigma`` from the
    compliance ``S`` of the affine tensor (:func:`affine_moduli`, in Voigt form), and for each
    bond ``sigma_b = k_n L eps_nn``, ``tau_b = k_s L |eps_nt|`` (elements translate with their
    centres, so ``theta = 0``)."""
    from siku_core.geometry.quat import centers

    cm = sim.context.contacts
    st = sim.state
    c = centers(st.q) * sim.radius
    d = c[cm.jj] - c[cm.ji]
    dv = np.stack([d[:, 1], d[:, 2]], axis=1)
    L = np.hypot(dv[:, 0], dv[:, 1])
    n = dv / L[:, None]
    kn = cm.joint_stiffness / np.minimum(st.thickness[cm.ji], st.thickness[cm.jj])  # [Pa/m]
    ks = kn / (2.0 * (1.0 + cm.poisson_ratio[cm.ji]))
    C = affine_tensor(sim)
    C = 0.25 * (C + C.transpose(1, 0, 2, 3) + C.transpose(0, 1, 3, 2)
                + C.transpose(1, 0, 3, 2))  # acting on a symmetric strain
    # rows sigma_xx, sigma_yy, sigma_xy; unknowns eps_xx, eps_yy, eps_xy
    rows = ((0, 0), (1, 1), (0, 1))
    m = np.array([[C[i, j, 0, 0], C[i, j, 1, 1], 2.0 * C[i, j, 0, 1]] for i, j in rows])
    exx, eyy, exy = np.linalg.solve(m, [sign, 0.0, 0.0])
    e_nn = exx * n[:, 0] ** 2 + eyy * n[:, 1] ** 2 + 2 * exy * n[:, 0] * n[:, 1]
    e_nt = (eyy - exx) * n[:, 0] * n[:, 1] + exy * (n[:, 0] ** 2 - n[:, 1] ** 2)
    use = (st.flags[cm.ji] == 0) | (st.flags[cm.jj] == 0)
    load = np.maximum(kn * L * e_nn / sigma_crit, ks * L * np.abs(e_nt) / tau_crit)[use]
    return float(1.0 / load.max())


def virtual_test(test: str = "tension", sigma_crit: float = 1e6, tau_crit: float | None = None,
                 *, element_size: float = 1.0, length: float | None = None,
                 width: float | None = None, thickness: float = 1.0, E: float = 1e9,
                 nu: float = 0.3, density: float = 910.0, strain_rate: float | None = None,
                 law: str = "bonded_particle", params: dict | None = None, seed: int = 0,
                 max_strain: float | None = None, dt_share: float = 0.4,
                 touching: str = "contact", jointed: str = "collide") -> LabResult:
    """Run one virtual test of a bonded block (module docstring) and return its curve and
    numbers. ``sigma_crit``, ``tau_crit`` (default ``sigma_crit``) [Pa] are the bond strengths
    of law ``bonded_particle`` (another law gets ``params`` only); ``length``, ``width`` [m]
    default to 24 D × 12 D (tension, compression) or 30 D × 8 D (flexure); ``strain_rate``
    [1/s] defaults to reaching ``sigma_crit / E`` in 30 crossing times; ``dt`` is ``dt_share``
    of the critical step; ``touching``, ``jointed``: the ``contact`` options (``jointed =
    "exclude"``: the bonds alone hold the block together while intact)."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.state import STEADY

    if test not in TESTS:
        raise SikuError(f"unknown virtual test '{test}'; one of {', '.join(TESTS)}")
    D = element_size
    if length is None:
        length = (30.0 if test == "flexure" else 24.0) * D
    if width is None:
        width = (8.0 if test == "flexure" else 12.0) * D
    tau_crit = sigma_crit if tau_crit is None else tau_crit
    pars = dict(params or {})
    if law == "bonded_particle":
        pars.setdefault("sigma_crit", float(sigma_crit))
        pars.setdefault("tau_crit", float(tau_crit))
    c = math.sqrt(E / density)
    if strain_rate is None:
        strain_rate = (sigma_crit / E) / (30.0 * length / c)
    if max_strain is None:
        max_strain = 4.0 * sigma_crit / E
    span = length - 2 * D
    # a first build, for the geometry and the critical step
    probe = Simulation(scene_from_text(_scene_text(
        test, length, width, D, 0.0, 1e-9, 1e-9, thickness, E, nu, density, law, pars, seed),
        f"<virtual {test} test>"), out=False, progress=False)
    st = probe.state
    from siku_core.geometry.quat import centers

    cen = centers(st.q) * probe.radius
    moving = st.flags == STEADY
    fixed = (st.flags != 0) & ~moving
    if test == "flexure":
        gauge = span
        speed = strain_rate * span * span / (6.0 * width)
    else:
        gauge = float(cen[moving, 1].mean() - cen[fixed, 1].mean())
        speed = strain_rate * gauge
    dt = dt_share * probe.critical_dt
    if test == "flexure":
        to_peak = max_strain * span * span / (6.0 * width) / speed
    else:
        to_peak = max_strain * gauge / speed
    text = _scene_text(test, length, width, D, speed, dt, to_peak, thickness, E, nu, density,
                       law, pars, seed, touching, jointed)
    sim = Simulation(scene_from_text(text, f"<virtual {test} test>"), out=False, progress=False)
    return measure(sim, sigma_crit, tau_crit, E)


def block_params(sim) -> dict:
    """The parameters of the scene's ``lab_block`` source, defaults filled in."""
    for t in sim.scene.cfg.elements.source:
        if t.name == "lab_block":
            return {**{k: p.default for k, p in LabBlock.params.items()}, **t.params}
    raise SikuError(f"{sim.scene.label}: no [[elements.source]] with name = \"lab_block\"")


def measure(sim, sigma_crit: float = math.nan, tau_crit: float = math.nan,
            E: float | None = None) -> LabResult:
    """Run a ``lab_block`` scene to failure (or to its end) and measure its curve (module
    docstring). ``sigma_crit`` (default: the law's ``sigma_crit`` if it has one) scales the
    stop criterion; ``E`` [Pa] defaults to the block's material."""
    from siku_core.contact_law import BREAK_MODES
    from siku_core.geometry.quat import centers
    from siku_core.state import STEADY

    bp = block_params(sim)
    test, width, D, speed = bp["test"], bp["width"], bp["element_size"], bp["speed"]
    st = sim.state
    thickness = float(np.mean(st.thickness))
    cm = sim.context.contacts
    if E is None:
        E = float(np.mean(cm.youngs_modulus))
    if not sigma_crit == sigma_crit:  # NaN: the law's strength, if it declares one
        sigma_crit = float(cm.law_params.get("sigma_crit", 0.0)) or 1e6
    moving = st.flags == STEADY
    fixed = (st.flags != 0) & ~moving
    span = bp["length"] - 2 * D
    cen = centers(st.q) * sim.radius
    gauge = span if test == "flexure" else float(cen[moving, 1].mean() - cen[fixed, 1].mean())
    e_aff, c11 = affine_moduli(sim)
    axis = 0 if test != "flexure" else 1
    sign = {"tension": -1.0, "compression": 1.0, "flexure": 1.0}[test]
    strains, stresses = [0.0], [0.0]
    peak = 0.0
    first_break = t_peak = math.nan
    for _ in range(sim.n_steps - sim.step_index):
        sim.step()
        # forces of the last evaluation: the state at the start of this step
        t = sim.time - sim.dt
        f = sign * float(st.F[moving, axis].sum())
        if test == "flexure":
            s = 3.0 * f * span / (2.0 * thickness * width * width)
            e = 6.0 * width * speed * t / (span * span)
        else:
            s = f / (width * thickness)
            e = speed * t / gauge
        strains.append(e)
        stresses.append(s)
        if first_break != first_break and cm.n_intact < cm.n_joints:
            first_break = peak  # the breaking evaluation's force already lacks the bond
        if s > peak:
            peak, t_peak = s, t
        # failed: the stress fell to half its peak once bonds broke (early stress waves make
        # the curve wiggle, so a drop before any break or at small strain is not failure)
        if (peak > 0 and s < 0.5 * peak and e > 0.2 * sigma_crit / E
                and cm.n_intact < cm.n_joints):
            break
    strain = np.array(strains)
    stress = np.array(stresses)
    ip = int(np.argmax(stress))
    # the rising branch: up to where the stress first reaches half the peak
    top = int(np.argmax(stress >= 0.5 * stress[ip])) + 1
    rise = stress[:top] >= 0.1 * stress[ip]
    if rise.sum() >= 3:
        x, y = strain[:top][rise], stress[:top][rise]
        modulus = float(np.polyfit(x, y, 1)[0])
    else:
        modulus = math.nan
    codes = np.bincount(cm.break_mode.astype(np.int64), minlength=len(BREAK_MODES))
    broken = {name: int(codes[c]) for c, name in BREAK_MODES.items() if c and codes[c]}
    to_peak = np.flatnonzero(cm.break_time <= t_peak)
    _, _, _, edge_north = cm.joint_lines()  # the joint's normal is its edge turned by 90°
    return LabResult(test, float(sigma_crit), float(tau_crit), D, strain, stress, modulus,
                     float(stress[ip]), float(strain[ip]), broken, st.n, cm.n_joints,
                     sim.step_index, sim.dt, e_aff, c11, float(first_break),
                     cm.break_mode[to_peak].copy(), edge_north[to_peak] ** 2,
                     float(np.mean(edge_north[(st.flags[cm.ji] == 0) | (st.flags[cm.jj] == 0)]
                                   ** 2)))


def block_extent(test: str, element_size: float, length: float | None = None,
                 width: float | None = None) -> tuple[float, float]:
    """The block of ``siku lab``: ``length × width`` [m] (default 24 × 12, flexure 30 × 8),
    whatever the element size (a smaller ``element_size`` refines it); at least 4 elements
    across, or a one-line error."""
    length = length or (30.0 if test == "flexure" else 24.0)
    width = width or (8.0 if test == "flexure" else 12.0)
    if min(length, width) < 4 * element_size:
        raise SikuError(f"--element-size {element_size} m: the {test} block ({length:g} m × "
                        f"{width:g} m) needs at least 4 elements across")
    return length, width


# ------------------------------------------------------------------ what the tests report
@dataclass
class StrengthTable:
    """Macro strength against bond strength for one test (Orzech et al. Fig. 3)."""

    test: str
    results: list[LabResult]
    slope: float  # macro strength per bond strength [1]
    intercept: float  # [Pa]
    r2: float  # coefficient of determination of the linear fit

    def rows(self) -> list[str]:
        out = [f"{self.test}: bond strength [MPa] | macro strength [MPa] | ratio | modulus "
               "[GPa] | bonds broken (tension/shear) | elements"]
        for r in self.results:
            out.append(f"  {r.sigma_crit / 1e6:8.3f} | {r.strength / 1e6:8.4f} | {r.ratio:6.3f} "
                       f"| {r.modulus / 1e9:6.3f} | {r.broken.get('tension', 0)}/"
                       f"{r.broken.get('shear', 0)} | {r.n_elements}")
        out.append(f"  linear fit: macro = {self.slope:.4f} × bond + {self.intercept / 1e6:.4f} "
                   f"MPa, R² = {self.r2:.4f}")
        return out


def strength_table(test: str, strengths: list[float], progress: bool = False,
                   **kwargs: Any) -> StrengthTable:
    """:func:`virtual_test` at each bond strength [Pa] (``sigma_crit = tau_crit``), and the
    least-squares line through the macro strengths."""
    results = []
    for s in strengths:
        if progress:
            print(f"siku lab: {test} at bond strength {s / 1e6:g} MPa ...", file=sys.stderr)
        results.append(virtual_test(test, s, **kwargs))
    x = np.array([r.sigma_crit for r in results])
    y = np.array([r.strength for r in results])
    if len(x) >= 2:
        slope, intercept = np.polyfit(x, y, 1)
        pred = slope * x + intercept
        ss = float(((y - y.mean()) ** 2).sum())
        r2 = 1.0 - float(((y - pred) ** 2).sum()) / ss if ss > 0 else 1.0
    else:
        slope, intercept, r2 = y[0] / x[0], 0.0, math.nan
    return StrengthTable(test, results, float(slope), float(intercept), r2)


@dataclass
class PackingSpread:
    """One test at one bond strength over several packings (seeds): the ratio macro / bond
    strength [1] of each and their spread."""

    test: str
    sigma_crit: float  # bond strength [Pa]
    seeds: list[int]
    results: list[LabResult]

    @property
    def ratios(self) -> np.ndarray:
        return np.array([r.ratio for r in self.results])

    @property
    def mean(self) -> float:
        return float(self.ratios.mean())

    @property
    def sd(self) -> float:
        """Sample standard deviation of the ratios (``ddof = 1``)."""
        return float(self.ratios.std(ddof=1)) if len(self.results) > 1 else math.nan

    def rows(self) -> list[str]:
        r = self.ratios
        return [f"{self.test} at bond strength {self.sigma_crit / 1e6:g} MPa over "
                f"{len(r)} packings (seeds {', '.join(map(str, self.seeds))}): ratios "
                + " ".join(f"{x:.3f}" for x in r),
                f"  mean {self.mean:.3f}, standard deviation {self.sd:.3f}, range "
                f"{r.min():.3f}–{r.max():.3f}"]


def packing_spread(test: str, seeds, sigma_crit: float = 1e6, progress: bool = False,
                   **kwargs: Any) -> PackingSpread:
    """:func:`virtual_test` of ``test`` at ``sigma_crit`` [Pa] on the packing of each seed of
    ``seeds``: the disorder's share of a ratio (``siku lab --packings N``)."""
    seeds = [int(x) for x in seeds]
    results = []
    for seed in seeds:
        if progress:
            print(f"siku lab: {test} at bond strength {sigma_crit / 1e6:g} MPa, packing "
                  f"{seed} ...", file=sys.stderr)
        results.append(virtual_test(test, sigma_crit, seed=seed, **kwargs))
    return PackingSpread(test, sigma_crit, seeds, results)


def plot_curves(tables: list[StrengthTable], path: Path) -> Path:
    """Stress–strain curves of every run (one panel per test) and the strength lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tables) + 1, figsize=(4.2 * (len(tables) + 1), 3.6),
                             constrained_layout=True)
    for ax, tab in zip(axes, tables):
        for r in tab.results:
            ax.plot(r.strain * 1e3, r.stress / 1e6, label=f"bond {r.sigma_crit / 1e6:g} MPa")
        ax.set_xlabel("macro strain [10⁻³]")
        ax.set_ylabel("macro stress [MPa]")
        ax.set_title(f"virtual {tab.test} test")
        ax.legend(fontsize=7)
    ax = axes[-1]
    for tab in tables:
        x = np.array([r.sigma_crit for r in tab.results]) / 1e6
        y = np.array([r.strength for r in tab.results]) / 1e6
        ax.plot(x, y, "o", label=f"{tab.test} (slope {tab.slope:.2f}, R² {tab.r2:.3f})")
        ax.plot(x, tab.slope * x + tab.intercept / 1e6, "-", lw=0.8)
    lim = max(r.sigma_crit for t in tables for r in t.results) / 1e6
    ax.plot([0, lim], [0, lim], "k:", lw=0.8, label="macro = bond")
    ax.set_xlabel("bond strength [MPa]")
    ax.set_ylabel("macro strength [MPa]")
    ax.set_title("strength against bond strength")
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path



def feasible_bonds(ranges: dict[str, tuple[float, float]],
                   ratios: dict[str, float]) -> tuple[float, float, str, str]:
    """The bond strengths [Pa] that put every test's macro strength ``ratio × bond`` in its
    range ``[lo, hi]`` [Pa]: ``(low, high, test_low, test_high)``, the tests that set the two
    ends (``low > high``: none does)."""
    lows = {t: ranges[t][0] / ratios[t] for t in ranges}
    highs = {t: ranges[t][1] / ratios[t] for t in ranges}
    t_lo = max(lows, key=lows.get)
    t_hi = min(highs, key=highs.get)
    return lows[t_lo], highs[t_hi], t_lo, t_hi


@dataclass
class Calibration:
    """The bond strength ``bond`` [Pa] that puts the macro strengths in ``ranges`` [Pa]."""

    ranges: dict[str, tuple[float, float]]
    reference: float  # bond strength of the first runs [Pa]
    ratios: dict[str, float]  # macro / bond at the reference [1]
    low: float  # the feasible bond strengths [Pa]
    high: float
    bond: float  # their geometric middle [Pa]
    check: dict[str, float]  # macro strength of each test run at ``bond`` [Pa]

    def rows(self) -> list[str]:
        out = [f"calibration: test | wanted macro strength [MPa] | macro / bond at "
               f"{self.reference / 1e6:g} MPa | bond strengths that meet it [MPa]"]
        for t, (lo, hi) in self.ranges.items():
            r = self.ratios[t]
            out.append(f"  {t:<11} | {lo / 1e6:.4g} .. {hi / 1e6:.4g} | {r:.4f} | "
                       f"{lo / r / 1e6:.4g} .. {hi / r / 1e6:.4g}")
        out.append(f"  all ranges: bond strength {self.low / 1e6:.4g} .. {self.high / 1e6:.4g} "
                   f"MPa; chosen (geometric middle): {self.bond / 1e6:.4g} MPa")
        for t, s in self.check.items():
            out.append(f"  check at {self.bond / 1e6:.4g} MPa: {t} macro strength "
                       f"{s / 1e6:.4g} MPa")
        return out


def calibrate(ranges: dict[str, tuple[float, float]], reference: float = 1e6,
              verify: bool = True, progress: bool = False,
              sizes: dict[str, tuple[float, float]] | None = None,
              **kwargs: Any) -> Calibration:
    """The bond strength (``sigma_crit = tau_crit``) [Pa] that puts each test's macro strength
    in its range ``ranges[test] = (lo, hi)`` [Pa] (module docstring). ``sizes[test]``: the
    block ``(length, width)`` [m]; ``kwargs`` go to :func:`~siku_plugins.lab.virtual_test`
    (element size, seed, ``jointed``, ...). ``verify``: run every test again at the result."""
    if not ranges:
        raise SikuError("calibrate: give a range for at least one test "
                        f"({', '.join(TESTS)})")
    for t, (lo, hi) in ranges.items():
        if t not in TESTS:
            raise SikuError(f"calibrate: unknown test '{t}'; one of {', '.join(TESTS)}")
        if not 0 < lo <= hi:
            raise SikuError(f"--{t} {lo / 1e6:g}:{hi / 1e6:g}: give 0 < low <= high [MPa]")
    sizes = sizes or {}

    def run(t: str, bond: float) -> LabResult:
        if progress:
            print(f"siku lab calibrate: {t} at bond strength {bond / 1e6:.4g} MPa ...",
                  file=sys.stderr)
        length, width = sizes.get(t, (None, None))
        return virtual_test(t, bond, length=length, width=width, **kwargs)

    ratios = {t: run(t, reference).strength / reference for t in ranges}
    low, high, t_lo, t_hi = feasible_bonds(ranges, ratios)
    if low > high:
        raise SikuError(
            f"no bond strength meets every range: {t_lo} needs at least {low / 1e6:.4g} MPa "
            f"(macro / bond = {ratios[t_lo]:.3f}) and {t_hi} at most {high / 1e6:.4g} MPa "
            f"(macro / bond = {ratios[t_hi]:.3f}); widen one of the two ranges")
    bond = math.sqrt(low * high)
    check = {t: run(t, bond).strength for t in ranges} if verify else {}
    return Calibration(dict(ranges), reference, ratios, low, high, bond, check)


def parse_range(text: str, option: str) -> tuple[float, float]:
    """``"LO:HI"`` [MPa] -> ``(lo, hi)`` [Pa]; a one-line error otherwise."""
    try:
        lo, hi = (float(x) * 1e6 for x in text.split(":"))
    except ValueError:
        raise SikuError(f"{option} {text!r}: give the wanted macro strength as LOW:HIGH in MPa, "
                        "e.g. 0.3:0.8") from None
    if not (0 < lo <= hi < 1e6 * 1e6) or not (math.isfinite(lo) and math.isfinite(hi)):
        raise SikuError(f"{option} {text!r}: give 0 < LOW <= HIGH in MPa")
    return lo, hi


def add_arguments(p) -> None:
    """The options of ``siku lab calibrate``."""
    for t in TESTS:
        p.add_argument(f"--{t}", metavar="LO:HI",
                       help=f"calibrate: wanted {t} macro strength [MPa], e.g. 0.3:0.8")
    p.add_argument("--reference", type=float, default=1.0,
                   help="calibrate: bond strength of the first runs [MPa] (default 1)")


def cmd_calibrate(args) -> int:
    """``siku lab calibrate --tension LO:HI --compression LO:HI --flexure LO:HI``."""
    ranges = {t: parse_range(getattr(args, t), f"--{t}") for t in TESTS
              if getattr(args, t, None)}
    if not ranges:
        raise SikuError("siku lab calibrate: give at least one of --tension, --compression, "
                        "--flexure as LOW:HIGH in MPa")
    if not 0 < args.reference < 1e6:
        raise SikuError(f"--reference {args.reference}: a bond strength in MPa, above 0")
    sizes = {t: block_extent(t, args.element_size, args.length, args.width) for t in ranges}
    cal = calibrate(ranges, args.reference * 1e6, progress=True, sizes=sizes,
                    element_size=args.element_size, seed=args.seed, jointed=args.jointed)
    print("\n".join(cal.rows()))
    return 0


def _cmd_lab(args) -> int:
    try:
        strengths = [float(s) * 1e6 for s in args.strength.split(",") if s.strip()]
    except ValueError:
        raise SikuError(f"--strength {args.strength!r}: give bond strengths in MPa separated "
                        "by commas, e.g. 0.1,0.5,1,2") from None
    if not strengths or any(not (0 < s < 1e12) for s in strengths):
        raise SikuError(f"--strength {args.strength!r}: strengths must be positive MPa")
    if not 1 <= args.packings <= 1000:
        raise SikuError(f"--packings {args.packings}: give 1 to 1000 packings")
    if not 0 < args.element_size < 1e5:
        raise SikuError(f"--element-size {args.element_size}: must be in (0, 1e5) m")
    if args.test == "calibrate":
        return cmd_calibrate(args)
    tests = TESTS if args.test == "all" else (args.test,)
    if args.packings > 1:    # the ratios' spread over packings; no curves
        for test in tests:
            length, width = block_extent(test, args.element_size, args.length, args.width)
            for s in strengths:
                sp = packing_spread(test, range(args.seed, args.seed + args.packings), s,
                                    progress=True, element_size=args.element_size,
                                    length=length, width=width, jointed=args.jointed)
                print("\n".join(sp.rows()))
        return 0
    tables = []
    for test in tests:
        length, width = block_extent(test, args.element_size, args.length, args.width)
        tab = strength_table(test, strengths, progress=True, element_size=args.element_size,
                             length=length, width=width, seed=args.seed, jointed=args.jointed)
        tables.append(tab)
        print("\n".join(tab.rows()))
        if test == "flexure":     # and out of the plane: siku_plugins.lab_bending
            from .lab_bending import vertical_flexure

            h = min(1.0, args.element_size)  # finer: thinner (else they capsize, lab.md §2.1)
            for s in strengths:
                print("\n".join(vertical_flexure(s, element_size=args.element_size,
                                                  length=args.length or 30.0,
                                                  thickness=h).rows()))
    out = Path(args.out_dir or ".") / f"siku_lab_{args.test}.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    print(f"picture: {plot_curves(tables, out)}", file=sys.stderr)
    return 0


@hookimpl
def siku_register_commands(subparsers):
    p = subparsers.add_parser(
        "lab", help="virtual ice tests of a bonded block: tension, compression, flexure")
    p.add_argument("test", choices=(*TESTS, "all", "calibrate"),
                   help="which test (all: the three; calibrate: the bond strength that puts "
                        "the three macro strengths in the ranges given)")
    p.add_argument("--strength", default="0.1,0.5,1,2",
                   help="bond strengths sigma_crit = tau_crit [MPa], comma-separated")
    p.add_argument("--element-size", type=float, default=1.0, help="mean element size D [m]; "
                   "the block keeps its size in metres, so a smaller D refines it")
    p.add_argument("--length", type=float, help="block length [m] (default 24; flexure 30)")
    p.add_argument("--width", type=float, help="block width [m] (default 12; flexure 8)")
    p.add_argument("--seed", type=int, default=0, help="seed of the packing")
    p.add_argument("--packings", type=int, default=1, help="run each test on this many "
                   "packings (seeds --seed, --seed + 1, ...) and print the ratios' mean and "
                   "spread instead of the curves (default 1)")
    p.add_argument("--jointed", choices=("collide", "exclude"), default="collide",
                   help="bonded neighbours also collide (collide, the default) or only their "
                        "bond acts until it breaks (exclude): contact.jointed")
    p.add_argument("--out-dir", help="where the stress-strain picture goes (default: here)")
    add_arguments(p)
    p.set_defaults(func=_cmd_lab)


@hookimpl
def siku_register_element_sources():
    return [LabBlock]
