"""Law "bonded_particle" (Orzech et al. eqs. 10–13; docs/explanation/contacts.md §4).

Two 100 m square cells of 1 m ice (``E = 1 GPa``, ``nu = 0.3``) at 60°N share one bond along
their common meridian edge, 5 m of open water between them (``gap = 0.05``; the bond is found
within the 10 % tolerance, its ends midway across the gap), so the displaced pair never
collides. For equal cells eq. 9 gives ``K = h E / (r_i + r_j)`` and the bond's stiffness per unit
area ``k_n = K / h = E / D`` with ``D = r_i + r_j`` the centre distance (eq. 12), ``k_s = k_n /
(2 (1 + nu))`` (eq. 13); the section is the joint, ``A = w h``, ``I = h w³ / 12``.

Precision of the engine-level checks: positions are round-off to ``R eps ≈ 1.4e-9 m``, so a
displacement of 5 m (a translation of ``j``) or a turn that moves the bond's ends by ``θ w / 2 ≈
1.9 m`` is known to 1e-9 relative; the projection of ``j``'s points into ``i``'s tangent plane
departs from a planar translation or turn by ``O((r/R)²) ≈ 1e-10`` (``r`` = 50 m). Hence the
1e-9 tolerance.
"""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from siku_core.contact_law import (
    BREAK_SHEAR, BREAK_TENSION, J_AX, J_AY, J_BX, J_BY, J_EI, J_EJ, J_HI, J_HJ, J_K, J_L0,
    J_MEFF, J_NU, J_S1X, J_S1Y, J_S2X, J_S2Y, J_SIZE, J_W,
)
from siku_core.geometry.quat import centers, from_tangent, qmatrix
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import (
    contact_forces, contact_scene, rotate_about, square_pack,
)
from siku_plugins.contact_laws import bond_rotation, bonded_particle_evaluator

R = 6_371_000.0
SIZE = 100.0
H, E, NU = 1.0, 1e9, 0.3
LAT = 60.0
STRONG = {"sigma_crit": 1e12, "tau_crit": 1e12}


# --------------------------------------------------------------------------- the evaluator


def geometry(s1, s2, w=80.0, L0=100.0, K=1e7, h=(1.0, 1.0), angle=0.4):
    """A joint vector: ends ``a, b`` of a joint of length ``w`` [m] along direction ``angle``
    through (30, -20) m, end displacements ``s1, s2`` [m] (in the joint's ``(n, t)`` axes)."""
    g = np.zeros(J_SIZE)
    t = np.array([math.cos(angle), math.sin(angle)])
    n = np.array([t[1], -t[0]])
    m = np.array([30.0, -20.0])
    a, b = m - 0.5 * w * t, m + 0.5 * w * t
    g[J_AX], g[J_AY], g[J_BX], g[J_BY] = *a, *b
    g[J_S1X], g[J_S1Y] = s1[0] * n + s1[1] * t
    g[J_S2X], g[J_S2Y] = s2[0] * n + s2[1] * t
    g[J_L0], g[J_W], g[J_K], g[J_MEFF] = L0, w, K, 1e9
    g[J_HI], g[J_HJ], g[J_EI], g[J_EJ], g[J_NU] = h[0], h[1], 1e9, 1e9, NU
    return g, n, t


def evaluate(g, sigma_crit=1e12, tau_crit=1e12, zeta=0.0):
    out, hist = np.zeros(4), np.zeros(2)
    bonded_particle_evaluator(g, np.array([sigma_crit, tau_crit, zeta]), hist, out)
    return out, hist


