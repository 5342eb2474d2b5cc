"""The stable-step estimate counts every stiffness and damper (siku_core.contact.stable_step).

The default scene rang at its shipped step (1.75 s, "safe step 1.76 s"): the element-wise bound
``2 / omega`` ignored the damping, which the integrator applies explicitly (to the old
velocity) and which lowers the stable step to ``4 / (gamma + sqrt(gamma² + 4 omega²))``; and
under ``jointed = "collide"`` a jointed pair that touches carries the joint's damper *and* the
collision's (``damping_ratio`` acts on touching faces), and when pressed the collision's
stiffness too. With the default scene's ratios (0.5 and 0.5) the stable step is 1.60 s.

Checked here, on small packs of every contact law and rule:

* the matrices the estimate assembles are the engine's own linearisation: the stiffness and
  damping of the joints by central differences of the engine's contact forces (``jointed =
  "exclude"``, where the linearisation at rest is smooth);
* a run at the largest accepted step (``dt_safety × dt_c``) from small random velocities, with no
  forcing, stays quiet for 10 000 steps: the kinetic energy never exceeds 4/3 of its start (the
  bound of an undamped mode of semi-implicit Euler at ``omega dt <= 1``, section header of
  ``test_stability.py``; damping only takes energy out) and no joint breaks; at a wider margin
  ``s`` (``[run] dt_safety = 0.9``) the same with the bound ``1 / (1 - s²)``: semi-implicit Euler
  keeps ``v² + omega² x² - dt omega² x v`` of an undamped mode, so from rest (``x = 0``) its
  kinetic energy stays within ``1 / (1 - (omega dt / 2)²)`` of its start, and ``dt_c <= 2 /
  omega_max`` makes ``omega dt / 2 <= s`` in every mode;
* the amplification matrix's spectral radius is at most 1 at every step the guard can accept,
  ``s × dt_c`` for ``s`` up to 1 (the largest ``dt_safety`` allowed), mode by mode;
* the same joint pack at 1.25 × its linear stable limit rings (the kinetic energy grows by
  more than a million times in 2000 steps): the run above could have failed;
* at 1.5 × the accepted step the run is refused before it starts, the message naming the
  element and the safe step; from the command line: exit 2, one line;
* above ``DENSE_DOF`` the estimate (a fixed number of Lanczos steps on the never-formed
  operators, capped by Gershgorin's bound) lies between the largest eigenvalue and that over
  ``1 - LANCZOS_TOL``, and a bonded pack of 40 000 elongated cells is checked within 1 GB
  (the matrices' triplets alone took about 50 kB per element before).
"""
from __future__ import annotations

import math
import re
import tracemalloc
import warnings

import numpy as np
import pytest

from siku_core.errors import NonFiniteError, StabilityError
from siku_core.geometry.quat import qmatrix
from siku_core.run.simulation import Simulation
from siku_core.contact import stable_step
from siku_core.contact.stable_step import (
    LANCZOS_TOL, contact_matrices, critical_step, top_eigenvalue,
)
from siku_core.state import FREE
from siku_core.testing.contact_cases import (
    contact_forces,
    contact_scene,
    contact_scene_text,
    rotate_about,
    square_pack,
)
from siku_core.testing.scenes import EARTH_RADIUS as R

DAMPED = {"damping_ratio": 0.5, "joint_damping_ratio": 0.5}
LAWS = {
    "distributed_spring": {"tensile_strain": 1.0, **DAMPED},
    "mohr_coulomb": {"sigma_c": 1e12, **DAMPED},
    "bonded_particle": {"sigma_crit": 1e12, "tau_crit": 1e12, **DAMPED},
    "collision": {"damping_ratio": 0.5},
}
SAFETY = 0.5  # default [run] dt_safety
WIDE = 0.9  # a wider [run] dt_safety (docs/explanation/speed_accuracy.md §6)
REL_STEP = 1e-5  # finite-difference step, relative to the element size
STEPS = 10_000

