"""Radiation memory of heave by Cummins' equation (siku_plugins.floating.memory, ``radiation =
"memory"``): the kernel's transforms give back B(omega) and the Kramers–Kronig added mass within
the truncation bound, the steady heave in monochromatic waves is capytaine's RAO at three
frequencies, the bouncing block decays to its floating position, restarts are bit for bit, and
bad input is one line; with bending and loads (a strip) the memory keeps the static
equilibrium, moves a rigid heave as each element alone, and restarts bit for bit."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import quad

from siku_core.errors import SceneError
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_plugins.floating import memory

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from test_floating import G, RHO_I, RHO_W, block, peaks, run, steady_response, wave_forcing  # noqa: E402,I001

SIZE = 1.0   # capytaine's panels [m]
SQUARE = np.array([[-5.0, -5.0], [5.0, -5.0], [5.0, 5.0], [-5.0, 5.0]])
D = RHO_I / RHO_W
BINS = 20   # the band's frequencies in these tests (the default is 40)
MEM = f'radiation = "memory", coefficients = "capytaine", mesh_size = 1.0, memory_bins = {BINS}'


def _nodes(omega, B):
    """The piecewise-linear B_lin of memory.kernel: 0 at 0, the band, the taper."""
    dw = omega[1] - omega[0]
    nt = memory.taper_bins(len(omega))
    w = np.concatenate([[0.0], omega, omega[-1] + dw * np.arange(1, nt + 1)])
    return w, np.concatenate([[0.0], B, B[-1] * (1.0 - np.arange(1, nt + 1) / nt)])


def _check_kernel(omega, B, dt, tol):
    """K is the cosine transform of B_lin (direct quadrature); its discrete transforms give
    back B_lin at the band (cosine) and the Kramers–Kronig A - A_inf = (2/pi) PV ∫ B_lin(w') /
    (w'² - w²) dw' (sine) within the truncation bound (bound, bound / w): no aliasing, as
    2 pi / dt exceeds the band's top plus the taper's."""
    K, bound = memory.kernel(omega, B, dt, tol)
    assert bound <= tol * np.max(B)
    w, f = _nodes(omega, B)
    assert 2 * math.pi / dt > 2 * w[-1]
    for j in (0, 1, 7, len(K) // 3, len(K) - 1):
        t = j * dt
        direct = (2 / math.pi) * sum(
            quad(lambda x: np.interp(x, w, f) * math.cos(x * t), a, b)[0]
            for a, b in zip(w[:-1], w[1:]))
        assert K[j] == pytest.approx(direct, abs=1e-9 * np.max(B))
    Bb, Ab = memory.transform(K, dt, omega)
    assert np.max(np.abs(Bb - B)) <= bound
    for i in range(0, len(omega), 5):
        x = omega[i]
        # PV by subtraction: ∫ (g(u) - g(x)) / (u - x) du + g(x) ln((W - x) / x)
        gx = B[i] / (2 * x)
        kk = (2 / math.pi) * (quad(
            lambda u: (np.interp(u, w, f) / (u + x) - gx) / (u - x) if u != x else 0.0,
            0.0, w[-1], points=w[1:-1], limit=400)[0] + gx * math.log((w[-1] - x) / x))
        assert abs(Ab[i] - kk) <= bound / x + 1e-9 * np.max(B)
    return K, bound


@pytest.mark.parametrize("dt", [0.02, 0.05])
def test_kernel_transforms_of_an_analytic_damping(dt):
    """B(w) = w² e^{-w²/2} (kg/s) on a band to 4 rad/s."""
    omega = 4.0 * np.arange(1, 41) / 40
    _check_kernel(omega, 1e5 * omega**2 * np.exp(-omega**2 / 2), dt, 1e-2)


@pytest.fixture(scope="module")
def band(tmp_path_factory):
    """Capytaine's A, B (heave, pitch, roll) of the 10 m × 10 m × 1 m block on the default
    band."""
    pytest.importorskip("capytaine")
    cache = tmp_path_factory.mktemp("hydro")
    omega = math.sqrt(2 * math.pi * G / (6 * SIZE)) * np.arange(1, BINS + 1) / BINS
    A, B = memory.shape_band(SQUARE, 1.0, D, RHO_W, G, SIZE, omega, cache, "test")
    return cache, omega, A, B


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_kernel_transforms_of_capytaines_damping(band, mode):
    """Heave, slope 1 (pitch) and slope 2 (roll)."""
    _, omega, A, B = band
    assert np.all(B[mode] > 0)
    _check_kernel(omega, B[mode], 0.02, 1e-2)


def _rao(w, Aw, Bw, F, a):
    return a * F / (RHO_W * G * 100 - w * w * (RHO_I * 100 + Aw) - 1j * w * Bw)


@pytest.mark.parametrize("T", [4.0, 5.0, 8.0])
def test_heave_in_waves_is_capytaines_rao_with_memory(band, T):
    """The block in a 2 cm monochromatic wave (Froude–Krylov plus diffraction), radiation by
    memory: steady heave amplitude and phase equal capytaine's RAO with A(w), B(w) at the
    wave's frequency within 2 % (0.02 rad), which the RAO with constant coefficients at the
    natural frequency misses by more than that."""
    from siku_plugins.floating import hydro

    cache = band[0]
    a = 0.02
    txt = block(f'{MEM}, hydro_cache = "{cache}", diffraction = true, frequency = "wave"',
                duration=12 * T, dt=0.02, forcing=wave_forcing(a, T))
    sim, z = run(txt)
    w = 2 * math.pi / T
    bod = hydro.body(SQUARE, D, 1.0, SIZE)
    F = sum(hydro.excitation(bod, w, RHO_W, G)["Heave"])
    X = _rao(w, *hydro.radiation(bod, "Heave", w, RHO_W, G), F, a)
    got = steady_response(z, sim.dt * np.arange(1, len(z) + 1), w)
    assert abs(got) == pytest.approx(abs(X), rel=2e-2)
    assert abs(np.angle(got / X)) < 2e-2
    A0, B0, _ = hydro.mode_coefficients(bod, "Heave", RHO_I * 100, RHO_W * G * 100, RHO_W, G)
    other = _rao(w, A0, B0, F, a)
    assert abs(abs(other) / abs(X) - 1) > 2e-2 or abs(np.angle(other / X)) > 2e-2


def test_free_decay_settles_at_the_floating_position(band):
    """Released 5 cm above its floating position (linear: within the freeboard), rolled by
    0.002 and pitched by -0.001 rad: with memory the energy of the three modes, (m + A_inf)
    ζ'²/2 + C ζ²/2 plus (I + A_inf,k)(roll'² + pitch'²)/2 + C_k (roll² + pitch²)/2 (the
    square's two axes are alike), never exceeds its start (the radiation force does work
    ∫ mu x' dt >= 0 for a kernel whose transform B >= 0; the truncation's error, at most the
    bound, allows 1e-3 relative), the first heave peaks fall, and the block comes to rest at
    its floating position (a millionth of the energy left after 60 s: 16 heave and 20 tilt
    periods)."""
    cache = band[0]
    txt = block(f'{MEM}, hydro_cache = "{cache}", initial_heave = 0.05, initial_roll = 0.002, '
                'initial_pitch = -0.001', duration=60.0, dt=0.02)
    sim = Simulation(scene_from_text(txt, "<b>"), out=False, progress=False)
    p = sim.processes[0]
    assert p.M1[0] == pytest.approx(p.M2[0], rel=1e-9) and p.C1[0] == pytest.approx(p.C2[0])
    names = ("heave", "heave_rate", "roll", "roll_rate", "pitch", "pitch_rate")
    rec = []
    for _ in range(sim.n_steps):
        sim.step()
        rec.append([sim.context.fields[k][0] for k in names])
    z, v, r, rr, q, qr = np.array(rec).T

    def energy(z, v, r, rr, q, qr):
        return (0.5 * p.M3[0] * v**2 + 0.5 * p.C3[0] * z**2
                + 0.5 * p.M1[0] * (rr**2 + qr**2) + 0.5 * p.C1[0] * (r**2 + q**2))

    E = energy(z, v, r, rr, q, qr)
    E0 = energy(0.05, 0.0, 0.002, 0.0, -0.001, 0.0)
    assert np.max(E) <= E0 * (1 + 1e-3)
    _, zp = peaks(sim.dt * np.arange(1, len(z) + 1), z)
    assert np.all(np.diff(zp[:4]) < 0)   # later, the band's echo at 2 pi / dw (docs)
    assert E[-1] < 1e-6 * E0


def test_with_radiation_memory_the_radiated_work_is_the_energy_released(band):
    """With Cummins' memory the fluid holds energy for a while, so the work of the memory force
    equals the energy lost only once the block has come to rest: released 5 cm up, rolled and
    pitched, after 60 s (a millionth of the energy left) ``∫ P A dt = E0`` within the kernel's
    truncation (1e-3 relative, ``tests/test_floating_memory.py``) and the scheme's
    ``(omega h)²``."""
    from test_floating_power import energy, radiated_work

    txt = block(f'{MEM}, hydro_cache = "{band[0]}", initial_heave = 0.05, '
                'initial_roll = 0.002, initial_pitch = -0.001', duration=60.0, dt=0.02)
    sim = run(txt, steps=0)[0]
    proc = sim.processes[0]
    f = sim.context.fields
    e0 = energy(proc, f)
    work = radiated_work(sim)
    e1 = energy(proc, f)
    assert e1 < 1e-6 * e0
    wh = math.sqrt(max(proc.C3[0] / proc.M3[0], proc.C1[0] / proc.M1[0])) * proc.memory.dt
    assert work == pytest.approx(e0 - e1, rel=1e-3 + wh**2)


def test_restart_with_memory_is_bit_for_bit(band, tmp_path):
    cache = band[0]
    out = {"file": str(tmp_path / "a.h5"), "every": "1s"}
    common = dict(duration=4.0, dt=0.02, forcing=wave_forcing(0.1, 5.0))
    p = f'{MEM}, hydro_cache = "{cache}", initial_heave = 0.05, initial_roll = 0.002'
    whole, _ = run(block(p, **common))
    half = block(p, **{**common, "duration": 2.0}, output=out)
    Simulation(scene_from_text(half, str(tmp_path / "s.toml")), out=tmp_path / "a.h5",
               progress=False).run()
    rest = Simulation(scene_from_text(block(p, **common), str(tmp_path / "s.toml")),
                      out=tmp_path / "b.h5", progress=False, restart=tmp_path / "a.h5")
    rest.run()
    for name in ("heave", "heave_rate", "roll", "roll_rate", "pitch", "pitch_rate"):
        np.testing.assert_array_equal(rest.context.fields[name],
                                      whole.context.fields[name], err_msg=name)
    np.testing.assert_array_equal(rest.processes[0].memory.hist,
                                  whole.processes[0].memory.hist)


def test_default_keeps_no_history():
    sim, _ = run(block("initial_heave = 0.1"), steps=1)
    assert sim.processes[0].history() is None and sim.processes[0].memory is None


def test_bad_input_is_one_line(band, monkeypatch):
    cache = band[0]
    with pytest.raises(SceneError, match="does not cover element 0's heave natural"):
        run(block(f'{MEM}, hydro_cache = "{cache}", memory_omega_max = 1.0'.replace(
            f"memory_bins = {BINS}", "memory_bins = 4")), steps=1)
    with pytest.raises(SceneError, match="needs coefficients = 'capytaine'"):
        run(block('radiation = "memory"'), steps=1)
    monkeypatch.setitem(sys.modules, "capytaine", None)
    with pytest.raises(SceneError, match=r"siku\[hydro\]"):
        run(block(f'{MEM}, hydro_cache = "{cache}"'), steps=1)


def test_bad_input_from_the_command_line_exits_2(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(block('radiation = "memory"'))
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(scene), "--out",
                        str(tmp_path / "o.h5")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    lines = [x for x in r.stderr.strip().splitlines() if x]
    assert len(lines) == 1 and "radiation = 'memory'" in lines[0]


# --- memory with bending and loads: a strip of 2 m × 2 m × 0.5 m elements (one shape) ---
STRIP = ('radiation = "memory", coefficients = "capytaine", mesh_size = 0.5, '
         f'memory_bins = {BINS}, hydro_cache = "{{cache}}"')


@pytest.fixture(scope="module")
def strip_cache(tmp_path_factory):
    pytest.importorskip("capytaine")
    return tmp_path_factory.mktemp("hydro_strip")


def _strip(cache, params, E=1e3, **kw):
    from test_floating import strip

    return strip(5, 2.0, E=E, params=f"{STRIP.format(cache=cache)}, {params}", **kw)


def test_memory_with_loads_and_bending_keeps_the_static_equilibrium(strip_cache):
    """A loaded strip started at rest at its static equilibrium ``(K_beams + C) u = F`` stays
    there (the memory force of rates that were always zero is zero): the loads, the beams and
    the buoyancy balance in the memory's stepping to 1e-9 of the deflection."""
    from test_floating import set_state

    sim = _strip(strip_cache, "loads = [[2, -500.0], [4, 200.0]]", E=1e9, dt=4e-4,
                 duration=0.2)
    proc = sim.processes[0]
    assert proc.memory is not None and proc.beams is not None
    u = proc.equilibrium(sim.context)
    set_state(sim, u)
    sim.run()
    np.testing.assert_allclose(sim.context.fields["heave"], u[:, 0],
                               atol=1e-9 * np.abs(u[:, 0]).max())
    slopes = -sim.context.fields["pitch"]
    np.testing.assert_allclose(slopes, u[:, 1], atol=1e-9 * np.abs(u[:, 1]).max())


def test_memory_in_a_bending_strip_is_the_lone_elements_memory(strip_cache):
    """Released 5 cm above the floating position, every element alike: the beams carry nothing
    (a rigid translation), so with bending each element heaves as without it (each alone,
    ``memory.advance_modes``), to the round-off of the beams' zero resultant (1e-9 of the
    release), over 4 s (two heave periods)."""
    runs = []
    for bend in ("true", "false"):
        sim = _strip(strip_cache, "initial_heave = 0.05", dt=0.02, duration=4.0)
        if bend == "false":
            sim = Simulation(scene_from_text(sim.scene.text.replace(
                "bending = true", "bending = false"), "<strip>"), out=False, progress=False)
        z = []
        for _ in range(sim.n_steps):
            sim.step()
            z.append(sim.context.fields["heave"].copy())
        runs.append((sim, np.array(z)))
    (a, za), (b, zb) = runs
    assert a.processes[0].beams is not None and b.processes[0].beams is None
    assert a.processes[0].memory.n_sub == b.processes[0].memory.n_sub
    assert np.ptp(za[-50:, 0]) > 0.1 * 0.05     # still moving at the end: a real comparison
    np.testing.assert_allclose(za, zb, rtol=0, atol=1e-9 * 0.05)


def test_restart_with_memory_loads_and_bending_is_bit_for_bit(strip_cache, tmp_path):
    p = "loads = [[2, -500.0]], initial_heave = 0.02, initial_roll = 0.001"

    def text(duration):
        sim = _strip(strip_cache, p, dt=0.02, duration=duration)
        return sim.scene.text

    whole = Simulation(scene_from_text(text(1.0), "<s>"), out=False, progress=False)
    whole.run()
    Simulation(scene_from_text(text(0.5), str(tmp_path / "s.toml")), out=tmp_path / "a.h5",
               progress=False).run()
    rest = Simulation(scene_from_text(text(1.0), str(tmp_path / "s.toml")),
                      out=tmp_path / "b.h5", progress=False, restart=tmp_path / "a.h5")
    rest.run()
    for name in ("heave", "heave_rate", "roll", "roll_rate", "pitch", "pitch_rate"):
        np.testing.assert_array_equal(rest.context.fields[name],
                                      whole.context.fields[name], err_msg=name)
    np.testing.assert_array_equal(rest.processes[0].memory.hist,
                                  whole.processes[0].memory.hist)
