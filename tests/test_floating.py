"""Floating elements (siku_plugins.floating): settling at the draft, the undamped heave period,
the wave load on the bottom against the exact transform of a rectangle, the response to a
monochromatic wave against the linear oscillator with the same load, restart bit for bit, a
scene without floating allocates nothing, and bad input."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from siku_core.errors import SceneError
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_plugins.floating.geometry import principal, quadrature, second_moments

RHO_W, G, RHO_I = 1026.0, 9.81, 910.0


def block(params: str = "", dt=0.01, duration=10.0, size=10.0, thickness=1.0, forcing=(),
          extra="", density=RHO_I, output=None):
    """A ``size`` × ``size`` square of ice at (0°, 0°) with the floating process."""
    table = f'[[process]]\nname = "floating"\nparams = {{ {params} }}\n'
    txt = scene_text([(0.0, 0.0)], size=size, dt=dt, duration=duration, thickness=thickness,
                     forcing=forcing, materials={"ice": {"density": density}},
                     extra=table + extra, output=output)
    return txt


def run(txt, steps=None, out=False, **kw):
    sim = Simulation(scene_from_text(txt, "<block>"), out=out, progress=False, **kw)
    z = []
    for _ in range(sim.n_steps if steps is None else steps):
        sim.step()
        z.append(sim.context.fields["heave"][0])
    return sim, np.array(z)


def peaks(t, z):
    """Times and values of the maxima of ``z`` (parabola through three samples)."""
    k = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:])) + 1
    a, b, c = z[k - 1], z[k], z[k + 1]
    den = a - 2 * b + c
    off = 0.5 * (a - c) / den
    return t[k] + off * (t[1] - t[0]), b - 0.25 * (a - c) * off


def test_waterplane_of_a_rectangle():
    poly = np.array([[-3.0, -1.0], [3.0, -1.0], [3.0, 1.0], [-3.0, 1.0]])
    area, ixx, iyy, ixy = second_moments(poly)
    assert area == pytest.approx(12.0, rel=1e-14)
    assert ixx == pytest.approx(6**3 * 2 / 12, rel=1e-14)   # ∫x² dA = b L³/12
    assert iyy == pytest.approx(6 * 2**3 / 12, rel=1e-14)
    assert abs(ixy) < 1e-12
    # turned by 30°: the principal axes come back
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    turned = poly @ np.array([[c, s], [-s, c]])
    phi, j1, j2 = principal(*second_moments(turned)[1:])
    assert j1 == pytest.approx(36.0, rel=1e-12) and j2 == pytest.approx(4.0, rel=1e-12)
    assert math.cos(2 * (phi - math.pi / 6)) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("k", [0.05, 0.16, 0.4])
def test_wave_load_quadrature_is_the_rectangle_transform(k):
    """∫ cos(k x) dA over an L × W rectangle = W L sinc(k L / 2) (exact), ∫ x sin(k x) dA =
    W [sin(kL/2)/k² - L cos(kL/2)/(2k)] · 2; the rule is of order (k s)³."""
    L, W = 10.0, 6.0
    poly = np.array([[-L / 2, -W / 2], [L / 2, -W / 2], [L / 2, W / 2], [-L / 2, W / 2]])
    pts, w = quadrature(poly, 4)
    assert w.sum() == pytest.approx(L * W, rel=1e-14)
    exact = W * L * math.sin(k * L / 2) / (k * L / 2)
    assert np.sum(w * np.cos(k * pts[:, 0])) == pytest.approx(exact, rel=2e-4)
    first = 2 * W * (math.sin(k * L / 2) / k**2 - L * math.cos(k * L / 2) / (2 * k))
    assert np.sum(w * pts[:, 0] * np.sin(k * pts[:, 0])) == pytest.approx(first, rel=2e-3)


@pytest.mark.parametrize("n", [1, 3, 8])
def test_the_loads_from_the_vertices_are_the_pointwise_sums(n):
    """The step's loads from the quadrature lattice (each point's phase a product of powers of
    its triangle's vertices', the centre's phase and the time's turned in once) equal the
    quadrature sums point by point (``kernels.excite``) to round-off: 1e-12 of ``a A``
    (three components, random polygons, frames, times and diffraction factors)."""
    from numba import njit

    from siku_plugins.floating import kernels as kn
    from siku_plugins.floating.geometry import lattice_arrays

    @njit
    def both(t, xc, yc, e0, e1, pts, wav, att):
        amp = wav.amp
        S = np.empty((amp.shape[0], 6))
        Z = np.empty(pts.zsize)
        kn._sums_lattice(e0, e1, 0, pts, amp, att, wav, S, Z)
        kn._turn(xc, yc, wav.kx, wav.ky, wav.phase, S)
        E, r = kn.clock(t, 0.0, 0, wav.omega, 0.0)
        new = kn._load(0, 0, S, E, r, wav.kap, wav.ext)
        old = kn.excite(t, 0, xc, yc, e0, e1, pts, amp, att, wav)
        return new, old

    rng = np.random.default_rng(n)
    for k in (4, 5, 7):
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        poly = np.c_[np.cos(ang), np.sin(ang)] * rng.uniform(3.0, 8.0, k)[:, None]
        poly -= poly.mean(axis=0)
        pts, w = quadrature(poly, n)
        qu, qv = pts[:, 0] * 0.8 + pts[:, 1] * 0.6, -pts[:, 0] * 0.6 + pts[:, 1] * 0.8
        kk = rng.uniform(0.02, 0.7 * n / 8.0, 3)
        th = rng.uniform(0, 2 * np.pi, 3)
        amp = rng.uniform(0.1, 1.0, 3)
        th0 = rng.uniform(0, 2 * np.pi)
        voff, vx, vy, m6, ia, ib, zsize = lattice_arrays([(poly, n)])
        points = kn.FloatingPoints(
            qoff=np.array([0, len(w)]), qa=pts[:, 0], qb=pts[:, 1], qu=qu, qv=qv, qw=w,
            voff=voff, m6=m6, vx=vx, vy=vy, ia=ia, ib=ib, zsize=zsize).check()
        for kap in (np.zeros((0, 0, 3, 2)), rng.uniform(-1, 1, (1, 3, 3, 2))):
            t, xc, yc = rng.uniform(0, 1e4), rng.uniform(-3e4, 3e4), rng.uniform(-3e4, 3e4)
            wav = kn.FloatingWave(
                lat0=0.0, lon0=0.0, R=1.0, depth=math.inf, ramp=0.0, amp=amp,
                kx=kk * np.sin(th), ky=kk * np.cos(th), omega=np.sqrt(G * kk),
                phase=rng.uniform(0, 6, 3), k=kk, acell=amp[None], cell=np.zeros(1, np.int64),
                kap=kap, ext=np.zeros((0, 3))).check()
            new, old = both(t, xc, yc, math.cos(th0), math.sin(th0), points, wav, np.ones(3))
            scale = amp.sum() * w.sum() * np.array([1.0, 8.0, 8.0])
            np.testing.assert_allclose(new, old, rtol=0, atol=1e-12 * scale.max())


@pytest.mark.parametrize("release", [0.3, 5.0, -0.5])
def test_settles_at_its_draft(release):
    """Released from any height (above the water, pushed under), a damped element settles
    where buoyancy equals weight: draft h rho_i / rho_w, to 1e-9 relative."""
    txt = block(f"initial_heave = {release}, damping_ratio = 0.5, tilt_damping_ratio = 0.5",
                duration=80.0, dt=0.05)
    sim, z = run(txt)
    h = 1.0
    draft = h * RHO_I / RHO_W
    submerged = draft - z[-1]   # the water line on the element, from its bottom
    assert submerged == pytest.approx(draft, rel=1e-9)
    assert abs(sim.context.fields["heave_rate"][0]) < 1e-9


def test_undamped_heave_period():
    """Without damping the heave period is 2 pi sqrt((m + A33) / (rho_w g A)) (the Verlet
    sub-steps lengthen it by (2 pi / 64)² / 24 = 0.04 %)."""
    a33 = 0.3
    txt = block(f"initial_heave = 0.05, damping_ratio = 0.0, added_mass = {a33}",
                duration=12.0, dt=0.01)
    sim, z = run(txt)
    A = 100.0
    m = RHO_I * 1.0 * A
    T = 2 * math.pi * math.sqrt((m + a33 * RHO_W * A**1.5) / (RHO_W * G * A))
    t = sim.dt * np.arange(1, len(z) + 1)
    tp, zp = peaks(t, z)
    assert len(tp) >= 3
    assert np.mean(np.diff(tp)) == pytest.approx(T, rel=1e-2)
    assert zp == pytest.approx(0.05, rel=1e-3)   # no loss without damping


def test_tilt_oscillates_at_its_restoring_period():
    """Roll of an undamped block: T = 2 pi sqrt(M / C), M = rho_i h J + m h²/12 + A_k,
    C = rho_w g (J - A d (h - d) / 2)."""
    txt = block("initial_roll = 0.01, tilt_damping_ratio = 0.0, added_inertia = 0.1",
                duration=8.0, dt=0.01)
    sim, _ = run(txt, steps=0)
    roll = []
    for _ in range(sim.n_steps):
        sim.step()
        roll.append(sim.context.fields["roll"][0])
    A, h, J = 100.0, 1.0, 10.0**4 / 12
    d = h * RHO_I / RHO_W
    M = RHO_I * h * J + RHO_I * h * A * h * h / 12 + 0.1 * RHO_W * math.sqrt(A) * J
    C = RHO_W * G * (J - A * d * (h - d) / 2)
    t = sim.dt * np.arange(1, len(roll) + 1)
    tp, _ = peaks(t, np.array(roll))
    assert np.mean(np.diff(tp)) == pytest.approx(2 * math.pi * math.sqrt(M / C), rel=1e-2)
    assert np.max(np.abs(sim.context.fields["pitch"])) < 1e-12


WAVE = ('{{ source = "waves", params = {{ drag = false, slope = false }}, field = {{ type = '
        '"linear_wave", params = {{ amplitude = {a}, period = {T}, direction = 90.0, origin = '
        '[0.0, 0.0] }} }} }}')


def wave_forcing(a, T):
    return [{"source": "waves", "params": {"drag": False, "slope": False},
             "field": {"type": "linear_wave",
                       "params": {"amplitude": a, "period": T, "direction": 90.0,
                                  "origin": [0.0, 0.0]}}}]


def steady_response(z, t, omega, periods=4):
    """Complex amplitude X of z ≈ Re(X e^{-i omega t}) over the last ``periods`` periods."""
    keep = t >= t[-1] - periods * 2 * math.pi / omega
    M = np.column_stack([np.cos(omega * t[keep]), np.sin(omega * t[keep])])
    c, s = np.linalg.lstsq(M, z[keep], rcond=None)[0]
    return complex(c, s)   # Re((c + i s) e^{-i w t}) = c cos + s sin


@pytest.mark.parametrize("T", [4.0, 5.0, 8.0])
def test_heave_in_waves_is_the_oscillator_with_the_froude_krylov_load(T):
    """A block in a monochromatic deep-water wave: the steady heave is X = F / (C - w² (m +
    A33) - i w B33), F = rho_w g a e^{-k d} W L sinc(k L / 2) (the Froude–Krylov load on the
    bottom, exact for a rectangle), within 1 % in amplitude and 0.01 rad in phase."""
    a, L = 0.02, 10.0   # small: the block stays within its freeboard (linear)
    txt = block("damping_ratio = 0.2", duration=12 * T, dt=0.02, forcing=wave_forcing(a, T))
    sim, z = run(txt)
    t = sim.dt * np.arange(1, len(z) + 1)
    w = 2 * math.pi / T
    k = w * w / G
    A = L * L
    d = RHO_I / RHO_W
    m = RHO_I * A
    A33 = 0.244 * RHO_W * A**1.5
    B33 = 2 * 0.2 * math.sqrt((m + A33) * RHO_W * G * A)
    F = RHO_W * G * a * math.exp(-k * d) * A * math.sin(k * L / 2) / (k * L / 2)
    X = F / (RHO_W * G * A - w * w * (m + A33) - 1j * w * B33)
    got = steady_response(z, t, w)
    assert abs(got) == pytest.approx(abs(X), rel=1e-2)
    assert abs(np.angle(got / X)) < 1e-2


def test_restart_is_bit_for_bit(tmp_path):
    """Half a run, a restart from its last snapshot, the other half: heave, tilts and rates
    equal those of the uninterrupted run bit for bit."""
    out = {"file": str(tmp_path / "a.h5"), "every": "1s"}
    common = dict(duration=4.0, dt=0.01, forcing=wave_forcing(0.3, 5.0))
    p = "initial_heave = 0.1, initial_roll = 0.002, initial_pitch = -0.001"
    whole, _ = run(block(p, **common))
    half = block(p, **{**common, "duration": 2.0}, output=out)
    Simulation(scene_from_text(half, str(tmp_path / "s.toml")), out=tmp_path / "a.h5",
               progress=False).run()
    rest = Simulation(scene_from_text(block(p, **common), str(tmp_path / "s.toml")),
                      out=tmp_path / "b.h5", progress=False, restart=tmp_path / "a.h5")
    rest.run()
    for name in ("heave", "heave_rate", "roll", "roll_rate", "pitch", "pitch_rate",
                 "wave_radiated_power"):
        np.testing.assert_array_equal(rest.context.fields[name],
                                      whole.context.fields[name], err_msg=name)


def test_a_scene_without_floating_allocates_nothing():
    txt = scene_text([(0.0, 0.0)], size=10.0, dt=0.01, duration=0.1)
    sim = Simulation(scene_from_text(txt, "<s>"), out=False, progress=False)
    assert sim.context.fields == {} and not sim.ice.active


@pytest.mark.parametrize("kw,words", [
    (dict(density=1030.0), "cannot float"),
    (dict(params="coefficients = \"capytaine\", hydro_cache = \"no/such/folder\""),
     "no such folder"),
    (dict(size=1.0, thickness=2.0), "capsize"),
    (dict(params="damping_ratio = -0.1"), "damping_ratio"),
    # a negative draft h rho_i / rho_w needs a negative thickness or density: refused first
    (dict(thickness=-1.0), "elements.thickness"),
    (dict(density=-910.0), "materials.ice.density"),
])
def test_bad_input_is_one_line(kw, words):
    with pytest.raises(SceneError, match=words):
        run(block(**kw), steps=1)


def test_bad_input_from_the_command_line_exits_2(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(block(density=1030.0))
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(scene), "--out",
                        str(tmp_path / "o.h5")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    lines = [x for x in r.stderr.strip().splitlines() if x]
    assert len(lines) == 1 and "cannot float" in lines[0]


def test_the_process_conformance_suite(tmp_path):
    """The suite every process passes (siku_core.testing.process_checks): finite, no volume
    change, nothing over no time, two runs equal, restart bit for bit; here with the pack's
    2 km elements released 0.1 m above their floating position and tilted."""
    from siku_core.testing.process_checks import check_process
    from siku_plugins.floating import Floating

    check_process(Floating, {"initial_heave": 0.1, "initial_roll": 1e-3,
                             "initial_pitch": -1e-3}, tmp_path)


# ---------------------------------------------------------------------------- bonds that bend
M_DEG = 1.0 / 111194.92664455873   # one metre of longitude at the equator [deg]


def strip(n, a, h=0.5, E=1e9, nu=0.3, params="", dt=0.01, duration=0.02, unstable=False):
    """A 1-element-wide strip of ``n`` squares of side ``a`` along the equator, jointed."""
    lon = n * a * M_DEG / 2
    txt = f"""
