"""Stability at the extremes of the parameter ranges (docs/explanation/physics.md §5).

Ranges: E 0.25–4 GPa, thickness h 0.05–10 m, cells 10 m–100 km, wind 0–50 m/s.

**Which corners.** A joint between square cells of side ``a`` has stiffness ``K w ≈ h E`` (eq. 9
with lever arms ``a/2`` and joint length ``a``) and the cell has mass ``rho h a²``, so
``omega² ∝ E / (rho a²)``: the thickness cancels and the critical step ``dt_c = 2/omega`` runs
from 1.9 ms (4 GPa, 10 m) to 72 s (0.25 GPa, 100 km). The corners are therefore the stiffest
smallest cells (shortest step; a 10 m cell spans 1.6e-6 rad of the sphere, round-off of
positions ``R eps ≈ 1e-9 m`` against displacements of 3e-4 m) and the softest largest (longest
step, cells 1.6 % of ``R``, curvature largest). Thickness enters through the forcing (wind
acceleration ``tau / (rho h)`` is largest on thin ice, and for 5 cm ice of 100 km the water-drag
limit ``rho h / (rho_w C_w |dU|) = 9.9 s`` sets the step, not the contacts), and through mixed
packs, the light side of a stiff joint: 5 cm cells jointed to 10 m cells. Each corner has thin
or thick ice, calm or a 50 m/s gale (air and water drag, eqs. 19–20).

**Bounds (theory).** The packs have no damping and unbreakable joints, and start unstrained
with random velocities and spins (kinetic energy ``E0``). A linear system integrated by
symplectic Euler (siku2) keeps the modified energy of velocity Verlet, so the energy with the
velocity synchronised to the positions (:func:`total_energy`) stays in ``[E0, B E0]``,
``B = 1 / (1 - (omega dt / 2)²)`` (:func:`modified_energy_bound`), with ``omega`` the largest
frequency of the pack linearised by finite differences of the engine's forces
(:func:`linearised_frequencies`); geometric nonlinearity (strains ≤ 1e-4) is allowed ``EPS``.
The estimate must bound that frequency (``omega_lin <= omega_est = 2/dt_c``). With wind the
pack tends to the free-drift speed ``U_t = U sqrt(rho_a C_a / (rho_w C_w)) = 1.06 m/s`` (water
drag damps relative motion), so no element exceeds ``U_t + sqrt(2 B E0 / m_min)``.

Measured (this file): ``omega_lin / omega_est`` = 0.65–0.73 (spring), 0.45–0.51
(Mohr–Coulomb; 0.51 the mixed corner), so the true critical step ``2/omega_lin`` is 1.4–1.5
``dt_c`` and 2.0–2.2 ``dt_c``; just below the accepted step the energy stays within ``[1.003,
1.033] E0`` (``B`` = 1.05–1.14), at 1.05 ``dt_c`` within ``[1.018, 1.18] E0``; beyond
``2/omega_lin`` the speed guard stops the run within 15–30 steps.

**Gap.** The packs leave 1 % open water between cells (joints are still found): then no
collision acts and the system is conservative. Touching packs gain energy without damping at a
rate that does not depend on ``dt``: the collision force ``K A n`` at the overlap centroid is
not a potential force (:func:`test_collision_force_does_no_work_around_a_closed_loop`).

**Mixed joints.** ``mohr_coulomb`` joints between different ice are the series combination of
the two sides, as eq. 9 and the estimate (``mohr_coulomb_evaluator``); with the pair's mean
``h`` and ``E``, as before, 5 cm ice jointed to 10 m ice was 50× stiffer than estimated,
``omega_lin / omega_est`` = 2.47, and a run at the accepted step diverged within 10 steps;
now 0.51.

Known engine problem, marked ``xfail(strict=True)``: the collision force is not conservative
(above).
"""
from __future__ import annotations

import contextlib
import functools
import math
import re
import warnings
from typing import NamedTuple

import numba
import numpy as np
import pytest

from siku_core.contact.contact_frames import frame_point
from siku_core.errors import NonFiniteError, StabilityError
from siku_core.geometry.quat import centers, qmatrix
from siku_core.contact.joint_metrics import joint_strain_opening
from siku_core.scene.packs import rect_pack
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import (
    contact_forces,
    contact_scene,
    rotate_about,
    square_pack,
)
from siku_core.testing.scenes import EARTH_RADIUS as R

