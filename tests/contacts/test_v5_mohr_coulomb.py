"""V5 Mohr–Coulomb joints (docs/explanation/physics.md §4.3 "mohr_coulomb", §8, Table 1).

The joint evaluator is called directly on hand-built geometry vectors (layout ``J_*`` of
:mod:`siku_core.contact.contact_forces`): a joint from ``a = (1000, -1000)`` to ``b = (1000, 1000)``
m in
``i``'s frame (tangent ``t = (0, 1)``, normal ``n = (1, 0)`` out of ``i``), ``L0`` = 2 km. A
uniform displacement ``d`` of ``j`` gives in every segment ``sigma_n = E d·n / L0`` (tension
positive) and ``sigma_s = G d·t / L0``, ``G = E / (2 (1 + nu))``. Loads grow in steps of 0.1 %
of the expected failure stress (offset by half a step, so no step lands on the threshold
itself, where round-off decides), so the first failing step lies at most 0.1 % beyond it; the
tests require 1 %. Then the same through the engine: a 2 × 1 pack pulled apart.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.contact_law import (
    BREAK_COMPRESSION, BREAK_SHEAR, BREAK_TENSION,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_DT,
    J_EI,
    J_EJ,
    J_HI,
    J_HJ,
    J_K,
    J_L0,
    J_MEFF,
    J_NU,
    J_S1X,
    J_S1Y,
    J_S2X,
    J_S2Y,
    J_SIZE,
    J_W,
)
from siku_core.geometry.quat import centers, to_tangent
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import (
    contact_forces,
    contact_scene,
    pull_apart,
    square_pack,
)
from siku_plugins.contact_laws import MohrCoulomb, mohr_coulomb_evaluator

E, NU, L0, W = 1e9, 0.3, 2000.0, 2000.0
G = E / (2 * (1 + NU))
STEP = 1e-3  # load increment, share of the expected failure stress


def law_pars(**params) -> np.ndarray:
    law = MohrCoulomb({**{k: p.default for k, p in MohrCoulomb.params.items()}, **params})
    return np.ascontiguousarray(law.joint_parameters(), dtype=float)


def geometry(s1, s2, h=(1.0, 1.0), e=(E, E), ri=1000.0) -> np.ndarray:
    """The joint at ``x = ri`` in ``i``'s frame (``ri`` from ``i``'s centre, ``L0 - ri`` from
    ``j``'s)."""
    g = np.zeros(J_SIZE)
    g[J_S1X], g[J_S1Y] = s1
    g[J_S2X], g[J_S2Y] = s2
    g[J_AX], g[J_AY], g[J_BX], g[J_BY] = ri, -1000.0, ri, 1000.0
    g[J_L0], g[J_W] = L0, W
    g[J_K] = h[0] * e[0] * h[1] * e[1] / (h[0] * e[0] * (L0 - ri) + h[1] * e[1] * ri)
    g[J_MEFF] = 1.8e9
    g[J_HI], g[J_HJ] = h
    g[J_EI], g[J_EJ] = e
    g[J_NU] = NU
    g[J_DT] = 0.1
    return g


def evaluate(pars, hist, s1, s2, h=(1.0, 1.0), e=(E, E), ri=1000.0):
    out = np.zeros(4)
    mohr_coulomb_evaluator(geometry(s1, s2, h, e, ri), pars, hist, out)
    return out


def series_he(h, e, ri=1000.0) -> float:
    """``(h E)_eff``: strips of ``i`` (length ``ri``) and ``j`` (``L0 - ri``) in series, as
    ``L0`` times eq. 9's ``K``."""
    a, b = h[0] * e[0], h[1] * e[1]
    return a * b * L0 / (a * (L0 - ri) + b * ri)


def sigma_c_default(h_min: float) -> float:
    """Table 1: 1285 h^(2/3) kPa, h in m."""
    return 1285e3 * h_min ** (2.0 / 3.0)


def first_failure(pars, path, n_max=3000, h=(1.0, 1.0), hist=None, e=(E, E)):
    """Apply ``path(k) -> (s1, s2)`` for k = 1, 2, ...; return the first k where a segment
    fails, with the history and the output of that evaluation."""
    nseg = int(pars[3])
    hist = np.zeros(nseg) if hist is None else hist
    for k in range(1, n_max + 1):
        out = evaluate(pars, hist, *path(k), h=h, e=e)
        if hist.any():
            return k, hist, out
    raise AssertionError("no failure")  # pragma: no cover


