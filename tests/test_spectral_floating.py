"""The ``floating`` process in a ``spectral`` wave field: each element is loaded with the local
sea of its grid cell (amplitudes ``sqrt(2 E_j)``, phases of the incident components), the same
sea the horizontal forces and the breaking check use (``siku_forcing.waves.spectral``)."""
from __future__ import annotations

import math

import numpy as np
import pytest

R_EARTH = 6_371_000.0
PERIOD = 8.0
DT = 0.25                     # 32 steps a wave period


def flume(tmp_path, field, floating="ramp = 8.0", duration=1.0, out=False, name="flume"):
    """A 1-D flume 0..400 m east of the origin at the equator, 20 m cells one cell wide, with
    ten 10 m floes, 1 m thick, from x = 100 m to 200 m (five cells of ice), free, neither
    dragged nor pushed by the slope (the horizontal forcing acts on the sea only), floating
    under an 8 s wave of 5 cm amplitude (far from overtopping their 8 cm freeboard: linear)."""
    from siku_core.testing import scene_text
    from siku_core.testing.contact_cases import square_pack

    pack = square_pack(math.degrees(100.0 / R_EARTH), -math.degrees(5.0 / R_EARTH), 10, 1,
                       size=10.0)
    txt = scene_text([], packs=[pack], dt=DT, duration=duration, thickness=1.0, forcing=[
        {"source": "waves", "params": {"drag": False, "slope": False}, "field": field}],
        output={"file": str(tmp_path / f"{name}.h5"), "every": f"{4 * DT}s"} if out else None)
    txt += f'\n[[process]]\nname = "floating"\nparams = {{ {floating} }}\n'
    path = tmp_path / f"{name}.toml"
    path.write_text(txt)
    return path


def spectral(**params):
    return {"type": "spectral", "params": {
        "spectrum": "monochromatic", "amplitude": 0.05, "period": PERIOD, "x": [0.0, 400.0],
        "y": [-10.0, 10.0], "resolution": 20.0, "origin": [0.0, 0.0], **params}}


def build(path):
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    return Simulation(load_scene(path), out=False, progress=False)


MODES = ("heave", "heave_rate", "roll", "roll_rate", "pitch", "pitch_rate")
#: the process's two kernels: elements one by one, and all together (a constant load on one
#: element makes the process integrate them as one system: siku_plugins.floating.bending);
#: the scene's damping ratios, which damp the free oscillation the ramp leaves at the natural
#: frequency (the wave-frequency coefficients of the default hardly damp it)
SCENE = 'coefficients = "scene"'
PATHS = {"independent": f"ramp = 8.0, {SCENE}",
         "together": f"ramp = 8.0, loads = [[0, 1.0]], {SCENE}"}


@pytest.mark.parametrize("path", sorted(PATHS))
def test_without_attenuation_the_floating_loads_are_the_incident_waves(tmp_path, path):
    """With no attenuation (``alpha = 0``) the spectrum stays the incident one, so every floe
    moves as in the uniform ``linear_wave`` of the same amplitude, period and phase; the two
    differ by the round-off of ``sqrt(2 (a² / 2))`` against ``a`` (one part in 1e16 of the
    load, linear in it), so 1e-12 of each mode's range."""
    linear = {"type": "linear_wave", "params": {"amplitude": 0.05, "period": PERIOD,
                                                "origin": [0.0, 0.0]}}
    sims = [build(flume(tmp_path, fld, PATHS[path], duration=12.0, name=name))
            for name, fld in (("spectral", spectral(attenuation="constant",
                                                    attenuation_params={"alpha": 0.0})),
                              ("linear", linear))]
    for s in sims:
        s.run()
    a, b = (s.context.fields for s in sims)
    f = sims[0].forcing[0].field
    assert sims[0].processes[0].field is f          # the run's sea, the one that evolves
    assert np.allclose(f.E, f.E_in[:, None, None], rtol=1e-14, atol=0.0)
    for k in MODES:
        scale = np.abs(b[k]).max()
        assert scale > 0, k
        assert np.abs(a[k] - b[k]).max() <= 1e-12 * scale, k


def amplitude(series, t):
    """Amplitude of the harmonic at the wave's frequency of each column of ``series``
    (samples at times ``t`` spanning whole periods, uniformly): exact for a sinusoid."""
    w = np.exp(1j * (2 * math.pi / PERIOD) * t)
    return np.abs(2.0 * (w[:, None] * series).mean(axis=0))