def test_evaluator_pull_shear_and_turn_match_eqs_10_to_13():
    """Pure opening ``d_n``, pure sliding ``d_s`` and a turn ``θ`` about the bond point, each on
    its own, against ``F = -A k_n d_n n``, ``-A k_s d_s t`` and ``C = -k_n I θ`` (1e-12)."""
    w, K, h = 80.0, 1e7, 1.0
    kn, ks = K / h, K / h / (2 * (1 + NU))
    A, Ib = w * h, h * w**3 / 12
    g, n, t = geometry((0.3, 0.0), (0.3, 0.0), w=w, K=K)
    out, hist = evaluate(g)
    assert out[:2] == pytest.approx(-A * kn * 0.3 * n, rel=1e-12)
    assert abs(out[2]) < 1e-12 * A * kn * 0.3 * w
    assert hist[0] == pytest.approx(kn * 0.3, rel=1e-12) and hist[1] == 0.0
    g, n, t = geometry((0.0, -0.2), (0.0, -0.2), w=w, K=K)
    out, hist = evaluate(g)
    assert out[:2] == pytest.approx(A * ks * 0.2 * t, rel=1e-12)
    assert hist[1] == pytest.approx(ks * 0.2, rel=1e-12) and hist[0] == pytest.approx(0, abs=1e-6)
    theta = 2e-3
    # a turn by theta about the midpoint: the ends move by ∓(w/2)(1 - cos θ) along t and
    # ±(w/2) sin θ against n (n = -z × t)
    half = 0.5 * w
    g, n, t = geometry((half * math.sin(theta), half * (1 - math.cos(theta))),
                       (-half * math.sin(theta), -half * (1 - math.cos(theta))), w=w, K=K)
    out, hist = evaluate(g)
    assert out[2] == pytest.approx(-kn * Ib * theta, rel=1e-12)
    assert np.abs(out[:2]).max() < 1e-9 * kn * Ib * theta / w
    # normal stress of the bending: the section modulus I / (w/2)
    assert hist[0] == pytest.approx(half * kn * theta, rel=1e-12)


@pytest.mark.parametrize("length", [1.0, 80.0, 5e3])
def test_bond_rotation_is_atan2_to_round_off(length):
    """The bond angle: the series of ``atan`` below ``|x| = 1e-2`` and ``atan2`` above agree
    with ``atan2`` to round-off (two ulps, 4.5e-16 relative: ``atan2`` is good to one, the
    series' remainder ``x¹¹/11`` is 1e-21 relative and its evaluation good to one), on either
    side of the switch, in every quadrant of the joint direction, for a stretched or shortened
    joint."""
    worst = 0.0
    for phi in np.linspace(-3.1, 3.1, 13):
        wx, wy = length * math.cos(phi), length * math.sin(phi)
        for theta in [0.0, 1e-15, -3e-9, 2e-6, -7e-4, 9.99e-3, -1.001e-2, -0.05, 0.7, -2.9]:
            for stretch in (0.97, 1.0, 1.04):
                c, s = math.cos(phi + theta), math.sin(phi + theta)
                Wx, Wy = stretch * length * c, stretch * length * s
                exact = math.atan2(wx * Wy - wy * Wx, wx * Wx + wy * Wy)
                got = bond_rotation(wx, wy, Wx, Wy)
                assert abs(got - theta) <= 1e-9 * abs(theta) + 1e-15
                worst = max(worst, abs(got - exact) / max(abs(exact), 1e-300))
    assert worst <= 4.5e-16


def test_evaluator_breaks_on_either_stress_with_its_mode():
    kn = 1e7
    ks = kn / (2 * (1 + NU))
    g, _, _ = geometry((0.01, 0.0), (0.01, 0.0))
    assert evaluate(g, sigma_crit=kn * 0.01 * (1 + 1e-9))[0][3] == 0.0
    out, _ = evaluate(g, sigma_crit=kn * 0.01 * (1 - 1e-9))
    assert out[3] == BREAK_TENSION and not out[:3].any()
    g, _, _ = geometry((0.0, 0.01), (0.0, 0.01))
    assert evaluate(g, tau_crit=ks * 0.01 * (1 + 1e-9))[0][3] == 0.0
    assert evaluate(g, tau_crit=ks * 0.01 * (1 - 1e-9))[0][3] == BREAK_SHEAR
    # compression does not break a bond (no compressive strength in eqs. 10–11)
    g, _, _ = geometry((-0.05, 0.0), (-0.05, 0.0))
    assert evaluate(g, sigma_crit=1.0)[0][3] == 0.0


def test_unequal_thickness_uses_series_stiffness_on_thinner_section():
    """``k_n A = K w`` (eq. 9's series stiffness, the spring law's) and the stress on the
    thinner side: ``sigma = K d_n / h_min``."""
    K = 2e6
    g, n, _ = geometry((0.1, 0.0), (0.1, 0.0), K=K, h=(0.5, 2.0))
    out, hist = evaluate(g)
    assert out[:2] == pytest.approx(-K * 80.0 * 0.1 * n, rel=1e-12)
    assert hist[0] == pytest.approx(K * 0.1 / 0.5, rel=1e-12)


