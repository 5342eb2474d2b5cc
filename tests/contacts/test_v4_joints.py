"""V4 frozen joints under law "distributed_spring" (docs/explanation/physics.md §4.2, §4.3, §8).

A 2 × 1 pack of 2 km cells of 1 m ice (E = 1 GPa) at 60°N: one joint along the shared
meridian edge, of length ``w`` ≈ 2 km, between centres ``L0`` ≈ 2 km apart. The spring has
stiffness ``K`` per unit length (eq. 9, ``K = h1 E1 h2 E2 / (h1 E1 r2 + h2 E2 r1)`` with ``r``
the distances from the centres to the joint midpoint). Integrating a displacement that varies
linearly along the joint gives the force ``K w (s1 + s2)/2`` and the couple
``K (w × (s2 - s1))/12`` (docs/explanation/physics.md §4.3), so

* pulling ``j`` straight away by ``s`` (``s1 = s2 = s``): force ``K w s``, no couple;
* turning ``j`` by ``theta`` about the joint midpoint (``s2 - s1 = theta × w``): couple
  ``K w³ theta / 12`` and no force.

The statics tests open 2 m of water between the cells (``gap = 0.001``; the joint is still
detected within the 10 % tolerance, its ends midway across the gap): turning ``j`` about the
joint midpoint would otherwise push half of its edge into ``i`` and add a collision force. Forces
come from one call of the engine's force evaluation, ``sim.compute_forces``, on a displaced
state.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.geometry.quat import centers, from_tangent, to_tangent
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import (
    contact_forces,
    contact_scene,
    pull_apart,
    rotate_about,
    square_pack,
)

R = 6_371_000.0
SIZE = 2000.0
H, E = 1.0, 1e9
LAT = 60.0


def pair_scene(gap=0.001, dt=0.01, **pack_keys):
    params = pack_keys.pop("params", {})
    return contact_scene(
        "distributed_spring", params,
        packs=[square_pack(20.0, LAT, 2, 1, SIZE, gap=gap, **pack_keys)],
        thickness=H, youngs_modulus=E, dt=dt, steps=1000,
    )


@pytest.fixture(scope="module")
def pair():
    sim = Simulation(pair_scene(), out=False, progress=False)
    cm = sim.contacts
    assert cm.n_joints == 1 and (cm.ji[0], cm.jj[0]) == (0, 1)
    return sim


def joint_K_w(sim) -> tuple[float, float]:
    """``K`` of eq. 9 from h, E and the centre-to-joint-midpoint distances, and ``w``."""
    cm = sim.contacts
    ri = float(np.hypot(*cm.ends_i[0].mean(axis=0)))
    rj = float(np.hypot(*cm.ends_j[0].mean(axis=0)))
    K = H * E * H * E / (H * E * rj + H * E * ri)
    w = float(np.hypot(*(cm.ends_i[0, 1] - cm.ends_i[0, 0])))
    return K, w


def test_joint_geometry(pair):
    cm = pair.contacts
    K, w = joint_K_w(pair)
    # the joint spans the shared edge, shrunk by the gap share; the centres are one cell apart
    assert w == pytest.approx(SIZE * (1 - 0.001), rel=1e-3)
    assert cm.L0[0] == pytest.approx(SIZE, rel=1e-3)
    assert K == pytest.approx(H * E / SIZE, rel=1e-3)
    assert cm.width[0] == pytest.approx(w, rel=1e-12)


def test_pull_apart_force_is_K_w_s(pair):
    """Force ``K w s`` to 1e-6 relative.

    Geometric error: ``j`` is turned about the planet centre by ``s/R``; its joint ends (1 km
    from either centre) move by ``s`` along the sphere and by ``s (1 + O((r/R)²))`` in ``i``'s
    gnomonic plane, and the force acts at the joint midpoint, not at ``j``'s centre, so the
    generalised force differs from it by ``O((r/R)²)`` and ``O(L0 r / R²)``: ~5e-8 in all.
    Round-off in the end positions (``R eps`` ≈ 1.4e-9 m) is 1.4e-8 of ``s`` = 0.1 m.
    Measured: 6.5e-9.
    """
    sim = pair
    st = sim.state
    K, w = joint_K_w(sim)
    s = 0.1  # strain 5e-5, below the default tensile_strain 2e-4
    q = pull_apart(st.q, 0, 1, s, R)
    F = np.zeros_like(st.F)
    T = np.zeros_like(st.T)
    sim.compute_forces(0.0, q, st.V.copy(), st.w.copy(), F, T)
    c = centers(q)
    away_j = -np.array(to_tangent(q[1], c[0], R))
    away_j /= np.linalg.norm(away_j)
    away_i = -np.array(to_tangent(q[0], c[1], R))
    away_i /= np.linalg.norm(away_i)
    expected = K * w * s
    # j is pulled back towards i, i towards j
    assert F[1] @ away_j == pytest.approx(-expected, rel=1e-6)
    assert F[0] @ away_i == pytest.approx(-expected, rel=1e-6)
    # along the line of centres: the other component is zero to the same accuracy
    assert abs(F[1, 0] * away_j[1] - F[1, 1] * away_j[0]) < 1e-6 * expected


@pytest.mark.parametrize("theta", [1e-4, -2e-4])
def test_rotation_about_joint_midpoint_gives_couple_K_w3_theta_over_12(pair, theta):
    """Couple ``K w³ theta / 12`` to 1e-5 relative (the brief asked for 1e-3).

    Linearisation: a planar turn gives ``w × (s2 - s1) = w² sin(theta)``, so the couple is
    ``K w³ sin(theta) / 12``: relative error ``theta²/6`` ≤ 7e-9. The joint force vanishes
    (``s1 + s2 = 0`` for a turn about the midpoint), and the couple acts about the midpoint's
    vertical, which leans from ``j``'s by ``r/R``: ``O((r/R)²)`` ≈ 2.5e-8. Round-off in the end
    positions (~1e-9 m) leaves a force of a few N acting 1 km off the centres: ~1e-7 of the
    couple at theta = 1e-4. Measured: 1.1e-7.
    """
    sim = pair
    st = sim.state
    cm = sim.contacts
    K, w = joint_K_w(sim)
    mid = cm.ends_i[0].mean(axis=0)
    X = from_tangent(st.q[0], mid[0], mid[1], R)  # joint midpoint on the sphere
    q = st.q.copy()
    q[1] = rotate_about(q[1], X, theta)
    F = np.zeros_like(st.F)
    T = np.zeros_like(st.T)
    sim.compute_forces(0.0, q, st.V.copy(), st.w.copy(), F, T)
    # the ends move by |theta| w / 2 <= 0.2 m, less than the 2 m gap: no collision
    expected = K * w**3 * theta / 12
    assert T[1] == pytest.approx(-expected, rel=1e-5)  # restoring on j
    assert T[0] == pytest.approx(expected, rel=1e-5)
    # no net force: |F| << K w |theta| w / 2, the force one end's displacement alone would give
    assert np.abs(F).max() < 1e-6 * K * w * abs(theta) * w / 2


# ------------------------------------------------------------------ breaking

V_PULL = 0.7  # handle speed [m/s]
EPS_T = 2e-5  # tensile strain; L0 eps / v = 57 ms
DTS = (0.002, 0.0007)


def break_scene(dt):
    """Left cell free, right cell a steady handle pulled east at V_PULL; no damping."""
    return pair_scene(
        gap=0.0, dt=dt, right="steady", right_velocity=[V_PULL, 0.0],
        params={"tensile_strain": EPS_T, "joint_damping_ratio": 0.0, "damping_ratio": 0.0},
    )


def run_until_break(dt):
    sim = Simulation(break_scene(dt), out=False, progress=False)
    cm = sim.contacts
    assert cm.n_joints == 1
    for n in range(10_000):
        sim.step()
        if not cm.intact[0]:
            # the step from n to n + 1 evaluated the joint on the state at t = n dt
            return sim, n
    raise AssertionError("the joint never broke")  # pragma: no cover


@pytest.fixture(scope="module")
def breaks():
    return {dt: run_until_break(dt) for dt in DTS}


def lag_bound(sim) -> float:
    """How much later [s] the free cell can make the break: the joint force ``K w s`` with
    ``s ≈ v t`` accelerates it after the handle by ``K w v t³ / (6 m)``, i.e. a delay of
    ``K w t³ / (6 m)`` (~1e-5 s here)."""
    K, w = joint_K_w(sim)
    t_b = sim.contacts.L0[0] * EPS_T / V_PULL
    return K * w * t_b**3 / (6 * sim.state.m[0])


@pytest.mark.parametrize("dt", DTS)
def test_joint_breaks_within_one_step_of_threshold_strain(breaks, dt):
    sim, n = breaks[dt]
    cm = sim.contacts
    t_b = cm.L0[0] * EPS_T / V_PULL
    lag = lag_bound(sim)
    assert lag < 0.02 * dt
    # the break time is not within the lag of a grid time, so "within one step" is sharp
    assert min(t_b / dt % 1.0, 1.0 - t_b / dt % 1.0) > 2 * lag / dt
    # first evaluation at or after the threshold time breaks; the one before held
    assert n == math.ceil(t_b / dt), f"dt = {dt}: broke at step {n}, t_b/dt = {t_b / dt:.3f}"
    assert (n - 1) * dt < t_b <= n * dt
    # history holds the strain that broke it: above the threshold by less than one step's pull
    strain = cm.hist[0, 0]
    assert EPS_T < strain <= EPS_T + V_PULL * dt / cm.L0[0]
    assert cm.n_broken_total == 1


def test_break_is_dt_independent(breaks):
    t = {dt: n * dt for dt, (_, n) in breaks.items()}
    assert abs(t[DTS[0]] - t[DTS[1]]) <= max(DTS)
    # both equal L0 eps / v within their own step
    for dt, (sim, _) in breaks.items():
        t_b = sim.contacts.L0[0] * EPS_T / V_PULL
        assert 0.0 <= t[dt] - t_b < dt


def test_broken_joint_continues_as_collision_contact(breaks):
    """Push the handle back 1 m into the free cell: the broken joint adds nothing, the
    collision law repels with ``K A = K w x`` for a face overlap ``x`` (``K`` with the overlap
    centroid ``x/2`` nearer both centres: +5e-4; the edges of the 2 km cells lean by 3e-4 rad:
    area within 1e-3)."""
    sim, _ = breaks[DTS[0]]
    cm = sim.contacts
    assert not cm.intact[0]
    st = sim.state
    c = centers(st.q)
    sep = R * math.acos(min(1.0, float(c[0] @ c[1])))
    x = 1.0
    q = pull_apart(st.q, 0, 1, -(sep - cm.L0[0]) - x, R)  # faces overlap by x
    F, _ = contact_forces(sim, q, np.zeros_like(st.V), np.zeros_like(st.w))
    away_j = -np.array(to_tangent(q[1], centers(q)[0], R))
    away_j /= np.linalg.norm(away_j)
    K, w = joint_K_w(sim)
    push = F[1] @ away_j
    assert push > 0.0, "no repulsion after the break"
    assert push == pytest.approx(K * w * x, rel=1e-2)
    # with the joint intact (same state), the joint would pull j back in: the repulsion is the
    # collision law's alone
    assert not cm.intact.any()