def normal_disp(sigma_n: float) -> float:
    return sigma_n * L0 / E


def load(k: int, target: float) -> float:
    """Load step ``k`` (1, 2, ...) towards ``target``: ``(k - 1/2) STEP target``."""
    return (k - 0.5) * STEP * target


def uniform_normal(target: float, modulus: float = E):
    """Path: both ends displaced normally, stress ``modulus d / L0`` rising to and past
    ``target`` [Pa]."""
    return lambda k: ((load(k, target) * L0 / modulus, 0.0),) * 2


def test_pure_tension_fails_at_sigma_t():
    pars = law_pars()
    sig_t = 0.1 * sigma_c_default(1.0)
    k, hist, out = first_failure(pars, uniform_normal(sig_t))
    sigma = load(k, sig_t)
    assert sigma == pytest.approx(sig_t, rel=0.01)
    assert sig_t < sigma <= sig_t * (1 + STEP)
    # uniform load: every segment fails at once and the joint breaks, in tension
    assert hist.all() and out[3] == BREAK_TENSION


def test_pure_compression_fails_at_sigma_c():
    pars = law_pars()
    sig_c = sigma_c_default(1.0)
    k, hist, out = first_failure(pars, uniform_normal(-sig_c))
    sigma = -load(k, -sig_c)
    assert sigma == pytest.approx(sig_c, rel=0.01)
    assert sig_c < sigma <= sig_c * (1 + STEP)
    assert hist.all() and out[3] == BREAK_COMPRESSION


@pytest.mark.parametrize(("h", "e", "ri"), [
    ((1.0, 1.0), (E, E), 1000.0),
    ((1.0, 3.0), (E, E), 1000.0),
    ((3.0, 1.0), (E, E), 1000.0),
    ((0.05, 10.0), (E, E), 1000.0),
    ((1.0, 1.0), (E, 4 * E), 1000.0),
    ((2.0, 0.5), (0.25 * E, 4 * E), 1000.0),
    ((1.0, 3.0), (E, 2 * E), 500.0),
    ((1.0, 3.0), (E, 2 * E), 1500.0),
    ((2.0, 1.0), (E, 2 * E), 700.0),
], ids=["same", "thick-j", "thick-i", "5cm-10m", "stiff-j", "thin-stiff-j", "near-i", "far-i",
        "equal-hE"])
def test_intact_joint_force_is_segment_sum(h, e, ri):
    """Below failure: force on ``j`` ``-(h E)_eff (d_n n + (G/E) d_t t) w / L0`` (uniform
    displacement), no couple. ``(h E)_eff`` is the series combination of the two sides,
    ``L0`` times eq. 9's ``K`` (the spring law's and the dt estimate's stiffness), ``h E`` for
    identical cells."""
    pars = law_pars(sigma_c=1e12)
    he = series_he(h, e, ri)
    d = np.array([1e-3, 2e-3])
    out = evaluate(pars, np.zeros(10), d, d, h=h, e=e, ri=ri)
    expected = -he * W * np.array([d[0], d[1] / (2 * (1 + NU))]) / L0
    assert out[3] == 0.0
    np.testing.assert_allclose(out[:2], expected, rtol=1e-12)
    assert abs(out[2]) < 1e-9 * abs(expected[0]) * W
    g = geometry(d, d, h, e, ri)
    assert out[0] == pytest.approx(-g[J_K] * W * d[0], rel=1e-12)  # normal stiffness K w
    if h[0] == h[1] and e[0] == e[1]:
        assert he == pytest.approx(h[0] * e[0], rel=1e-15)