# --------------------------------------------------------------------------- through the engine


@pytest.fixture(scope="module")
def pair():
    scene = contact_scene("bonded_particle", STRONG,
                          packs=[square_pack(20.0, LAT, 2, 1, SIZE, gap=0.05)],
                          thickness=H, youngs_modulus=E, poisson_ratio=NU, dt=0.002, steps=10)
    sim = Simulation(scene, out=False, progress=False)
    assert sim.contacts.n_joints == 1
    return sim


def bond_constants(sim):
    cm = sim.contacts
    ri = float(np.hypot(*cm.ends_i[0].mean(axis=0)))
    rj = float(np.hypot(*cm.ends_j[0].mean(axis=0)))
    K = H * E / (ri + rj)
    w = float(cm.width[0])
    tv = (cm.ends_i[0, 1] - cm.ends_i[0, 0]) / w
    return K / H, w, tv, np.array([tv[1], -tv[0]])


def move_j(sim, direction_i, s):
    """``q`` with ``j`` carried by ``s`` [m] along the unit vector ``direction_i`` of ``i``'s
    tangent plane (a rotation about the axis through the planet centre normal to it)."""
    q = sim.state.q.copy()
    c = centers(q)
    u = qmatrix(q[0]) @ np.array([*direction_i, 0.0])
    q[1] = rotate_about(q[1], np.cross(c[1], u), s / R)
    return q


def generalised(q, k, point_i, f_i, couple):
    """Generalised force and torque on element ``k`` of a force ``f_i`` (``i``'s frame) at
    ``i``-frame point ``point_i`` plus a couple about the vertical there (torque about the
    planet centre in ``k``'s body frame: ``Fx = tau_y / R``, ``Fy = -tau_x / R``)."""
    X = from_tangent(q[0], *point_i, R)
    X = X / np.linalg.norm(X)
    fg = qmatrix(q[0]) @ np.array([*f_i, 0.0])
    tau = R * np.cross(X, fg) + couple * X
    tb = qmatrix(q[k]).T @ tau
    return np.array([tb[1] / R, -tb[0] / R]), tb[2]


@pytest.mark.parametrize("kind", ["pull", "shear"])
def test_engine_bond_force_matches_formula(pair, kind):
    """Opening by 5 m (``F = A k_n d_n``) or sliding by 5 m along the joint (``A k_s d_s``): the
    generalised force and torque on both elements, force at the bond point, to 1e-9.

    The round-off of the bond's ends (``R eps ≈ 1.4e-9 m``) acts through the stiffer normal
    spring, ``k_n A ≈ 9.5e8 N/m``: about 1.3 N, 7e-10 of the 1.8e9 N sliding force (at 2 m it
    would be 1.8e-9, measured 1.5e-9)."""
    sim = pair
    kn, w, tv, nv = bond_constants(sim)
    ks = kn / (2 * (1 + NU))
    s = 5.0
    A = w * H
    q = move_j(sim, nv if kind == "pull" else tv, s)
    F, T = contact_forces(sim, q)
    f_on_j = -A * (kn * s * nv if kind == "pull" else ks * s * tv)
    m = sim.contacts.ends_i[0].mean(axis=0)
    Fj, Tj = generalised(q, 1, m, f_on_j, 0.0)
    Fi, Ti = generalised(q, 0, m, -f_on_j, 0.0)
    scale = np.linalg.norm(f_on_j)
    assert np.linalg.norm(F[1] - Fj) <= 1e-9 * scale
    assert np.linalg.norm(F[0] - Fi) <= 1e-9 * scale
    assert abs(T[1] - Tj) <= 1e-9 * scale * SIZE and abs(T[0] - Ti) <= 1e-9 * scale * SIZE


