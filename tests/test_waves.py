"""Waves on ice (``siku_forcing.waves.wave_field``, ``siku_forcing.waves.wave_breaking``):
dispersion, the fields against linear theory, a free floe in waves against an independent
integration, the averaging of the slope force over a bonded floe, and wave-induced breaking."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from siku_core.geometry.quat import east_north_local, latlon_of
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene
from siku_forcing.waves.wave_field import Jonswap, LinearWave, jonswap, log_layer_drag, wavenumber

R = 6_371_000.0
G = 9.81


def field(cls, **params):
    f = cls({**{k: p.default for k, p in cls.params.items()}, **params})
    f._build()
    return f


# ----------------------------------------------------------------------------- dispersion
@pytest.mark.parametrize("period,depth", [(8.0, 4000.0), (8.0, 15.0), (20.0, 2.0),
                                          (4.0, 1e5), (12.0, 0.05)])
def test_dispersion_to_1e12(period, depth):
    omega = 2 * math.pi / period
    k = wavenumber(omega, depth)
    assert abs(G * k * math.tanh(k * depth) - omega**2) <= 1e-12 * omega**2
    ref = brentq(lambda x: G * x * math.tanh(x * depth) - omega**2, 1e-12, 10 * omega**2 / G
                 + 10 * omega / math.sqrt(G * depth), xtol=1e-300, rtol=1e-15, maxiter=500)
    assert k == pytest.approx(ref, rel=1e-12)


def test_dispersion_limits():
    omega = 2 * math.pi / 10.0
    assert wavenumber(omega, math.inf) == omega**2 / G
    # deep water: tanh(kh) = 1 - 2e^{-2kh}; shallow: x tanh x = y gives x = sqrt(y) (1 + y/6
    # + O(y²)), y = omega² h / g = (c0 h)²: the series to within y²
    assert wavenumber(omega, 1e4) == pytest.approx(omega**2 / G, rel=1e-14)
    h = 0.01
    c0 = omega / math.sqrt(G * h)
    assert wavenumber(omega, h) == pytest.approx(c0 * (1 + (c0 * h) ** 2 / 6), rel=(c0 * h) ** 4)


# ----------------------------------------------------------------------------- fields
def test_linear_wave_against_formulas():
    a, T, h, direction, phase = 0.7, 9.0, 30.0, 60.0, 25.0
    f = field(LinearWave, amplitude=a, period=T, depth=h, direction=direction, phase=phase,
              origin=[10.0, 0.0])
    omega = 2 * math.pi / T
    k = wavenumber(omega, h)
    kx, ky = k * math.sin(math.radians(direction)), k * math.cos(math.radians(direction))
    rng = np.random.default_rng(1)
    lon = math.radians(10.0) + rng.uniform(-2e-5, 2e-5, 50)
    lat = rng.uniform(-2e-5, 2e-5, 50)
    t = 3.3
    x = R * (lon - math.radians(10.0))
    y = R * lat
    psi = kx * x + ky * y - omega * t + math.radians(phase)
    r = f.evaluate(t, lat, lon)
    m = 1.0 / np.cos(lat)  # east derivative metric at the origin latitude 0
    np.testing.assert_allclose(r["eta"], a * np.cos(psi), rtol=0, atol=1e-13)
    np.testing.assert_allclose(r["eta_e"], -a * kx * m * np.sin(psi), rtol=0, atol=1e-14)
    np.testing.assert_allclose(r["eta_n"], -a * ky * np.sin(psi), rtol=0, atol=1e-14)
    U = a * omega * math.cosh(k * h) / math.sinh(k * h)
    np.testing.assert_allclose(r["u"], U * np.cos(psi) * m * kx / k, rtol=0, atol=1e-13)
    np.testing.assert_allclose(r["v"], U * np.cos(psi) * ky / k, rtol=0, atol=1e-13)
    # curvature along a direction s, and by finite differences of the slope
    s = np.array([0.6, 0.8])
    curv = f.curvature(t, lat, lon, np.full(50, s[0]), np.full(50, s[1]))
    np.testing.assert_allclose(curv, -a * (kx * m * s[0] + ky * s[1]) ** 2 * np.cos(psi),
                               rtol=0, atol=1e-14)
    # the slope is the derivative of the elevation: central differences over 1 cm
    d = 0.01
    dlat, dlon = d / R, d / (R * np.cos(lat))
    fd_e = (f.evaluate(t, lat, lon + dlon)["eta"] - f.evaluate(t, lat, lon - dlon)["eta"]) / (2 * d)
    fd_n = (f.evaluate(t, lat + dlat, lon)["eta"] - f.evaluate(t, lat - dlat, lon)["eta"]) / (2 * d)
    # truncation a k³ d²/6 ~ 1e-9; round-off of eta (1e-16) / d = 1e-14 ... a few 1e-9
    np.testing.assert_allclose(fd_e, r["eta_e"], rtol=0, atol=1e-8)
    np.testing.assert_allclose(fd_n, r["eta_n"], rtol=0, atol=1e-8)


def test_jonswap_significant_height_within_1_percent():
    for hs, tp, gamma in ((1.0, 8.0, 3.3), (3.5, 12.0, 1.0), (0.4, 5.0, 7.0)):
        f = field(Jonswap, hs=hs, tp=tp, gamma=gamma)
        # the components carry the spectrum's variance over the band
        assert 4 * math.sqrt(f.variance()) == pytest.approx(hs, rel=0.01)
        # and the spectrum itself integrates to (hs/4)² (independent quadrature)
        m0 = quad(lambda x: float(jonswap(x, hs, tp, gamma)), 1e-3 / tp, 50 / tp, limit=400,
                  points=[1 / tp])[0]
        assert m0 == pytest.approx((hs / 4) ** 2, rel=1e-6)
        # its peak is at fp
        fs = np.linspace(0.5 / tp, 2 / tp, 3001)
        assert fs[np.argmax(jonswap(fs, hs, tp, gamma))] == pytest.approx(1 / tp, rel=1e-3)


def test_jonswap_elevation_variance_in_time():
    """The sampled surface has the variance of the spectrum: over a long record at one point,
    the sample variance of a sum of many random-phase components is within a few per cent."""
    f = field(Jonswap, hs=2.0, tp=10.0, n_frequencies=64, n_directions=8, seed=7)
    t = np.arange(0.0, 3600.0, 0.5)
    eta = np.array([f.evaluate(tt, np.zeros(1), np.zeros(1))["eta"][0] for tt in t])
    # 1 h of record, correlation time ~ a few tp: ~ 100 independent samples, 2/sqrt(50) ~ 0.3 of
    # the variance at worst; the expected deviation is far smaller for this seed-independent sum
    assert np.var(eta) == pytest.approx(f.variance(), rel=0.1)


def test_jonswap_phases_from_seed():
    a = field(Jonswap, seed=3)
    b = field(Jonswap, seed=3)
    c = field(Jonswap, seed=4)
    np.testing.assert_array_equal(a.phase, b.phase)
    assert not np.array_equal(a.phase, c.phase)


# ----------------------------------------------------------------------------- a free floe
A_W, T_W, H_I, D_E = 0.5, 8.0, 1.0, 5.0


def _surge(integrator, dt, duration=80.0):
    wave = {"type": "linear_wave", "params": {"amplitude": A_W, "period": T_W, "direction": 90.0,
                                              "origin": [0.0, 0.0]}}
    sc = make_scene([(0.0, 0.0)], size=D_E, thickness=H_I, dt=dt, duration=duration,
                    integrator=integrator, forcing=[{"source": "waves", "field": wave}])
    sim = Simulation(sc, out=False, progress=False)
    ts, xs = [0.0], [0.0]
    for _ in range(sim.n_steps):
        sim.step()
        lat, lon = latlon_of(sim.state.q)
        ts.append(sim.time)
        xs.append(R * lon[0])
    return np.array(ts), np.array(xs), sim


def _reference(t, C):
    """The same body integrated by scipy: surge ``X`` of a point floe of mass per area
    ``rho_i h`` under ``g a k sin(kX - wt)`` and drag ``(rho_w C / rho_i h) |u_w - u|(u_w - u)``,
    ``u_w = a w cos(kX - wt)`` (deep water)."""
    om = 2 * math.pi / T_W
    k = om**2 / G
    b = 1026.0 * C / (910.0 * H_I)

    def rhs(tt, y):
        ph = k * y[0] - om * tt
        uw = A_W * om * math.cos(ph)
        return [y[1], G * A_W * k * math.sin(ph) + b * abs(uw - y[1]) * (uw - y[1])]

    return solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-12, atol=1e-14,
                     method="DOP853").y[0]


def _amp_phase(t, x, period):
    """Amplitude and phase of the surge over the last five periods (drift removed)."""
    s = t >= t[-1] - 5 * period
    om = 2 * math.pi / period
    G_ = np.column_stack([np.ones(s.sum()), t[s], np.cos(om * t[s]), np.sin(om * t[s])])
    c = np.linalg.lstsq(G_, x[s], rcond=None)[0]
    return math.hypot(c[2], c[3]), math.atan2(c[3], c[2])


@pytest.mark.parametrize("integrator,order,dt", [("rk4", 4, T_W / 40), ("siku2", 1, T_W / 160)])
def test_free_floe_surge_against_independent_integration(integrator, order, dt):
    """Surge amplitude and phase within ``(omega dt)^p`` (the leading error term of an
    order-``p`` integrator, constant 1), and the error falls by at least ``0.7 × 2^p`` when dt
    halves (so what is measured is the integrator's error, not the model's)."""
    om = 2 * math.pi / T_W
    errs = []
    for d in (dt, dt / 2):
        t, x, sim = _surge(integrator, d)
        C = sim.forcing[0].C
        ref = _reference(t, C)
        errs.append(np.max(np.abs(x - ref)))
        if d == dt:
            a_s, p_s = _amp_phase(t, x, T_W)
            a_r, p_r = _amp_phase(t, ref, T_W)
            tol = (om * d) ** order
            assert abs(a_s - a_r) <= tol * a_r
            assert abs((p_s - p_r + math.pi) % (2 * math.pi) - math.pi) <= tol
            # the floe really surges: excursion of the order of the orbital one (a = 0.5 m)
            assert 0.2 < a_r < 2.0
    assert C == pytest.approx((0.41 / math.log(30 * 1.0 / 0.001)) ** 2, rel=1e-15)
    assert log_layer_drag(1.0, 0.001) == C
    assert errs[0] / errs[1] >= 0.7 * 2**order


# ----------------------------------------------------------------------------- a bonded floe
@pytest.mark.parametrize("kL", [0.5, 1.5, 3.0, 4.5])
def test_slope_force_on_a_floe_follows_sinc(kL):
    """Total slope force on an intact floe of length L along the waves: amplitude ``m g a k
    sin(kL/2)/(kL/2)`` (the integral of ``-rho_i h g grad eta`` over the floe)."""
    T = 8.0
    k = (2 * math.pi / T) ** 2 / G
    L, W, D = kL / k, 20.0, 3.0
    wave = {"type": "linear_wave", "params": {"amplitude": 0.3, "period": T, "direction": 90.0,
                                              "origin": [0.0, 0.0]}}
    sc = make_scene([], thickness=1.0, dt=1e-3, duration=1e-3,
                    forcing=[{"source": "waves", "params": {"drag": False}, "field": wave}],
                    extra='[[elements.source]]\nname = "floe"\nparams = { outline = "rectangle", '
                          f'center = [0.0, 0.0], length = {L}, width = {W}, element_size = {D}, '
                          'seed = 2 }\n',
                    run={"allow_unstable_dt": True})
    sim = Simulation(sc, out=False, progress=False)
    st = sim.state
    assert st.n >= 0.9 * L * W / D**2
    src_ = sim.forcing[0]
    amps = []
    for t in (0.0, T / 4):
        F = np.zeros((st.n, 2))
        src_.add(t, st.q, st.V, st.w, F, np.zeros(st.n))
        e = np.array([east_north_local(st.q[i])[:2] for i in range(st.n)])
        amps.append(np.sum(F[:, 0] * e[:, 0] + F[:, 1] * e[:, 1]))
    total = math.hypot(*amps)
    expected = st.m.sum() * G * 0.3 * k * abs(math.sin(kL / 2) / (kL / 2))
    assert total == pytest.approx(expected, rel=0.02)


# ----------------------------------------------------------------------------- breaking
def _breaking():
    """The strip experiment of ``examples/waves/breaking.py`` (documented there)."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "examples" / "waves" / "breaking.py"
    spec = importlib.util.spec_from_file_location("breaking_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_breaking_critical_length():
    """A strip breaks only if longer than ``L_c = (64 E h² eps_c / (rho_w g a k²))^(1/4)``
    (module docstring of wave_breaking): 0.8 L_c stays whole, 1.6 L_c breaks, in flexure."""
    ex = _breaking()
    a, T, E, eps = 0.5, 8.0, 1e9, 3e-5
    k = (2 * math.pi / T) ** 2 / G
    Lc = (64 * E * eps / (1026.0 * G * a * k * k)) ** 0.25
    assert Lc == pytest.approx(ex.critical_length(a, T, E, 1.0, eps), rel=1e-15)
    assert 15 < Lc < 20
    cm, sizes = ex.strip(0.8 * Lc, Lc / 16, a, T, E, eps)
    assert cm.intact.all()
    cm, sizes = ex.strip(1.6 * Lc, Lc / 16, a, T, E, eps)
    assert (~cm.intact).sum() >= 1
    assert set(cm.break_mode[~cm.intact]) == {6.0}  # BREAK_FLEXURE
    assert sizes.max() <= Lc * 1.05


def test_fragments_shrink_as_waves_grow():
    ex = _breaking()
    means = [ex.strip(200.0, 2.0, a)[1].mean() for a in (0.1, 0.5, 2.0)]
    assert means[0] > means[1] > means[2]


def test_breaking_needs_joints():
    wave = {"type": "linear_wave", "params": {}}
    sc = make_scene([(0.0, 0.0)], size=5.0, dt=0.1, duration=1.0,
                    forcing=[{"source": "waves", "params": {"breaking": True}, "field": wave}])
    with pytest.raises(Exception, match="breaking = true need"):
        Simulation(sc, out=False, progress=False)


def test_breaking_check_equals_recomputing_every_strain_at_every_pass():
    """A check computes a joint's surface strain once and its rigid-floe strain again only when
    its floe changed: the same joints break, in the same order, as with every strain of every
    intact joint computed again at every pass (the check before that saving). A JONSWAP sea on
    a Voronoi floe with a stiff plate, so that both limits decide some joints."""
    from siku_core.contact_law import BREAK_FLEXURE
    from siku_core.testing import scene_text
    from siku_core.scene.scene_file import scene_from_text

    def build():
        txt = scene_text([], dt=1e-4, duration=1e-4, forcing=[{
            "source": "waves", "params": {"breaking": True, "drag": False, "slope": False,
                                          "critical_strain": 3e-5},
            "field": {"type": "jonswap", "params": {"hs": 1.5, "tp": 6.0, "n_frequencies": 8,
                                                    "n_directions": 4}}}],
            thickness=1.0, materials={"ice": {"youngs_modulus": 1e9}},
            run={"allow_unstable_dt": True},
            extra='[[elements.source]]\nname = "floe"\nparams = { outline = "rectangle", '
                  'length = 120.0, width = 40.0, element_size = 5.0, seed = 3 }\n'
                  '[contact]\nlaw = "distributed_spring"\nparams = {tensile_strain = 1.0}\n')
        return Simulation(scene_from_text(txt, "<floe>"), out=False, progress=False)

    def naive_check(br, t, q):
        cm = br.cm
        while True:
            joints = np.flatnonzero(cm.intact)
            eps = br.strains(t, q, joints)
            over = eps > br.eps_c
            if not over.any():
                return
            _, label = cm.floe_labels()
            fl, k, e = label[cm.ji[joints[over]]], joints[over], eps[over]
            best = np.lexsort((-e, fl))
            first = np.r_[True, fl[best][1:] != fl[best][:-1]]
            cm.break_joints(k[best][first], BREAK_FLEXURE, t)

    new, old = build(), build()
    rigid = False
    for t in np.linspace(0.0, 4.5, 4):
        b_new, b_old = new.forcing[0].breaker, old.forcing[0].breaker
        b_new.check(t, new.state.q)
        naive_check(b_old, t, old.state.q)
        joints = np.flatnonzero(old.contacts.intact)
        if len(joints):
            eps_f = b_old.surface_strains(t, old.state.q, joints)
            rigid |= bool((b_old.strains(t, old.state.q, joints) < eps_f).any())
    cn, co = new.contacts, old.contacts
    assert (~cn.intact).sum() > 10 and (cn.intact).sum() > 10
    assert rigid  # the rigid limit decided some joints
    assert np.array_equal(cn.intact, co.intact)
    assert np.array_equal(cn.take_breaks()["joint"], co.take_breaks()["joint"])