@pytest.mark.parametrize(("h", "e", "ri"), [
    ((0.05, 10.0), (E, E), 1000.0),
    ((3.0, 1.0), (E, 2 * E), 1000.0),
    ((1.0, 3.0), (4 * E, E), 1500.0),
    ((2.0, 1.0), (E, 2 * E), 700.0),
], ids=["5cm-10m", "thin-j", "far-i", "equal-hE"])
def test_mixed_joint_fails_at_the_thinner_sides_stress(h, e, ri):
    """The traction ``(h E)_eff d / L0`` is the same on both sides; the stress is largest on
    the thinner, ``sigma = (h E)_eff d / (h_min L0)``, and the joint fails in tension when that
    reaches the Table 1 ``sigma_t`` of ``h_min``."""
    pars = law_pars()
    hmin = min(h)
    sig_t = 0.1 * sigma_c_default(hmin)
    e_s = series_he(h, e, ri) / hmin
    nseg = int(pars[3])
    hist = np.zeros(nseg)
    for k in range(1, 3000):
        out = evaluate(pars, hist, *uniform_normal(sig_t, e_s)(k), h=h, e=e, ri=ri)
        if hist.any():
            break
    assert sig_t < load(k, sig_t) <= sig_t * (1 + STEP)
    assert hist.all() and out[3] == BREAK_TENSION


@pytest.mark.parametrize("confinement", [0.5, -0.2, -0.6],
                         ids=["tension 0.5 sigma_t", "-0.2 sigma_c", "-0.6 sigma_c"])
def test_shear_under_confinement_fails_on_mohr_coulomb_envelope(confinement):
    pars = law_pars()
    sig_c = sigma_c_default(1.0)
    sig_t = 0.1 * sig_c
    tan_phi = math.tan(math.radians(15.0))  # Table 1 default
    sigma_n = confinement * (sig_t if confinement > 0 else sig_c)
    tau_f = tan_phi * (sig_t - sigma_n)
    hist = np.zeros(10)
    # confine first (in 100 increments): nothing fails
    for k in range(1, 101):
        evaluate(pars, hist, *((normal_disp(sigma_n * k / 100), 0.0),) * 2)
    assert not hist.any()
    dn = normal_disp(sigma_n)

    def path(k):
        return ((dn, load(k, tau_f) * L0 / G),) * 2

    k, hist, out = first_failure(pars, path, hist=hist)
    assert out[3] == BREAK_SHEAR  # uniform: every segment fails at once, on the envelope
    tau = load(k, tau_f)
    assert tau == pytest.approx(tau_f, rel=0.01)
    assert tau_f < tau <= tau_f * (1 + STEP)
    # the opposite shear sense fails at the same stress
    hist2 = np.zeros(10)
    for m in range(1, 101):
        evaluate(pars, hist2, *((normal_disp(sigma_n * m / 100), 0.0),) * 2)
    k2, _, _ = first_failure(pars, lambda m: tuple((a, -b) for a, b in path(m)), hist=hist2)
    assert k2 == k


@pytest.mark.parametrize("h", [(2.0, 3.0), (0.5, 0.5)])
def test_table1_default_compressive_strength(h):
    """``sigma_c = 1285 h_min^(2/3)`` kPa and ``sigma_t = 0.1 sigma_c`` when sigma_c is 0."""
    assert MohrCoulomb.params["sigma_c"].default == 0.0
    assert MohrCoulomb.params["tensile_ratio"].default == 0.1
    assert MohrCoulomb.params["friction_angle"].default == 15.0
    pars = law_pars()
    sig_c = sigma_c_default(min(h))
    if h == (2.0, 3.0):
        assert sig_c == pytest.approx(2.0398e6, rel=1e-4)
    # the thinner side's stress (h E)_eff d / (h_min L0) (E for equal cells); failure at the
    # h_min strength
    e_s = series_he(h, (E, E)) / min(h)
    k, _, _ = first_failure(pars, uniform_normal(-sig_c, e_s), h=h)
    assert load(k, sig_c) == pytest.approx(sig_c, rel=0.01)
    k, _, _ = first_failure(pars, uniform_normal(0.1 * sig_c, e_s), h=h)
    assert load(k, 0.1 * sig_c) == pytest.approx(0.1 * sig_c, rel=0.01)


def segment_z(nseg):
    return (np.arange(nseg) + 0.5) / nseg