#: (law, jointed, touching, pack keys, cell size [m]): jittered packs (irregular shapes) of
#: several sizes, some with a static column (static neighbours)
CASES = {
    "spring-collide-contact": ("distributed_spring", "collide", "contact",
                               {"jitter": 0.2, "seed": 3}, 2000.0),
    "spring-collide-ignore-static": ("distributed_spring", "collide", "ignore",
                                     {"left": "static"}, 500.0),
    "spring-exclude": ("distributed_spring", "exclude", "contact", {"jitter": 0.2, "seed": 5},
                       8000.0),
    "spring-exclude-static": ("distributed_spring", "exclude", "contact", {"left": "static"},
                              8000.0),
    "mohr_coulomb-collide": ("mohr_coulomb", "collide", "contact", {"jitter": 0.2, "seed": 3},
                             2000.0),
    "mohr_coulomb-exclude-static": ("mohr_coulomb", "exclude", "ignore", {"left": "static"},
                                    1000.0),
    "bonded_particle-collide": ("bonded_particle", "collide", "contact", {"jitter": 0.2,
                                                                           "seed": 7}, 50.0),
    "bonded_particle-exclude": ("bonded_particle", "exclude", "ignore", {}, 20.0),
    "collision-contact": ("collision", "collide", "contact", {"jitter": 0.2, "seed": 3}, 2000.0),
    "collision-ignore-static": ("collision", "collide", "ignore", {"left": "static"}, 4000.0),
}
#: packs whose limiting mode is a collision the pack at rest does not feel (a pressed jointed
#: pair, or the free edges' budget against a partner that is not there): at 1.25 × the limit
#: the kinetic energy does not grow (measured); the estimate is conservative there
NOT_RINGING = ("bonded_particle-collide",)
FAST = ("spring-collide-contact", "bonded_particle-exclude", "collision-ignore-static")


def _scene(case: str, dt: float, steps: int = 10, allow: bool = False, cells=(4, 3),
           safety: float = SAFETY):
    law, jointed, touching, keys, size = CASES[case]
    pack = square_pack(10.0, 70.0, *cells, size, **keys)
    return contact_scene(law, LAWS[law], packs=[pack], dt=dt, steps=steps, size=size,
                         jointed=jointed, touching=touching,
                         run={"allow_unstable_dt": allow, "max_speed": 1e30,
                              "dt_safety": safety})


def _probe(case: str, cells=(4, 3)) -> Simulation:
    return Simulation(_scene(case, 1e-6, cells=cells), out=False, progress=False)


def _radius(sim: Simulation, explicit: bool = False):
    """The spectral radius of semi-implicit Euler's amplification matrix of the assembled
    linear system (dense, small packs) as a function of the step ``h`` [s], with the dampers
    as they act in a step of ``h`` (bounded: ``siku_core.contact.damping``; ``explicit``: as
    written)."""
    st = sim.state
    rates = sim.contacts.law.stability_rates()
    K, _ = contact_matrices(sim.contacts, rates)
    dof = np.flatnonzero(np.repeat(st.flags == FREE, 3))
    mass = np.stack([st.m, st.m, st.I], axis=1).ravel()[dof]
    Kd = K[dof][:, dof].toarray() / mass[:, None]
    n = len(dof)
    eye = np.eye(n)

    def radius(h):
        C = contact_matrices(sim.contacts, rates, dt=None if explicit else h)[1]
        a = eye - h * (C[dof][:, dof].toarray() / mass[:, None])
        amp = np.block([[a, -h * Kd], [h * a, eye - h * h * Kd]])
        return np.max(np.abs(np.linalg.eigvals(amp)))

    return radius


def _linear_limit(sim: Simulation, explicit: bool = False) -> float:
    """The largest stable step [s] of the assembled linear system: bisection on the spectral
    radius of :func:`_radius`."""
    radius = _radius(sim, explicit)

    # a mode without stiffness has a double eigenvalue 1 (a Jordan block), which round-off
    # splits by about sqrt(eps)
    one = 1.0 + 1e-6
    lo, hi = 0.0, 2.0 * sim.critical_dt
    while radius(hi) <= one:
        hi *= 2.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if radius(mid) <= one else (lo, mid)
    return lo


def _kick(sim: Simulation, speed: float = 1e-6, seed: int = 0) -> None:
    """Random velocities of about ``speed`` [m/s] and spins of the same edge speed."""
    st = sim.state
    rng = np.random.default_rng(seed)
    free = st.flags == FREE
    st.V[free] = speed * rng.standard_normal((free.sum(), 2))
    st.w[free] = speed / st.radius[free] * rng.standard_normal(free.sum())


def _kinetic(sim: Simulation) -> float:
    st = sim.state
    return 0.5 * float(np.sum(st.m * np.sum(st.V**2, axis=1)) + np.sum(st.I * st.w**2))