#: laws without damping, joints that never break
LAWS = {
    "distributed_spring": {"tensile_strain": 1.0, "joint_damping_ratio": 0.0,
                           "damping_ratio": 0.0},
    "mohr_coulomb": {"sigma_c": 1e12, "joint_damping_ratio": 0.0, "damping_ratio": 0.0},
    "collision": {"damping_ratio": 0.0},
}
JOINT_LAWS = ("distributed_spring", "mohr_coulomb")
SAFETY = 0.5  # default [run] dt_safety
BELOW = 0.95 * SAFETY  # share of dt_c just below the largest accepted step
STEPS = 10_000
GAP = 0.01  # open share of each cell's width
EPS = 1e-3  # geometric nonlinearity, relative (strains here <= 1e-4)
AIR = (1.3, 0.0016)  # rho_a [kg/m³], C_a: air_drag defaults (eq. 21)
WATER = (1026.0, 0.0045)  # rho_w [kg/m³], C_w: water_drag defaults
RHO_ICE = 910.0


class Corner(NamedTuple):
    E: float  # Young's modulus [Pa]
    h: float  # thickness [m]
    size: float  # cell side [m]
    wind: float  # eastward wind [m/s]


CORNERS = {
    "stiff-small-thin": Corner(4e9, 0.05, 10.0, 0.0),
    "stiff-small-thick-gale": Corner(4e9, 10.0, 10.0, 50.0),
    "soft-large-thick": Corner(0.25e9, 10.0, 100e3, 0.0),
    "soft-large-thin-gale": Corner(0.25e9, 0.05, 100e3, 50.0),
    "stiff-small-mixed": Corner(4e9, 0.05, 10.0, 0.0),  # 5 cm cells jointed to 10 m cells
}
CALM = [k for k, c in CORNERS.items() if c.wind == 0.0]


def cases(laws, corners):
    """``(law, corner)`` parameters."""
    return [pytest.param(law, c, id=f"{law}-{c}") for law in laws for c in corners]


# ---------------------------------------------------------------------------------------------
# scenes


def corner_scene(law: str, corner: str, dt: float = 1e-9, steps: int = 10, allow: bool = False):
    """A 3 × 3 jittered pack of ``corner`` at 70°N (``collision``: the side columns static);
    ``stiff-small-mixed``: 2 columns of 5 cm ice west of 2 columns of 10 m ice, 3 rows."""
    c = CORNERS[corner]
    forcing = []
    if c.wind:
        forcing = [{"source": "air_drag", "field": {"type": "uniform", "params": {"u": c.wind}}},
                   {"source": "water_drag"}]
    if corner == "stiff-small-mixed":
        thin = square_pack(10.0, 70.0, 2, 3, c.size, gap=GAP, thickness=c.h)
        lon0, lon1 = thin["lon"]
        packs = [thin, dict(thin, lon=[lon1, 2 * lon1 - lon0], thickness=10.0)]
    else:
        walls = {"left": "static", "right": "static"} if law == "collision" else {}
        packs = [square_pack(10.0, 70.0, 3, 3, c.size, gap=GAP, jitter=0.2, seed=3, **walls)]
    return contact_scene(law, LAWS[law], packs=packs, dt=dt, steps=steps, thickness=c.h,
                         youngs_modulus=c.E, forcing=forcing, run={"allow_unstable_dt": allow})


def build(*args, **kwargs) -> Simulation:
    return Simulation(corner_scene(*args, **kwargs), out=False, progress=False)


def kick(sim: Simulation, v0: float = 0.1, seed: int = 1) -> float:
    """Random velocities (``v0`` [m/s] rms per component) and spins (``v0 / sqrt(area)``
    [rad/s] rms) of the free elements; returns their kinetic energy [J]."""
    st = sim.state
    rng = np.random.default_rng(seed)
    free = np.flatnonzero(st.flags == 0)
    st.V[free] = rng.normal(0.0, v0, (len(free), 2))
    st.w[free] = rng.normal(0.0, v0, len(free)) / np.sqrt(st.area[free])
    return sim.diagnostics()["kinetic_energy"]


@contextlib.contextmanager
def one_thread():
    """Evaluate forces of these small packs on one thread, as ``Simulation.step`` does."""
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(n)


# ---------------------------------------------------------------------------------------------
# the linearised pack and its energy