def test_non_uniform_displacement_fails_segments_progressively():
    """End ``a`` held, end ``b`` pulled: ``sigma_n(z) = E z s2 / L0`` fails segment ``k``
    (centre ``z_k``) at ``s2 = sigma_t L0 / (E z_k)``: from ``b``'s end towards ``a``'s, one at
    a time; the joint breaks only with the last one (break_share = 1)."""
    pars = law_pars()
    sig_t = 0.1 * sigma_c_default(1.0)
    z = segment_z(10)
    s2_fail = sig_t * L0 / (E * z)  # per segment
    hist = np.zeros(10)
    ds = s2_fail.min() * STEP
    order = []
    for k in range(1, 20_000):
        s2 = (k - 0.5) * ds
        before = hist.copy()
        out = evaluate(pars, hist, (0.0, 0.0), (s2, 0.0))
        new = np.flatnonzero(hist != before)
        for seg in new:
            order.append(int(seg))
            assert s2 == pytest.approx(s2_fail[seg], rel=0.01)
            assert s2_fail[seg] < s2 <= s2_fail[seg] + ds
        assert len(new) <= 1
        if out[3]:
            break
        # intact segments carry h sigma_n(z) w / n each, at their centres
        intact = hist == 0
        fx = -np.sum(E * z[intact] * s2 / L0) * 1.0 * W / 10
        assert out[0] == pytest.approx(fx, rel=1e-12, abs=1e-6)
    assert order == list(range(9, -1, -1))
    assert hist.all()


def test_break_share_breaks_joint_when_share_of_segments_failed():
    pars = law_pars(break_share=0.5)
    sig_t = 0.1 * sigma_c_default(1.0)
    z = segment_z(10)
    hist = np.zeros(10)
    ds = sig_t * L0 / E * STEP
    for k in range(1, 20_000):
        out = evaluate(pars, hist, (0.0, 0.0), ((k - 0.5) * ds, 0.0))
        nfailed = int(hist.sum())
        assert (out[3] == BREAK_TENSION) == (nfailed >= 5), (
            f"{nfailed} failed, break flag {out[3]}")
        if out[3]:
            break
    assert nfailed == 5
    # the failed ones are the five nearest to b
    assert hist.tolist() == [0.0] * 5 + [1.0] * 5
    assert (k - 0.5) * ds == pytest.approx(sig_t * L0 / (E * z[5]), rel=0.01)


def test_failed_segments_stay_failed():
    pars = law_pars()
    sig_t = 0.1 * sigma_c_default(1.0)
    hist = np.zeros(10)
    s2 = 1.5 * sig_t * L0 / E  # fails segments with z > 1/1.5
    evaluate(pars, hist, (0.0, 0.0), (s2, 0.0))
    failed = hist.copy()
    assert 0 < failed.sum() < 10
    out = evaluate(pars, hist, (0.0, 0.0), (0.0, 0.0))  # unloaded
    assert np.array_equal(hist, failed) and out[3] == 0.0
    # reloaded in compression: failed segments carry nothing
    out = evaluate(pars, hist, (-0.01, 0.0), (-0.01, 0.0))
    intact = int((hist == 0).sum())
    assert out[0] == pytest.approx(1.0 * E * 0.01 / L0 * W * intact / 10, rel=1e-12)


# ------------------------------------------------------------------ through the engine

R = 6_371_000.0


@pytest.fixture(scope="module")
def engine_pair():
    scene = contact_scene("mohr_coulomb", {"joint_damping_ratio": 0.0},
                          packs=[square_pack(20.0, 60.0, 2, 1, 2000.0, gap=0.001)],
                          thickness=1.0, youngs_modulus=E, poisson_ratio=NU, dt=0.01, steps=10)
    sim = Simulation(scene, out=False, progress=False)
    assert sim.contacts.n_joints == 1
    return sim


def test_engine_pulled_pair_force(engine_pair):
    """Pull ``j`` away by ``d``: force ``h E w d / L0`` on each, to 1e-6 (geometric error of
    the projection O((r/R)²) ~ 5e-8, as in V4)."""
    sim = engine_pair
    cm = sim.contacts
    d = normal_disp(50e3)
    q = pull_apart(sim.state.q, 0, 1, d, R)
    F, _ = contact_forces(sim, q)
    w = cm.width[0]
    away = -np.array(to_tangent(q[1], centers(q)[0], R))
    away /= np.linalg.norm(away)
    assert F[1] @ away == pytest.approx(-1.0 * E * w * d / cm.L0[0], rel=1e-6)
    assert not cm.hist.any()