title = "floating strip"
[time]
duration = {duration}
dt = {dt}
[materials.ice]
density = {RHO_I}
youngs_modulus = {E}
poisson_ratio = {nu}
[elements]
thickness = {h}
[[elements.pack]]
lon = [{-lon}, {lon}]
lat = [{-a * M_DEG / 2}, {a * M_DEG / 2}]
nx = {n}
ny = 1
[contact]
law = "distributed_spring"
[run]
allow_unstable_dt = {str(unstable).lower()}
[[process]]
name = "floating"
params = {{ bending = true, {params} }}
"""
    return Simulation(scene_from_text(txt, "<strip>"), out=False, progress=False)


def set_state(sim, u):
    """Heave, pitch and roll from ``u`` (heave and slopes along the principal axes)."""
    p = sim.processes[0]
    c, s = p.cphi, p.sphi
    f = sim.context.fields
    f["heave"][:] = u[:, 0]
    f["pitch"][:] = -(u[:, 1] * c - u[:, 2] * s)
    f["roll"][:] = u[:, 1] * s + u[:, 2] * c


def test_a_loaded_floating_beam_is_hetenyis():
    """A point load on a floating strip (1 m elements, below a quarter of the characteristic
    length l = (D / rho_w g)^(1/4) = 5.8 m): the deflection and the bending
    stress at the joints are Hetényi's beam on an elastic foundation, w = P lam / (2 k)
    e^{-lam x} (cos lam x + sin lam x) (P < 0: downwards), M = EI w'' = -P / (4 lam) e^{-lam x}
    (cos lam x - sin lam x),
    k = rho_w g b, lam = 1 / (sqrt(2) l), within 3 %."""
    n, a, h, E, nu, P = 121, 1.0, 0.5, 1e9, 0.3, -1000.0
    sim = strip(n, a, h, E, nu, f"loads = [[{n // 2}, {P}]]", unstable=True)
    proc = sim.processes[0]
    u = proc.equilibrium(sim.context)
    D = E * h**3 / (12 * (1 - nu**2))
    ell = (D / (RHO_W * G)) ** 0.25
    assert a <= ell / 4
    lam = 1 / (math.sqrt(2) * ell)
    k = RHO_W * G * a
    x = np.abs(np.arange(n) - n // 2) * a
    near = x <= 3 * ell          # where the deflection is not small
    w = P * lam / (2 * k) * np.exp(-lam * x) * (np.cos(lam * x) + np.sin(lam * x))
    np.testing.assert_allclose(u[near, 0], w[near], rtol=3e-2)
    set_state(sim, u)
    sig = proc.stresses(sim.context)
    cm = sim.contacts
    xj = np.abs(0.5 * (cm.ji + cm.jj) - n // 2) * a
    # M = EI w'' (sagging positive) of the w above
    M = -P / (4 * lam) * np.exp(-lam * xj) * (np.cos(lam * xj) - np.sin(lam * xj))
    big = xj <= ell
    np.testing.assert_allclose(sig[big], (6 * M / (a * h * h))[big], rtol=3e-2)


def test_a_damped_loaded_beam_settles_at_its_equilibrium():
    """Stepped in time (the engine's stable step), a damped loaded strip settles at the static
    solution of the same stiffness, to 1e-6 relative."""
    sim = strip(5, 2.0, params="loads = [[2, -500.0]], damping_ratio = 1.0, "
                "tilt_damping_ratio = 1.0", dt=4e-4, duration=6.0)
    sim.run()
    u = sim.processes[0].equilibrium(sim.context)
    np.testing.assert_allclose(sim.context.fields["heave"], u[:, 0], rtol=1e-6)


@pytest.mark.parametrize("factor,broken", [(0.5, 0), (1.5, 2)])
def test_joints_break_in_flexure_where_the_stress_exceeds_the_strength(factor, broken):
    """A load whose static bending stress at the two joints beside it is ``factor`` times the
    flexural strength: below, nothing breaks; above, those two break, with mode flexure."""
    from siku_core.contact_law import BreakMode

    probe = strip(5, 2.0, params="loads = [[2, -500.0]]", dt=4e-4)
    pr = probe.processes[0]
    u = pr.equilibrium(probe.context)
    set_state(probe, u)
    strength = float(np.max(np.abs(pr.stresses(probe.context)))) / factor
    sim = strip(5, 2.0, params=f"loads = [[2, -500.0]], damping_ratio = 1.0, "
                f"tilt_damping_ratio = 1.0, flexural_strength = {strength}", dt=4e-4,
                duration=3.0)
    sim.run()
    cm = sim.contacts
    gone = np.flatnonzero(~cm.intact)
    assert len(gone) == broken
    if broken:
        assert set(gone) == {k for k in range(cm.n_joints) if 2 in (cm.ji[k], cm.jj[k])}
        assert np.all(cm.break_mode[gone] == int(BreakMode.FLEXURE))


def test_restart_with_bending_is_bit_for_bit(tmp_path):
    """A loaded, bending strip that breaks a joint in flexure mid-run: restarted from a
    snapshot after the break, it ends bit for bit as the uninterrupted run."""
    def text(duration):
        sim = strip(5, 2.0, params="loads = [[2, -500.0]], flexural_strength = 4e3",
                    dt=4e-4, duration=duration)
        return sim.scene.text

    whole = Simulation(scene_from_text(text(0.3), "<s>"), out=False, progress=False)
    times = []
    while whole.step_index < whole.n_steps:
        whole.step()
        if not times and not whole.contacts.intact.all():
            times.append(whole.time)
    assert times and times[0] < 0.15    # broken before the snapshot the restart starts from
    Simulation(scene_from_text(text(0.15), str(tmp_path / "s.toml")), out=tmp_path / "a.h5",
               progress=False).run()
    rest = Simulation(scene_from_text(text(0.3), str(tmp_path / "s.toml")),
                      out=tmp_path / "b.h5", progress=False, restart=tmp_path / "a.h5")
    rest.run()
    for name in ("heave", "heave_rate", "roll", "roll_rate", "pitch", "pitch_rate"):
        np.testing.assert_array_equal(rest.context.fields[name],
                                      whole.context.fields[name], err_msg=name)
    np.testing.assert_array_equal(rest.contacts.intact, whole.contacts.intact)