def test_engine_bond_couple_matches_formula(pair):
    """``j`` turned by 0.04 rad about the bond point: couple ``k_n I θ`` (``I = h w³/12``) on
    both to 1e-9, and no force beyond round-off."""
    sim = pair
    kn, w, _, _ = bond_constants(sim)
    theta = 0.04
    q = sim.state.q.copy()
    m = sim.contacts.ends_i[0].mean(axis=0)
    axis = from_tangent(q[0], *m, R)
    q[1] = rotate_about(q[1], axis, theta)
    F, T = contact_forces(sim, q)
    C = kn * H * w**3 / 12 * theta
    assert T[1] == pytest.approx(-C, rel=1e-9)
    assert T[0] == pytest.approx(C, rel=1e-9)
    # no force beyond the round-off of the ends through the normal spring, k_n A R eps ≈ 1.3 N
    # (measured 1.0 N; the couple's force scale C / w is 3.0e8 N)
    assert np.abs(F).max() <= 4 * kn * w * H * R * np.finfo(float).eps
    # the stress it leaves: the bending term (w/2) k_n θ
    sim.contacts.add(0.0, q, sim.state.V, sim.state.w, np.zeros((2, 2)), np.zeros(2), False)
    assert sim.contacts.hist[0, 0] == 0.0  # history changes only when committed


def test_momentum_and_angular_momentum_conserved(tmp_path):
    """Two free bonded cells moving apart and spinning, damped bond: the pair's angular
    momentum about the planet centre (which holds its linear momentum) is conserved at every
    step to round-off (1e-12 relative over 400 steps)."""
    scene = contact_scene("bonded_particle", {"joint_damping_ratio": 0.3, **STRONG},
                          packs=[square_pack(20.0, LAT, 2, 1, SIZE, gap=0.05)],
                          thickness=H, youngs_modulus=E, poisson_ratio=NU, dt=0.002, steps=400)
    sim = Simulation(scene, out=False, progress=False)
    sim.state.V[:] = [[0.05, -0.02], [-0.03, 0.04]]
    sim.state.w[:] = [2e-4, -1e-4]

    def L(s):
        d = s.diagnostics()
        return np.array([d[f"angular_momentum_{a}"] for a in "xyz"])

    L0 = L(sim)
    worst = 0.0
    for _ in range(400):
        sim.step()
        worst = max(worst, float(np.linalg.norm(L(sim) - L0) / np.linalg.norm(L0)))
    assert sim.contacts.n_intact == 1
    assert worst < 1e-12


# --------------------------------------------------------------------------- breaking in a run

V_PULL = 0.01  # m/s
STRENGTH = 1e5  # Pa


def break_scene(direction: str, dt: float) -> str:
    """A steady cell (west) moving west (``"tension"``) or north (``"shear"``) at 1 cm/s, bonded
    to a free cell so heavy (density 1e9 kg/m³) that it stays put: the bond's stress rises as
    ``k_n v t`` or ``k_s v t``. No bond damping: a share of critical damping on the heavy cell's
    mass would drag it along with the handle."""
    v = [-V_PULL, 0.0] if direction == "tension" else [0.0, V_PULL]
    west = square_pack(20.0, LAT, 1, 1, SIZE, gap=0.05)
    east = square_pack(west["lon"][1], LAT, 1, 1, SIZE, gap=0.05)
    return f"""
[time]
dt = {dt!r}
duration = 4.0
[materials.ice]
youngs_modulus = {E!r}
poisson_ratio = {NU!r}
[materials.heavy]
youngs_modulus = {E!r}
poisson_ratio = {NU!r}
density = 1e9
[elements]
thickness = {H!r}
[[elements.pack]]
lon = {west["lon"]!r}
lat = {west["lat"]!r}
nx = 1
ny = 1
gap = 0.05
flag = "steady"
velocity = {v!r}
[[elements.pack]]
lon = {east["lon"]!r}
lat = {east["lat"]!r}
nx = 1
ny = 1
gap = 0.05
material = "heavy"
[contact]
law = "bonded_particle"
params = {{ sigma_crit = {STRENGTH!r}, tau_crit = {STRENGTH!r}, joint_damping_ratio = 0.0 }}
[output]
every = "1s"
"""