def linearised_frequencies(sim: Simulation, rel: float = 1e-7) -> np.ndarray:
    """Angular frequencies [rad/s] of the pack linearised about its current (unstrained)
    state, ascending: ``sqrt(eig(M^-1/2 K M^-1/2))``, ``K`` by central differences of the
    engine's contact forces over each free element's two displacements and its turn,
    ``M = diag(m, m, I)``."""
    st = sim.state
    n = st.n
    free = np.flatnonzero(st.flags == 0)
    zv, zw = np.zeros((n, 2)), np.zeros(n)
    K = np.zeros((3 * len(free), 3 * len(free)))
    for col in range(K.shape[1]):
        i, d = free[col // 3], col % 3
        Q = qmatrix(st.q[i])
        s = math.sqrt(st.area[i]) * rel if d < 2 else rel  # [m] or [rad]
        axis, angle = ((Q[:, 1], s / R), (-Q[:, 0], s / R), (Q[:, 2], s))[d]
        f = []
        for sign in (1.0, -1.0):
            q = st.q.copy()
            q[i] = rotate_about(st.q[i], axis, sign * angle)
            with one_thread():
                F, T = contact_forces(sim, q, zv, zw)
            f.append(np.column_stack([F, T])[free].reshape(-1))
        K[:, col] = -(f[0] - f[1]) / (2 * s)
    M = np.column_stack([st.m, st.m, st.I])[free].reshape(-1)
    lam = np.linalg.eigvalsh(0.5 * (K + K.T) / np.sqrt(np.outer(M, M)))
    return np.sqrt(np.clip(lam, 0.0, None))


class Reference(NamedTuple):
    dt_c: float  # critical step of the run [s] (contacts or water drag)
    omega_est: float  # the contacts' estimate [rad/s]
    element: int  # the element that sets it
    omega_lin: float  # largest frequency of the linearised pack [rad/s]


@functools.cache
def reference(law: str, corner: str) -> Reference:
    sim = build(law, corner)
    om, elem = sim.contacts.stiffness_bound()
    return Reference(sim.critical_dt, om, elem, float(linearised_frequencies(sim)[-1]))


def elastic_energy(sim: Simulation) -> float:
    """Elastic energy [J] of the intact joints.

    ``distributed_spring``: ``K w (|s1|² + s1·s2 + |s2|²) / 6`` (``K`` per unit length along the
    joint, displacement linear from ``s1`` to ``s2``; its force ``K w (s1 + s2)/2`` and couple
    ``K w w × (s2 - s1)/12`` derive from it). ``mohr_coulomb``: the sum over the ``n`` segments
    of ``(h E)_eff (w/n) (d_n² + d_t² G/E) / (2 L0)``, ``(h E)_eff`` the series combination of
    the two sides, strips of lengths ``r_i`` and ``L0 - r_i`` (``h E`` for identical cells).
    """
    cm, st = sim.contacts, sim.state
    out = 0.0
    for k in np.flatnonzero(cm.intact):
        i, j = cm.ji[k], cm.jj[k]
        a, b = cm.ends_i[k]
        s1 = np.array(frame_point(st.q[j], st.q[i], *cm.ends_j[k, 0], R)) - a
        s2 = np.array(frame_point(st.q[j], st.q[i], *cm.ends_j[k, 1], R)) - b
        w = cm.width[k]
        if cm.law.name == "distributed_spring":
            out += cm.jK[k] * w * (s1 @ s1 + s1 @ s2 + s2 @ s2) / 6.0
            continue
        nseg = int(cm.law.p["n_segments"])
        lam = min(np.hypot(*(0.5 * (a + b))) / cm.L0[k], 1.0)
        ka, kb = st.thickness[i] * cm.E[i], st.thickness[j] * cm.E[j]
        hE = ka * kb / (lam * kb + (1.0 - lam) * ka)
        g_over_e = 1.0 / (2.0 * (1.0 + cm.nu[i]))
        t = (b - a) / w
        z = (np.arange(nseg)[:, None] + 0.5) / nseg
        d = s1 + z * (s2 - s1)
        dn, dt = d @ np.array([t[1], -t[0]]), d @ t
        out += float(np.sum(hE * (w / nseg) * (dn**2 + g_over_e * dt**2) / (2.0 * cm.L0[k])))
    return out


def total_energy(sim: Simulation) -> float:
    """Kinetic plus elastic energy [J] at the current time. The state holds the half-step
    velocity of symplectic Euler (``V`` kicked by ``F(q_n)``, then ``q`` drifted to
    ``q_{n+1}``); the velocity at ``t_{n+1}`` is ``V + dt/2 F(q_{n+1})/m`` (velocity Verlet)."""
    st = sim.state
    with one_thread():
        F, T = contact_forces(sim)
    free = st.flags == 0
    V = st.V + 0.5 * sim.dt * F / st.m[:, None]
    w = st.w + 0.5 * sim.dt * T / st.I
    ke = 0.5 * np.sum(st.m[free] * (V[free] ** 2).sum(axis=1) + st.I[free] * w[free] ** 2)
    return float(ke) + elastic_energy(sim)


def modified_energy_bound(omega: float, dt: float) -> float:
    """``B = 1 / (1 - (omega dt / 2)²)``: velocity Verlet (and symplectic Euler) conserve
    ``v² + omega² x² (1 - (omega dt/2)²)`` of a linear mode, so its energy ``v² + omega² x²``
    stays between that and ``B`` times it (infinite for ``omega dt >= 2``: unstable)."""
    x = 0.5 * omega * dt
    return 1.0 / (1.0 - x * x) if x < 1.0 else math.inf


def free_drift_speed(wind: float) -> float:
    """Terminal speed [m/s] of ice under wind ``U`` over still water, ``rho_a C_a U² =
    rho_w C_w v²`` (eqs. 19–20 without turning angles)."""
    return wind * math.sqrt(AIR[0] * AIR[1] / (WATER[0] * WATER[1]))


def energy_series(sim: Simulation, steps: int, samples: int = 100) -> tuple[np.ndarray, float]:
    """``total_energy / E0`` after every ``steps / samples`` steps, and the largest speed."""
    e0 = total_energy(sim)
    out, vmax = [], 0.0
    for _ in range(samples):
        sim.run(steps // samples)
        out.append(total_energy(sim) / e0)
        vmax = max(vmax, sim.diagnostics()["max_speed"])
    return np.array(out), vmax


def assert_energy_within(e: np.ndarray, B: float, what: str) -> None:
    assert e.min() >= 1.0 - EPS and e.max() <= B * (1.0 + EPS), (
        f"{what}: energy / E0 in [{e.min():.6f}, {e.max():.6f}], bound [1, {B:.4f}] ± {EPS:g}")


# ---------------------------------------------------------------------------------------------
# the estimate at the corners


@pytest.mark.parametrize(("law", "corner"), cases(JOINT_LAWS, CORNERS))
def test_estimate_bounds_the_linearised_pack(law, corner):
    """The Gershgorin estimate is an upper bound of the pack's largest frequency."""
    ref = reference(law, corner)
    assert ref.omega_lin <= ref.omega_est, (
        f"omega_lin = {ref.omega_lin:.4g} rad/s > estimate {ref.omega_est:.4g} rad/s "
        f"(ratio {ref.omega_lin / ref.omega_est:.3f}): the estimate is optimistic")


@pytest.mark.parametrize(("law", "corner"), cases(JOINT_LAWS, CORNERS))
def test_energy_bounded_just_below_the_accepted_step(law, corner):
    """0.95 of the largest accepted step, 10^4 steps: accepted without a warning; calm: the
    energy stays in ``[E0, B E0]``; gale: no element faster than ``U_t + sqrt(2 B E0 /
    m_min)``, and where the run is much longer than the drag time the pack drifts at ``U_t``.
    Every joint intact."""
    c, ref = CORNERS[corner], reference(law, corner)
    dt = BELOW * ref.dt_c
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = build(law, corner, dt, STEPS)
    e0 = kick(sim)
    B = modified_energy_bound(ref.omega_lin, dt)
    e, vmax = energy_series(sim, STEPS)
    assert sim.step_index == STEPS
    assert sim.contacts.n_intact == sim.contacts.n_joints
    if c.wind == 0.0:
        assert_energy_within(e, B, f"{law} at {corner}, dt = {dt:.4g} s")
        return
    ut = free_drift_speed(c.wind)
    bound = ut + math.sqrt(2.0 * B * e0 / sim.state.m.min())
    assert vmax <= bound, f"max speed {vmax:.4g} m/s above {bound:.4g} m/s"
    # v' = a - b v²: v = U_t tanh(k t), k = U sqrt(rho_a C_a rho_w C_w) / (rho h)
    k = c.wind * math.sqrt(AIR[0] * AIR[1] * WATER[0] * WATER[1]) / (RHO_ICE * c.h)
    if k * sim.time > 5.0:
        d = sim.diagnostics()
        p = math.sqrt(sum(d[f"momentum_{x}"] ** 2 for x in "xyz"))
        assert p / sim.state.m.sum() == pytest.approx(ut, rel=0.05)


@pytest.mark.parametrize("share", [0.9, 1.05])
@pytest.mark.parametrize(("law", "corner"), cases(JOINT_LAWS, CALM))
def test_override_above_the_safe_share_warns_and_stays_bounded(law, corner, share):
    """0.9 and 1.05 ``dt_c`` with ``allow_unstable_dt``: a warning; as the estimate is
    conservative (``omega_lin dt < 2`` still), 2000 steps keep the energy in ``[E0, B E0]``."""
    ref = reference(law, corner)
    dt = share * ref.dt_c
    with pytest.warns(UserWarning, match=rf"under law '{law}'.*allow_unstable_dt = true"):
        sim = build(law, corner, dt, 2000, allow=True)
    kick(sim)
    B = modified_energy_bound(ref.omega_lin, dt)
    assert B < math.inf
    e, _ = energy_series(sim, 2000, samples=40)
    assert_energy_within(e, B, f"{law} at {corner}, dt = {share} dt_c")
    assert sim.contacts.n_intact == sim.contacts.n_joints


@pytest.mark.parametrize(("law", "corner"), cases(LAWS, CORNERS))
def test_step_just_above_the_safe_share_is_refused_naming_the_limit(law, corner):
    """1.02 × the safe share: ``StabilityError`` naming what sets ``dt_c`` (the law and
    element, or the water drag on thin large cells); the safe share itself is accepted."""
    ref = reference(law, corner)
    with pytest.raises(StabilityError) as err:
        build(law, corner, 1.02 * SAFETY * ref.dt_c)
    msg = str(err.value)
    assert "allow_unstable_dt" in msg
    if ref.dt_c < 2.0 / ref.omega_est * (1 - 1e-12):
        assert re.search(r"set by 'water_drag': water drag on element \d+", msg), msg
    else:
        assert (f"set by '{law}': stiffest contact of element {ref.element} under law '{law}'"
                in msg)
    build(law, corner, SAFETY * ref.dt_c)


@pytest.mark.parametrize("law", JOINT_LAWS)
def test_override_beyond_the_true_critical_step_diverges_and_is_caught(law, tmp_path):
    """At 1.05 × the linearised critical step ``2 / omega_lin`` (1.6 / 2.3 ``dt_c``) the pack
    diverges; the speed guard stops it with a message naming element, speed and step, and the
    state in memory and in the file is the last finite one, equal to a rerun to that step."""
    h5py = pytest.importorskip("h5py")
    corner = "stiff-small-thin"
    ref = reference(law, corner)
    dt = 1.05 * 2.0 / ref.omega_lin
    scene = corner_scene(law, corner, dt, 200, allow=True)
    with pytest.warns(UserWarning):
        sim = Simulation(scene, out=tmp_path / "div.h5", progress=False)
    kick(sim)
    with pytest.raises(NonFiniteError) as err:
        sim.run()
    m = re.search(r"speed of element \d+ is [\d.e+]+ m/s, above \[run\] max_speed = 100 m/s: "
                  r"the run is diverging \(is dt above the stable step\?\) at step (\d+) .*; "
                  r"\S+div.h5 holds the snapshots to the last good state \(step (\d+),",
                  str(err.value))
    assert m, str(err.value)
    bad, good = int(m[1]), int(m[2])
    assert good < bad < 100 and good == sim.step_index
    with pytest.warns(UserWarning):
        rerun = Simulation(scene, out=False, progress=False)
    kick(rerun)
    rerun.run(good)
    with h5py.File(tmp_path / "div.h5", "r") as f:
        assert f["states/step"][-1] == good
        for k in ("q", "V", "w"):
            assert np.isfinite(getattr(sim.state, k)).all()
            assert np.array_equal(getattr(sim.state, k), getattr(rerun.state, k)), k
            assert np.array_equal(f[f"states/{k}"][-1], getattr(rerun.state, k)), k
    # the joints went back with the elements (history of the same snapshot)
    assert np.array_equal(sim.contacts.intact, rerun.contacts.intact)
    assert np.array_equal(sim.contacts.hist, rerun.contacts.hist)


# ---------------------------------------------------------------------------------------------
# collisions


@pytest.mark.parametrize("share", [BELOW, 0.9])
@pytest.mark.parametrize("corner", ["stiff-small-thin", "soft-large-thick"])
def test_head_on_collision_at_the_corners(corner, share):
    """Two cells 1 % of their side apart close head-on along the equator at 0.2 m/s. A
    one-sided linear spring entered and left within a step keeps ``v² (1 - x²) <= H <= v²``,
    ``x = omega dt / 2``, so ``KE_out / KE_in`` lies in ``[1 - x², 1 / (1 - x²)]`` (``omega``
    the estimate: ``[0.77, 1.29]`` just below the accepted step)."""
    c = CORNERS[corner]
    dlon = math.degrees(1.01 * c.size / R)
    els = [{"center": (0.0, 0.0), "velocity": (0.1, 0.0)},
           {"center": (dlon, 0.0), "velocity": (-0.1, 0.0)}]

    def scene(dt, steps):
        return contact_scene("collision", LAWS["collision"], elements=els, size=c.size, dt=dt,
                             steps=steps, thickness=c.h, youngs_modulus=c.E, joints="none",
                             run={"allow_unstable_dt": True})

    probe = Simulation(scene(1e-9, 1), out=False, progress=False)
    om = probe.contacts.stiffness_bound()[0]
    dt = share * probe.critical_dt
    steps = int((0.01 * c.size / 0.2 + 40.0 / om) / dt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(dt, steps), out=False, progress=False)
    ke0 = sim.diagnostics()["kinetic_energy"]
    touched = 0
    for _ in range(steps):
        sim.step()
        touched += sim.contacts.n_overlap
    x2 = (0.5 * om * dt) ** 2
    ratio = sim.diagnostics()["kinetic_energy"] / ke0
    assert touched > 0 and sim.contacts.n_overlap == 0
    assert sim.state.V[0, 0] < 0 < sim.state.V[1, 0]  # bounced back
    assert 1.0 - x2 <= ratio <= 1.0 / (1.0 - x2), f"KE out / in = {ratio:.4f}"


@pytest.mark.xfail(strict=True, reason=(
    "engine: the collision force K A n (contact_laws/collision.py, collision_evaluator) is "
    "not a potential force: for a "
    "face contact A = L(y) depth depends on the sliding offset y, but no tangential force "
    "-dU/dy goes with it; the loop gains 18 % of the elastic energy, and undamped touching "
    "packs gain energy at a dt-independent rate (x5 in 1e5 steps)"))
def test_collision_force_does_no_work_around_a_closed_loop():
    """Two 2 km cells at 70°N overlapping face-on: move ``j`` round a rectangle in (push,
    slide) = (1 m → 3 m, 200 m → 600 m). A conservative force does no net work (here to the
    midpoint-rule and curvature error, far below 1e-3 of the elastic energy)."""
    a = 2000.0
    dlon = math.degrees(a / (R * math.cos(math.radians(70.0))))
    els = [{"center": (10.0, 70.0)}, {"center": (10.0 + dlon, 70.0)}]
    sim = Simulation(contact_scene("collision", LAWS["collision"], elements=els, size=a,
                                   joints="none"), out=False, progress=False)
    q0, Q = sim.state.q.copy(), qmatrix(sim.state.q[1])
    zv, zw = np.zeros((2, 2)), np.zeros(2)

    def force(push, slide):
        """Force on ``j`` along (push into ``i``, slide north) [N]."""
        q = q0.copy()
        q[1] = rotate_about(rotate_about(q0[1], Q[:, 1], -push / R), -Q[:, 0], slide / R)
        F, _ = contact_forces(sim, q, zv, zw)
        return np.array([-F[1, 0], F[1, 1]])

    corners = [np.array(p) for p in ((1.0, 200.0), (3.0, 200.0), (3.0, 600.0), (1.0, 600.0))]
    work, n = 0.0, 200
    for p0, p1 in zip(corners, corners[1:] + corners[:1]):
        for k in range(n):
            work += force(*(p0 + (p1 - p0) * (k + 0.5) / n)) @ ((p1 - p0) / n)
    elastic = 0.5 * abs(force(3.0, 200.0)[0]) * 3.0
    assert abs(work) <= 1e-3 * elastic, f"work round the loop {work / elastic:+.3f} × elastic"


# ---------------------------------------------------------------------------------------------
# the pole and the antimeridian

TO_POLE = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])  # (1,0,0) -> north pole