@pytest.mark.parametrize("path", sorted(PATHS))
def test_in_steady_state_a_floe_heaves_with_the_amplitude_of_its_cell(tmp_path, path):
    """Constant attenuation ``alpha`` [1/m]: the sea decays through the five cells of ice, and
    in steady state a floe's heave is the linear response to its cell's amplitude
    ``sqrt(2 E_c)`` (the floes are identical and independent; the scheme is linear and time
    invariant, so the response scales with the amplitude exactly, whatever the phase). The
    heave amplitudes of floes in the first and last cells of ice therefore stand in the ratio
    ``sqrt(E_last / E_first)`` (0.85 here; the incident amplitudes that the process used before
    give 1) up to the free oscillation left from the ramp and the sea's settling, which
    decays as ``exp(-zeta omega_n t)`` (``zeta = B33 / (2 sqrt(M33 C33))``). The sea is
    steady in the cells of ice (to 1e-10 of itself, checked) from ``T_s = 100 s`` on, and the
    two periods measured start ``tau`` later, so the tolerance is ``2 exp(-zeta omega_n tau)``
    plus 1e-9 for the sea's remaining change. (Two floes fill half of each 20 m cell: ``C =
    0.5``.)"""
    alpha = 4e-3
    settled = 100.0
    n_window = int(2 * PERIOD / DT)
    sim = build(flume(tmp_path, spectral(attenuation="constant",
                                         attenuation_params={"alpha": alpha}),
                      PATHS[path], duration=190.0))
    f = sim.forcing[0].field
    proc = sim.processes[0]
    sim.run(steps=int(settled / DT) + 1)      # the sea advances at a step's start: to 100 s
    assert f.t_wave == settled
    E0 = f.E.copy()
    sim.run(steps=sim.n_steps - n_window - sim.step_index)
    t0 = sim.time
    t, heave = [], []
    for _ in range(n_window):
        sim.step()
        t.append(sim.time)
        heave.append(sim.context.fields["heave"].copy())
    # the sea of the ice's cells (and of those upstream, the only ones they depend on in the
    # upwind scheme) is steady since 100 s; downstream the deficit is still leaving the flume
    assert np.abs(f.E - E0)[..., :10].max() <= 1e-10 * E0.max()
    A = amplitude(np.array(heave), np.array(t))
    cell = f.cells(*f._latlon(sim.state.q))[0]
    first, last = 0, 9                        # x = 105 m (cell 5) and 195 m (cell 9)
    assert (cell[first], cell[last]) == (5, 9)
    want = math.sqrt(f.E[0, 0, 9] / f.E[0, 0, 5])
    assert want < 0.9                         # a ratio the incident sea (1) would miss
    zeta = proc.B3[0] / (2 * math.sqrt(proc.M3[0] * proc.C3[0]))
    omega_n = math.sqrt(proc.C3[0] / proc.M3[0])
    tol = 2 * math.exp(-zeta * omega_n * (t0 - settled)) + 1e-9
    assert tol < 1e-6
    assert A[last] / A[first] == pytest.approx(want, rel=tol)
    assert A[first] == pytest.approx(A[1], rel=tol)   # two floes in one cell: one amplitude


def test_a_restart_with_floating_elements_in_the_spectral_sea_is_bit_for_bit(tmp_path):
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    path = flume(tmp_path, spectral(attenuation="doble2015", start="calm"), duration=4 * DT * 3,
                 out=True)
    scene = load_scene(path)
    whole = Simulation(scene, out=tmp_path / "whole.h5", progress=False).run()
    part = tmp_path / "part.h5"
    Simulation(scene, out=part, progress=False).run(steps=4)
    second = Simulation(scene, out=part, restart=part, progress=False)
    assert second.restarted_from == 4
    second.run()
    a, b = second.forcing[0].field, whole.forcing[0].field
    assert a.t_wave == b.t_wave > 0 and np.array_equal(a.E, b.E)
    assert np.abs(whole.context.fields["heave"]).max() > 0
    for k in (*MODES, "wave_radiated_power"):
        assert np.array_equal(second.context.fields[k], whole.context.fields[k]), k


def test_the_elements_cells_are_the_fields_cells_of_their_centres(tmp_path):
    """``Spectral.element_cells`` (one compiled pass, what the floating process uses) gives
    :meth:`Spectral.cells` of the centres exactly, inside the grid, on it and beyond it
    (clipped), for any heading."""
    from siku_core.geometry.quat import latlon_of, q_from_latlon, qmul

    sim = build(flume(tmp_path, spectral()))
    f = sim.forcing[0].field
    rng = np.random.default_rng(7)
    n = 4000
    x = rng.uniform(-100.0, 500.0, n)          # the grid is 0..400 m by -10..10 m
    y = rng.uniform(-30.0, 30.0, n)
    x[:200] = 20.0 * rng.integers(-2, 22, 200)  # on cell edges
    q = np.array([q_from_latlon(yy / R_EARTH, xx / R_EARTH) for xx, yy in zip(x, y)])
    a = rng.uniform(0, 2 * np.pi, n)            # spun about the vertical: the same centre
    spin = np.column_stack([np.cos(a / 2), np.zeros(n), np.zeros(n), np.sin(a / 2)])
    q = np.array([qmul(qi, si) for qi, si in zip(q, spin)])
    want, inside = f.cells(*latlon_of(q))
    assert not inside.all() and inside.any()
    assert np.array_equal(f.element_cells(q), want)