def _run_kinetic(case: str, dt: float, steps: int) -> tuple[float, float, Simulation]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_scene(case, dt, steps, allow=True), out=False, progress=False)
    _kick(sim)
    ke0 = _kinetic(sim)
    top = ke0
    try:
        for _ in range(steps):
            sim.step()
            top = max(top, _kinetic(sim))
    except NonFiniteError:
        top = math.inf
    return ke0, top, sim


# ------------------------------------------------------------------ the matrices
def _engine_linearisation(sim: Simulation):
    """``(K, C)`` of the engine's contact forces by central differences about the rest state,
    over each free element's two displacements and its turn (then its two velocities and
    spin)."""
    st = sim.state
    free = np.flatnonzero(st.flags == FREE)
    n3 = 3 * len(free)
    K = np.zeros((n3, n3))
    C = np.zeros((n3, n3))
    zv, zw = np.zeros((st.n, 2)), np.zeros(st.n)
    for col in range(n3):
        i, d = free[col // 3], col % 3
        Q = qmatrix(st.q[i])
        s = math.sqrt(st.area[i]) * REL_STEP if d < 2 else REL_STEP
        axis, angle = ((Q[:, 1], s / R), (-Q[:, 0], s / R), (Q[:, 2], s))[d]
        fk, fc = [], []
        for sign in (1.0, -1.0):
            q = st.q.copy()
            q[i] = rotate_about(st.q[i], axis, sign * angle)
            F, T = contact_forces(sim, q, zv, zw)
            fk.append(np.column_stack([F, T])[free].reshape(-1))
            V, w = zv.copy(), zw.copy()
            if d < 2:
                V[i, d] = sign * 1e-6
            else:
                w[i] = sign * 1e-6 / st.radius[i]
            F, T = contact_forces(sim, st.q, V, w)
            fc.append(np.column_stack([F, T])[free].reshape(-1))
        K[:, col] = -(fk[0] - fk[1]) / (2 * s)
        C[:, col] = -(fc[0] - fc[1]) / (2 * (1e-6 if d < 2 else 1e-6 / st.radius[i]))
    return K, C


@pytest.mark.parametrize("case", ["spring-exclude-static", "mohr_coulomb-exclude-static",
                                  "bonded_particle-exclude"])
def test_assembled_joint_matrices_are_the_engines_linearisation(case):
    """Joints alone (``exclude``, regular packs: no other pair touches at rest): the
    estimate's stiffness and damping against the engine's.
    Along the joint the spring is as stiff as across it, Mohr–Coulomb and the bond
    ``1/(2(1+nu))`` of it (the laws' ``stability_rates``). The assembled matrices equal the
    engine's (Mohr–Coulomb's segment sums bend a little less than the exact integral: the
    estimate bounds them from above, ``x^T (K_est - K_eng) x >= 0``). Finite differences of
    ``REL_STEP`` of the element size ``L`` carry the round-off of positions on the sphere,
    ``R eps / (REL_STEP L)``; the tolerance is ten times that."""
    sim = _probe(case)
    st = sim.state
    law = CASES[case][0]
    deficit = 1.0 / sim.contacts.law.p["n_segments"] ** 2 if law == "mohr_coulomb" else 0.0
    # the dampers as they act at the run's step (bounded: siku_core.contact.damping)
    Kx, Cx = contact_matrices(sim.contacts, sim.contacts.law.stability_rates(), edges=False,
                              dt=sim.dt)
    dof = np.flatnonzero(np.repeat(st.flags == FREE, 3))
    Ka, Ca = Kx[dof][:, dof].toarray(), Cx[dof][:, dof].toarray()
    Ke, Ce = _engine_linearisation(sim)
    mass = np.stack([st.m, st.m, st.I], axis=1).ravel()[dof]
    s = 1.0 / np.sqrt(np.outer(mass, mass))
    tol = 10 * R * np.finfo(float).eps / (REL_STEP * math.sqrt(st.area.min())) + 1e-6
    for est, eng in ((Ka * s, Ke * s), (Ca * s, Ce * s)):
        eng = 0.5 * (eng + eng.T)
        scale = np.max(np.abs(est))
        gap = np.linalg.eigvalsh(est - eng)
        assert gap[0] >= -tol * scale, case
        if law != "mohr_coulomb":
            np.testing.assert_allclose(eng, est, atol=tol * scale)
        # the largest eigenvalues agree: exactly, or for Mohr–Coulomb within the midpoint
        # rule's bending deficit over n segments (1/n² of the couple)
        top_est, top_eng = np.linalg.eigvalsh(est)[-1], np.linalg.eigvalsh(eng)[-1]
        assert top_eng <= top_est * (1 + tol)
        assert top_eng >= top_est * (1 - deficit - tol)


# ------------------------------------------------------------------ runs
def _check_quiet(case, safety: float = SAFETY, steps: int = STEPS):
    probe = _probe(case)
    dt = safety * probe.critical_dt
    Simulation(_scene(case, dt, safety=safety), out=False, progress=False)  # accepted
    ke0, top, sim = _run_kinetic(case, dt, steps)
    # an undamped mode from rest at omega dt / 2 <= safety (the module's docstring)
    assert top <= ke0 / (1.0 - safety**2), (case, top / ke0)
    if sim.contacts.n_joints:
        assert sim.contacts.n_intact == sim.contacts.n_joints


def _check_rings(case):
    """Joint packs only: a collision is one-sided, and past the limit a pair that bounces apart
    takes the gained energy away instead of ringing (the collision pack here gains a factor of
    about 40 in 2000 steps, then drifts)."""
    if CASES[case][0] == "collision" or case in NOT_RINGING:
        return
    limit = _linear_limit(_probe(case))
    ke0, top, _ = _run_kinetic(case, 1.25 * limit, 2000)
    assert top > 1e6 * ke0, (case, top / ke0)


@pytest.mark.parametrize("case", FAST)
def test_a_run_at_the_accepted_step_stays_quiet(case):
    _check_quiet(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", [c for c in CASES if c not in FAST])
def test_a_run_at_the_accepted_step_stays_quiet_every_law_and_rule(case):
    _check_quiet(case)


@pytest.mark.parametrize("case", FAST)
def test_a_run_at_a_wide_margin_stays_within_the_schemes_energy_bound(case):
    """``[run] dt_safety = 0.9``: accepted, and 3000 steps from rest within ``1 / (1 - 0.81)``
    of the starting kinetic energy, no joint broken."""
    _check_quiet(case, WIDE, 3000)


@pytest.mark.parametrize("case", FAST)
def test_the_damped_scheme_is_stable_at_every_step_the_guard_can_accept(case):
    """The spectral radius of the amplification matrix (dense, the dampers bounded as they
    act at each step) is at most 1 at ``s × dt_c`` for ``s`` from 0.05 to 1, the widest
    ``[run] dt_safety``: no margin the guard accepts leaves the linear system's stable set."""
    probe = _probe(case)
    radius = _radius(probe)
    one = 1.0 + 1e-6  # (a mode without stiffness: a Jordan block split by round-off)
    for s in np.linspace(0.05, 1.0, 20):
        assert radius(s * probe.critical_dt) <= one, (case, s)


@pytest.mark.parametrize("case", FAST)
def test_the_estimate_is_within_the_linear_limit_and_past_it_rings(case):
    """``dt_c`` never exceeds the assembled system's exact limit; 1.25 × that limit rings."""
    probe = _probe(case)
    limit = _linear_limit(probe)
    assert probe.critical_dt <= limit * (1 + 1e-9)
    _check_rings(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", [c for c in CASES if c not in FAST])
def test_past_the_linear_limit_every_law_and_rule_rings(case):
    probe = _probe(case)
    assert probe.critical_dt <= _linear_limit(probe) * (1 + 1e-9)
    _check_rings(case)


def test_bounded_dampers_leave_the_step_near_the_undamped_limit():
    """The default scene's ratios (0.5 and 0.5) on a touching jointed pack, where explicit
    dampers set the step (``4 / (gamma + sqrt(gamma² + 4 omega²))``: 0.36 × ``2 / omega``
    here). Bounded by the step (``siku_core.contact.damping``), the dampers leave the assembled
    system's exact limit at 0.72 × the undamped ``2 / omega`` (asserted: above 0.7 ×); the
    whole pack's estimate lies within that limit and above 1.5 × the explicit one, and the
    amplification matrix's spectral radius is at most 1 at the estimate, mode by mode. The
    engine takes the smaller of it and the element-wise undamped bound."""
    sim = _probe("spring-collide-contact")
    d = sim.contacts.stable_step_details
    om, gam = d["omega"], d["gamma"]
    explicit = 4.0 / (gam + math.sqrt(gam * gam + 4 * om * om))
    assert sim.critical_dt == pytest.approx(min(d["linear"], d["undamped_bound"]), rel=1e-12)
    assert d["linear"] > 1.5 * explicit
    limit = _linear_limit(sim)
    assert d["linear"] <= limit * (1 + 1e-9)
    assert limit >= 0.7 * 2.0 / om
    assert _linear_limit(sim, explicit=True) < 0.4 * 2.0 / om
    radius = _radius(sim)
    one = 1.0 + 1e-6  # (a mode without stiffness: a Jordan block split by round-off)
    assert radius(d["linear"]) <= one
    assert radius(1.5 * explicit) <= one


def test_a_law_with_explicit_dampers_keeps_the_damped_estimate():
    """A law that does not declare ``bounded_damping`` (a third party's, whose dampers act as
    written) keeps the explicit estimate ``4 / (gamma + sqrt(gamma² + 4 omega²))``, within
    the exact limit of its explicit dampers."""
    from siku_plugins.contact_laws import DistributedSpring

    class Explicit(DistributedSpring):
        name = "explicit_spring"

    sim = _probe("spring-collide-contact")
    sim.contacts.law.__class__ = Explicit
    assert sim.contacts.law.stability_rates()["bounded_damping"] is False
    dt_c, _ = sim.contacts.stability_limit(None)
    d = sim.contacts.stable_step_details
    om, gam = d["omega"], d["gamma"]
    assert d["linear"] == pytest.approx(4.0 / (gam + math.sqrt(gam * gam + 4 * om * om)))
    assert dt_c <= _linear_limit(sim, explicit=True) * (1 + 1e-9)


@pytest.mark.parametrize("case", ["spring-collide-contact", "collision-contact"])
def test_one_and_a_half_times_the_safe_step_is_refused_naming_element_and_step(case):
    probe = _probe(case)
    safe = SAFETY * probe.critical_dt
    with pytest.raises(StabilityError) as err:
        Simulation(_scene(case, 1.5 * safe), out=False, progress=False)
    msg = str(err.value)
    assert "\n" not in msg
    assert re.search(r"element \d+", msg)
    assert f"safe step {safe:.4g} s" in msg


def test_the_command_line_refuses_with_exit_2_and_one_line(tmp_path, capsys):
    from siku_core.run.cli import main

    case = "spring-collide-contact"
    probe = _probe(case)
    safe = SAFETY * probe.critical_dt
    law, jointed, touching, keys, size = CASES[case]
    text = contact_scene_text(law, LAWS[law], packs=[square_pack(10.0, 70.0, 4, 3, size, **keys)],
                              dt=1.5 * safe, steps=10, size=size, jointed=jointed,
                              touching=touching)
    path = tmp_path / "pack.toml"
    path.write_text(text)
    assert main(["run", "--no-progress", str(path)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1
    assert re.search(r"element \d+", err[0]) and f"safe step {safe:.4g} s" in err[0]


def test_where_the_estimate_cannot_be_sure_the_engine_says_so():
    """The ``sqrt_area`` collision law's stiffness ``K w sqrt(A_min/A)/2`` has no bound as the
    overlap vanishes: the engine warns, and the refusal message carries the reason."""
    pack = square_pack(10.0, 70.0, 4, 3, 2000.0)
    with pytest.warns(UserWarning, match="cannot be sure: the sqrt_area collision stiffness"):
        sim = Simulation(contact_scene("collision", {"sqrt_area": True}, packs=[pack],
                                       dt=1e-3, steps=1), out=False, progress=False)
    with pytest.warns(UserWarning), pytest.raises(StabilityError, match="not sure: the sqrt"):
        Simulation(contact_scene("collision", {"sqrt_area": True}, packs=[pack],
                                 dt=1.5 * sim.critical_dt, steps=1), out=False, progress=False)


# ------------------------------------------------------------------ the sparse estimate
def _scaled(sim: Simulation):
    """``(K, C)`` factored, the inverse square roots of the DOF's masses and the free DOF."""
    st = sim.state
    KA, CA = contact_matrices(sim.contacts, sim.contacts.law.stability_rates(), factored=True)
    scale = 1.0 / np.sqrt(np.stack([st.m, st.m, st.I], axis=1).ravel())
    return KA, CA, scale, np.flatnonzero(np.repeat(st.flags == FREE, 3))


@pytest.mark.parametrize("case", ["spring-collide-contact", "bonded_particle-collide",
                                  "collision-ignore-static"])
def test_the_sparse_estimate_lies_above_the_largest_eigenvalue_within_its_tolerance(case):
    """``lambda_max <= estimate <= lambda_max / (1 - LANCZOS_TOL)`` for the mass-scaled
    stiffness and damping of packs of 16 × 16 cells (768 DOF: the sparse path's 89 Lanczos
    steps span an eighth of the space), ``lambda_max`` dense; the factored operator's
    Gershgorin bound is an upper bound too."""
    KA, CA, scale, dof = _scaled(_probe(case, cells=(16, 16)))
    for A in (KA, CA):
        S = (A.matrix().multiply(np.outer(scale, scale)))
        exact = np.linalg.eigvalsh(S.toarray()[np.ix_(dof, dof)])[-1]
        op = A.gram(scale)
        est, vec = top_eigenvalue(op)
        assert exact * (1 - 1e-12) <= est <= exact / (1 - LANCZOS_TOL) * (1 + 1e-12), case
        assert op.gershgorin().max() >= exact * (1 - 1e-12)
        # the vector is its mode: a Rayleigh quotient as close to the top as the estimate
        assert vec @ op.matvec(vec) / (vec @ vec) >= (1 - LANCZOS_TOL) * exact


@pytest.mark.parametrize("case", FAST)
def test_the_sparse_path_gives_the_dense_step_within_its_tolerance(case, monkeypatch):
    """The same pack (12 × 12 cells, 432 DOF) through either path: each eigenvalue at most
    ``1 / (1 - LANCZOS_TOL)`` above the dense one, so ``dt_c`` at most ``LANCZOS_TOL`` below
    it, never above. With bounded dampers ``dt_c = sqrt(4 - 2 g) / omega``, ``g = h
    gamma'(h)``: ``omega`` at most ``tol/2`` high and ``g`` at most ``g tol`` high, so ``dt_c``
    at most ``tol/2 + g tol / (4 - 2 g)`` below (to first order; twice that allowed)."""
    sim = _probe(case, cells=(12, 12))
    rates = sim.contacts.law.stability_rates()
    dense, _, d = critical_step(sim.contacts, rates)
    monkeypatch.setattr(stable_step, "DENSE_DOF", 0)
    sparse, _, _ = critical_step(sim.contacts, rates)
    tol = LANCZOS_TOL
    if "gamma_bounded" in d:
        g = 2.0 / d["omega"] * d["gamma_bounded"]
        tol = 2.0 * (LANCZOS_TOL / 2 + g * LANCZOS_TOL / (4.0 - 2.0 * g))
    assert dense * (1 - tol) <= sparse <= dense * (1 + 1e-12)


@pytest.mark.slow
def test_a_pack_of_40000_elongated_cells_is_checked_within_one_gigabyte(monkeypatch):
    """20 × 2000 cells of 2000 m × 100 m, bonded: 40 000 elements, 138 000 joints, 120 000
    DOF. The check's own allocations (numpy's, traced) stay under 1 GB (254 MB measured; the
    assembled triplets alone would take about 2 GB) and its answer is the step of the same
    cells' 8 000-element pack within the estimate's tolerance (the stiffest mode is local)."""
    from siku_core.contact import contact_model

    def pack(ny):
        lat = math.degrees(100.0 * ny / R)
        dlon = math.degrees(2000.0 * 20 / R) / math.cos(math.radians(70.0 + lat / 2))
        return contact_scene("distributed_spring", LAWS["distributed_spring"],
                             packs=[{"lon": [10.0, 10.0 + dlon], "lat": [70.0, 70.0 + lat],
                                     "nx": 20, "ny": ny}], dt=1e-3, steps=1, size=100.0)

    small = Simulation(pack(400), out=False, progress=False).critical_dt
    monkeypatch.setattr(contact_model.ContactModel, "stability_limit", lambda self, ctx: None)
    sim = Simulation(pack(2000), out=False, progress=False)
    assert sim.state.n == 40_000
    tracemalloc.start()
    try:
        dt_c, _, _ = critical_step(sim.contacts, sim.contacts.law.stability_rates())
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**30
    assert dt_c == pytest.approx(small, rel=LANCZOS_TOL)