def site_elements(site: str, size: float) -> dict:
    """Scene keys of a jointed pack with 1 % gaps: ``equator`` 4 × 4 cells about (0°, 0°),
    ``north-pole`` the same turned exactly (a permutation of coordinates) so that the pole is
    its middle vertex; ``meridian`` 4 × 3 cells at 70°N about 0°E, ``antimeridian`` the same
    turned by 180° about the axis, straddling 180°."""
    if site in ("equator", "north-pole"):
        d = math.degrees(size / R)
        out = []
        for cell in rect_pack((-2 * d, 2 * d), (-2 * d, 2 * d), 4, 4, gap=GAP):
            ll = np.radians(cell.lonlat)
            p = np.column_stack([np.cos(ll[:, 1]) * np.cos(ll[:, 0]),
                                 np.cos(ll[:, 1]) * np.sin(ll[:, 0]), np.sin(ll[:, 1])])
            if site == "north-pole":
                p = p @ TO_POLE.T
            lonlat = np.degrees(np.column_stack([np.arctan2(p[:, 1], p[:, 0]),
                                                 np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1]))]))
            out.append({"vertices": lonlat.tolist()})
        return {"elements": out}
    pack = square_pack(0.0, 70.0, 4, 3, size, gap=GAP)
    width = pack["lon"][1] - pack["lon"][0]
    lon0 = -0.5 * width + (180.0 if site == "antimeridian" else 0.0)
    return {"packs": [dict(pack, lon=[lon0, lon0 + width])]}