def test_engine_pulled_pair_fails_at_sigma_t(engine_pair):
    sim = engine_pair
    cm = sim.contacts
    sig_t = 0.1 * sigma_c_default(1.0)
    L = cm.L0[0]
    for k in range(1, 3000):
        d = load(k, sig_t) * L / E
        contact_forces(sim, pull_apart(sim.state.q, 0, 1, d, R), commit=True)
        if not cm.intact[0]:
            break
    sigma = E * d / L
    assert sigma == pytest.approx(sig_t, rel=0.01)
    assert cm.hist[0].all()
    # broken: no joint force any more, and apart there is no collision either
    F, T = contact_forces(sim, pull_apart(sim.state.q, 0, 1, 0.5 * d, R))
    assert not F.any() and not T.any()


def _segment_loop(g, pars, hist):
    """Eqs. 14–16 segment by segment, as written in the evaluator's docstring: the reference
    for the evaluator's closed form of an intact joint."""
    nseg = int(pars[3])
    L0_, w = g[J_L0], g[J_W]
    hi, hj, ei, ej = g[J_HI], g[J_HJ], g[J_EI], g[J_EJ]
    a, b = hi * ei, hj * ej
    mx2, my2 = g[J_AX] + g[J_BX], g[J_AY] + g[J_BY]
    lam = min(max(0.5 * np.hypot(mx2, my2) / L0_, 0.0), 1.0)
    he = a * b / (lam * b + (1 - lam) * a)
    h = min(hi, hj)
    e = he / h
    gs = e / (2 * (1 + g[J_NU]))
    sigc = pars[0] if pars[0] > 0 else 1285e3 * h ** (2 / 3)
    sigt = pars[1] * sigc
    ax, ay, bx, by = g[J_AX], g[J_AY], g[J_BX], g[J_BY]
    t = np.array([bx - ax, by - ay]) / w
    n = np.array([t[1], -t[0]])
    s1, s2 = np.array([g[J_S1X], g[J_S1Y]]), np.array([g[J_S2X], g[J_S2Y]])
    f, c, failed = np.zeros(2), 0.0, 0
    for k in range(nseg):
        z = (k + 0.5) / nseg
        d = s1 + z * (s2 - s1)
        sn, ss = e * d @ n / L0_, gs * d @ t / L0_
        if hist[k] == 0 and (sn > sigt or sn < -sigc or abs(ss) > pars[2] * (sigt - sn)):
            hist[k] = 1.0
        if hist[k]:
            failed += 1
            continue
        sf = h * (w / nseg) * (sn * n + ss * t)
        p = (z - 0.5) * w * t
        f += sf
        c += p[0] * sf[1] - p[1] * sf[0]
    return f, c, failed


def test_the_closed_form_of_an_intact_joint_is_the_segment_sum():
    """An intact joint far enough from failure is evaluated from its end segments in closed
    form (the stresses are linear along the joint): the same force and couple as the segment
    loop to 1e-12 relative, on random displacements of every kind (uniform, linear, bending,
    near and beyond the strengths), and the same segments fail."""
    rng = np.random.default_rng(11)
    closed = 0
    for _ in range(3000):
        nseg = int(rng.integers(1, 17))
        pars = law_pars(sigma_c=float(10 ** rng.uniform(5, 7)), n_segments=nseg,
                        joint_damping_ratio=0.0)
        h = tuple(rng.uniform(0.2, 3.0, 2))
        e = tuple(rng.uniform(0.5, 4.0, 2) * E)
        scale = 10 ** rng.uniform(-4, 0) * float(pars[0]) * L0 / E
        s1, s2 = rng.normal(0, scale, 2), rng.normal(0, scale, 2)
        g = geometry(s1, s2, h, e, float(rng.uniform(600, 1400)))
        hist_ref = np.zeros(nseg)
        f, c, failed = _segment_loop(g, pars, hist_ref)
        hist = np.zeros(nseg)
        out = np.zeros(4)
        mohr_coulomb_evaluator(g, pars, hist, out)
        assert np.array_equal(hist, hist_ref)
        if out[3] != 0.0:
            assert failed >= nseg - 1e-9
            continue
        closed += failed == 0
        fs = max(np.abs(f).max(), 1e-300)
        np.testing.assert_allclose(-out[:2], f, rtol=0, atol=1e-12 * fs)
        assert abs(-out[2] - c) <= 1e-12 * fs * W
    assert closed > 1000  # the closed form was exercised, not only the loop