@pytest.mark.parametrize("direction", ["tension", "shear"])
@pytest.mark.parametrize("dt", [0.01, 0.023])
def test_bond_breaks_within_one_step_of_critical_stress(tmp_path, direction, dt):
    """The bond breaks at the first step whose state carries more than the critical stress:
    ``t_crit < t_break <= t_crit + dt`` with ``t_crit = sigma_crit / (k_n v)`` (tension) or
    ``tau_crit / (k_s v)`` (shear); the free cell moves by ~1e-6 of the imposed displacement
    (its acceleration is ``k A d / m`` with ``m = 9e12 kg``), far below ``v dt``. The break is
    in the output with its time, pair, place and mode."""
    out = tmp_path / "b.h5"
    sim = Simulation(scene_from_text(break_scene(direction, dt)), out=out, progress=False)
    cm = sim.contacts
    assert cm.n_joints == 1
    kn, _, _, _ = bond_constants(sim)
    k = kn if direction == "tension" else kn / (2 * (1 + NU))
    t_crit = STRENGTH / (k * V_PULL)
    sim.run()
    assert cm.n_intact == 0
    t_break = float(cm.break_time[0])
    assert t_crit < t_break <= t_crit + dt * (1 + 1e-6)
    with h5py.File(out, "r") as f:
        b = f["breaks"]
        assert b["time"][:].tolist() == [t_break]
        assert (b["i"][0], b["j"][0]) == (0, 1)
        mode = int(b["mode"][0])
        assert b.attrs[f"mode_{mode}"] == direction
        assert mode == (BREAK_TENSION if direction == "tension" else BREAK_SHEAR)
        # the bond point lies between the two cells
        c = centers(sim.state.q)
        mid = (c[0] + c[1]) / np.linalg.norm(c[0] + c[1])
        assert b["lat"][0] == pytest.approx(math.degrees(math.asin(mid[2])), abs=1e-3)
        d = f["diagnostics"]
        assert d[f"joints_broken_{direction}"][-1] == 1


def test_breaks_restart_bit_for_bit(tmp_path):
    """A run stopped after a snapshot that holds its break and restarted from it ends with the
    same breaks table (the break once) and the same final state as the run in one go."""
    text = break_scene("tension", 0.01)
    whole = tmp_path / "whole.h5"
    Simulation(scene_from_text(text), out=whole, progress=False).run()
    part = tmp_path / "part.h5"
    sim = Simulation(scene_from_text(text), out=part, progress=False)
    sim.run(steps=250)  # snapshots at 1 s and 2 s; the break (t_crit = 1.3 s) in between
    sim2 = Simulation(scene_from_text(text), out=part, progress=False, restart=part)
    sim2.run()
    with h5py.File(whole, "r") as a, h5py.File(part, "r") as b:
        for k in ("time", "i", "j", "mode", "joint"):
            assert np.array_equal(a["breaks"][k][:], b["breaks"][k][:])
        assert np.array_equal(a["states"]["q"][-1], b["states"]["q"][-1])


def test_joint_broken_from_outside_the_law_carries_no_force_and_is_recorded(tmp_path):
    """``ContactModel.break_joints`` (the interface for components other than the law, e.g.
    wave-induced breaking): the pulled bond's force disappears from the next evaluation, the
    break is stamped with mode ``external`` and its time, once, and reaches ``/breaks``."""
    from siku_core.contact_law import BREAK_EXTERNAL

    sim = Simulation(scene_from_text(break_scene("tension", 0.01)), out=tmp_path / "x.h5",
                     progress=False)
    cm = sim.contacts
    sim.run(steps=50)  # t = 0.5 s: pulled by 5 mm, below the strength
    F, _ = contact_forces(sim)
    assert np.abs(F[1]).max() > 0
    assert cm.break_joints(np.array([0]), BREAK_EXTERNAL, sim.time) == 1
    assert cm.break_joints(np.array([0]), BREAK_EXTERNAL, sim.time) == 0  # already broken
    F, _ = contact_forces(sim)
    assert not F.any()
    assert cm.break_mode[0] == BREAK_EXTERNAL and cm.break_time[0] == pytest.approx(0.5)
    sim.run()
    with h5py.File(tmp_path / "x.h5", "r") as f:
        b = f["breaks"]
        assert b["mode"][:].tolist() == [int(BREAK_EXTERNAL)]
        assert b.attrs["mode_5"] == "external"
        assert f["diagnostics"]["joints_broken_external"][-1] == 1