def set_motion(sim: Simulation, motion: str, rate: float) -> None:
    """``spin``: the pack turns rigidly about its centre at ``rate`` [rad/s]; ``pull``: it
    expands uniformly, velocity ``rate`` [1/s] × distance from the centre."""
    st = sim.state
    c = centers(st.q)
    c0 = c.mean(axis=0) / np.linalg.norm(c.mean(axis=0))
    for i in range(st.n):
        if motion == "spin":
            v, st.w[i] = rate * R * np.cross(c0, c[i]), rate * (c0 @ c[i])
        else:
            v, st.w[i] = rate * R * (c[i] * (c[i] @ c0) - c0), 0.0
        st.V[i] = (qmatrix(st.q[i]).T @ v)[:2]


@functools.cache
def site_run(law: str, site: str, motion: str, size: float) -> dict:
    """2000 steps at 0.95 of the accepted step, the law's default joint strengths, no damping:
    joint count, intact joints, energy / E0 and largest joint strain after every 40 steps."""
    params = {"joint_damping_ratio": 0.0, "damping_ratio": 0.0}

    def sim_of(dt, steps):
        scene = contact_scene(law, params, dt=dt, steps=steps, **site_elements(site, size))
        return Simulation(scene, out=False, progress=False)

    probe = sim_of(1e-9, 1)
    dt = BELOW * probe.critical_dt
    sim = sim_of(dt, 2000)
    set_motion(sim, motion, (2e-5 if motion == "spin" else 1e-5) * 2000.0 / size)
    cm = sim.contacts
    e0 = total_energy(sim)
    energy, strain = [], []
    for _ in range(50):
        sim.run(40)
        energy.append(total_energy(sim) / e0)
        strain.append(joint_strain_opening(sim.state.q, cm.ji, cm.jj, cm.ends_i, cm.ends_j,
                                           cm.L0, R)[0].max())
    F, T = contact_forces(sim)
    return {"joints": cm.n_joints, "intact": cm.n_intact, "energy": np.array(energy),
            "strain": np.array(strain), "finite": bool(np.isfinite(F).all() & np.isfinite(T).all()),
            "B": modified_energy_bound(float(linearised_frequencies(probe)[-1]), dt)}


SITES = [("north-pole", "equator", 2000.0), ("antimeridian", "meridian", 2000.0),
         ("north-pole", "equator", 10.0)]
PULL_STRAIN = 3e-5  # the pull's largest joint strain (measured 3.0e-5 at every site)


def round_off_floor(size: float, steps: int = 2000) -> float:
    """``sqrt(N) R eps / (PULL_STRAIN L0)``: the position round-off of ``N`` steps (a random
    walk of ``R eps`` per step in each quaternion) against the pull's largest joint opening."""
    return math.sqrt(steps) * R * np.finfo(float).eps / (PULL_STRAIN * size)


@pytest.mark.parametrize("motion", ["spin", "pull"])
@pytest.mark.parametrize(("site", "reference_site", "size"), SITES,
                         ids=["north-pole", "antimeridian", "north-pole-10m"])
@pytest.mark.parametrize("law", JOINT_LAWS)
def test_jointed_pack_at_the_pole_and_across_the_antimeridian(law, site, reference_site, size,
                                                               motion):
    """A 4 × 4 pack whose middle vertex is the north pole, and a 4 × 3 pack straddling 180°E at
    70°N, spinning rigidly or pulled apart uniformly (0.1 and 0.06 m/s at the outer corners):
    every joint found (24, 17), none broken (strains <= 4e-5, below both laws' default
    strength), forces finite, energy in ``[E0, B E0]``. A rigid spin strains no joint beyond its
    centripetal load, strain ``~ Omega² r rho a / E ≈ 3e-9`` (measured 6e-9; allowed 1e-7).

    The packs are exact turns of a reference pack (equator; 0°E at 70°N) and differ from it only
    by round-off. Latitudes are exact to round-off everywhere (``atan2(z, hypot(x, y))``); the
    former ``asin(z)`` moved the cells next to the pole by ``R eps / colatitude`` when they were
    built (0.46 mm for 10 m cells, putting that pack's strain 15 floors from the reference;
    1e-6 m for 2 km cells, harmless there as the joints are found in the shifted places).
    What is left is the round-off of the positions: ``R eps = 1.4e-9 m`` per step in each
    element's quaternion, a random walk to ``sqrt(N) R eps = 6.3e-8 m`` after the ``N = 2000``
    steps, against the pull's largest joint opening ``3e-5 L0``: the floor ``f`` of
    :func:`round_off_floor`, 1.05e-6 for 2 km cells and 2.1e-4 for 10 m. Measured: the largest
    strains agree to 0.4–1.6 ``f`` (relative; the antimeridian 0.4, not a pole effect), the
    energies to at most 0.21 ``f`` (of ``E0``; the spins' far less); allowed 10 ``f`` and
    2 ``f``."""
    run = site_run(law, site, motion, size)
    assert run["joints"] == (24 if site == "north-pole" else 17)
    assert run["intact"] == run["joints"]
    assert run["finite"]
    assert_energy_within(run["energy"], run["B"], f"{law} {motion} at {site}")
    if motion == "spin":
        assert run["strain"].max() <= 1e-7
    ref = site_run(law, reference_site, motion, size)
    assert ref["joints"] == run["joints"]
    f = round_off_floor(size)
    de = np.abs(run["energy"] - ref["energy"]).max()
    assert de <= 2 * f, f"energy differs from {reference_site} by {de:.3e} E0 = {de / f:.2f} f"
    if motion == "pull":
        ds = np.abs(run["strain"] - ref["strain"]).max() / ref["strain"].max()
        assert ds <= 10 * f, f"strain differs from {reference_site} by {ds:.3e} = {ds / f:.2f} f"


# ---------------------------------------------------------------------------------------------
# long runs


def long_run(law: str, steps: int, stride: int | None = None) -> dict:
    """A 2 × 2 jittered pack of 2 km cells of 1 m ice (E = 1 GPa) at 70°N, unbreakable joints,
    no damping, no forcing, kicked, at 0.95 of the accepted step: the energy every ``stride``
    steps (chosen to keep every mode's oscillation from aliasing), the linearised frequencies
    and the step."""
    pack = square_pack(10.0, 70.0, 2, 2, 2000.0, gap=GAP, jitter=0.2, seed=5)

    def sim_of(dt, n):
        scene = contact_scene(law, LAWS[law], packs=[pack], dt=dt, steps=n)
        return Simulation(scene, out=False, progress=False)

    probe = sim_of(1e-9, 1)
    omega = linearised_frequencies(probe)
    omega = omega[omega > 1e-3 * omega[-1]]  # the rigid motions (3) keep their energy
    dt = BELOW * probe.critical_dt
    # the energy of mode m oscillates at 2 w_m, w_m dt = 2 asin(omega_m dt / 2)
    wdt = 2.0 * np.arcsin(0.5 * omega * dt)
    if stride is None:
        stride = max(range(1, 16), key=lambda s: np.abs(np.sin(wdt * s)).min())
    sim = sim_of(dt, steps)
    kick(sim)
    e0 = total_energy(sim)
    energy = []
    for _ in range(steps // stride):
        sim.run(stride)
        energy.append(total_energy(sim) / e0)
    return {"energy": np.array(energy), "omega": omega, "dt": dt, "stride": stride,
            "wdt": wdt, "intact": sim.contacts.n_intact == sim.contacts.n_joints}


def check_long_run(run: dict) -> None:
    """The energy stays in ``[E0, B E0]`` and the first and last 10 % windows (``N`` samples
    each) have equal means up to the averaging residual of that bounded oscillation: with
    ``E_n - H = sum_m a_m (1 + cos(2 w_m n s dt + phi_m))``, ``sum a_m <= (B - 1) E0 / 2``,
    a window mean deviates by at most ``sum a_m / (N |sin(w_m s dt)|)``. A secular drift (any
    first-order non-symplectic scheme, or a non-conservative force) exceeds that."""
    e = run["energy"]
    B = modified_energy_bound(run["omega"][-1], run["dt"])
    assert_energy_within(e, B, "long run")
    assert run["intact"]
    n = len(e) // 10
    drift = e[-n:].mean() - e[:n].mean()
    residual = 0.5 * (B - 1.0) / (n * np.abs(np.sin(run["wdt"] * run["stride"])).min())
    assert abs(drift) <= 2.0 * residual, (
        f"energy drift between the first and last 10 %: {drift:+.3e} E0, allowed "
        f"{2 * residual:.3e} (range [{e.min():.6f}, {e.max():.6f}], B = {B:.4f})")


@pytest.mark.slow  # the long validation; 10^4 steps at every corner stay in the default suite
@pytest.mark.parametrize("law", JOINT_LAWS)
def test_long_run_has_no_energy_drift(law):
    """10^5 steps (about 7 s each on an idle machine). Measured: energy within [1.0005, 1.018]
    E0 (B = 1.074, spring; 1.034, Mohr–Coulomb), drift -5e-6 / -2e-6 E0 against 4e-5 / 2e-5
    allowed."""
    check_long_run(long_run(law, 100_000))
