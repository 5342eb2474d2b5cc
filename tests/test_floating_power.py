"""The radiation damping's power of floating elements (``wave_radiated_power``): its integral
over a free decay is the mechanical energy lost, to the time stepping's order; in steady
monochromatic waves its mean is ``B33 omega² |Z|² / 2`` per area; it is declared (units) and
its total is a diagnostic."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tests.test_floating import G, RHO_I, RHO_W, block, run, steady_response, wave_forcing


def energy(proc, f):
    """Heave and tilt energy [J] of element 0: ``(M v² + C x²) / 2`` per mode (mass with the
    added mass, hydrostatic restoring), the slopes along the principal axes."""
    c, s = proc.cphi[0], proc.sphi[0]
    sx, sy, wx, wy = -f["pitch"][0], f["roll"][0], -f["pitch_rate"][0], f["roll_rate"][0]
    s1, s2 = sx * c + sy * s, -sx * s + sy * c
    v1, v2 = wx * c + wy * s, -wx * s + wy * c
    return 0.5 * (proc.M3[0] * f["heave_rate"][0] ** 2 + proc.C3[0] * f["heave"][0] ** 2
                  + proc.M1[0] * v1**2 + proc.C1[0] * s1**2
                  + proc.M2[0] * v2**2 + proc.C2[0] * s2**2)


def radiated_work(sim) -> float:
    """Run ``sim`` to its end: the work [J] of element 0's radiation damping, the sum of
    ``wave_radiated_power A dt``."""
    proc = sim.processes[0]
    f = sim.context.fields
    work = 0.0
    for _ in range(sim.n_steps):
        sim.step()
        work += f["wave_radiated_power"][0] * proc.area[0] * sim.dt
    return work


def decay(spp, dt=0.05, duration=12.0):
    """A block released with heave, roll and pitch in still water (linear: it stays within its
    freeboard): ``(E0, E_end, ∫ P A dt, omega_max h, (B/M)_max h)``, ``h`` the sub-step."""
    p = ("initial_heave = 0.05, initial_roll = 0.01, initial_pitch = -0.007, "
         f"steps_per_period = {spp}, damping_ratio = 0.15, tilt_damping_ratio = 0.1")
    sim, _ = run(block(p, dt=dt, duration=duration), steps=0)
    proc = sim.processes[0]
    f = sim.context.fields
    e0 = energy(proc, f)
    work = radiated_work(sim)
    n_sub = math.ceil(dt * spp / proc.period_min - 1e-9)
    h = dt / n_sub
    w = max(math.sqrt(c / m) for c, m in ((proc.C3, proc.M3), (proc.C1, proc.M1),
                                          (proc.C2, proc.M2)) for c, m in [(c[0], m[0])])
    b = max(bb[0] / mm[0] for bb, mm in ((proc.B3, proc.M3), (proc.B1, proc.M1),
                                         (proc.B2, proc.M2)))
    return e0, energy(proc, f), work, w * h, b * h


def test_the_radiated_work_of_a_free_decay_is_the_energy_lost():
    """Velocity Verlet with the damping half explicit, half implicit conserves, without
    damping, ``H = M v²/2 + C x² (1 - (omega h)²/4)/2``, and with it the trapezoid of ``B v²``
    over a sub-step matches the change of ``H`` to ``O(h³)``: ``∫ P A dt = E0 - E`` within
    ``(omega h)²/4 (E0 + E)`` (``E`` against ``H``) plus ``(b h)²/2 E0`` (the sum of the local
    errors, ``b = B/M``); halving the sub-step quarters the mismatch (second order)."""
    errs = []
    for dt in (0.1, 0.05):            # one sub-step per step (steps_per_period = 8)
        e0, e1, work, wh, bh = decay(8, dt)
        assert e1 < 0.05 * e0          # most of the energy radiated over the run
        err = abs(work - (e0 - e1))
        assert err <= (wh**2 / 4 * (e0 + e1) + bh**2 / 2 * e0)
        errs.append(err)
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.25)


@pytest.mark.parametrize("T", [4.0, 6.0])
def test_the_mean_radiated_power_in_steady_waves_is_b33_omega2_z2_over_2(T):
    """A block in a monochromatic deep-water wave, tilts undamped: over whole periods of the
    steady state the mean of ``wave_radiated_power`` is ``B33 omega² |Z|² / 2 / A``, with
    ``Z`` the fitted heave amplitude within the sub-step error ``(omega h)²``, and with ``Z``
    the linear oscillator's (``tests/test_floating.py``: 1 % in amplitude) within 2 %."""
    a, L, dt = 0.02, 10.0, 0.02
    txt = block("damping_ratio = 0.2, tilt_damping_ratio = 0.0", duration=12 * T, dt=dt,
                forcing=wave_forcing(a, T))
    sim = run(txt, steps=0)[0]
    proc = sim.processes[0]
    z, pw = [], []
    for _ in range(sim.n_steps):
        sim.step()
        z.append(sim.context.fields["heave"][0])
        pw.append(sim.context.fields["wave_radiated_power"][0])
    z, pw = np.array(z), np.array(pw)
    t = dt * np.arange(1, len(z) + 1)
    w = 2 * math.pi / T
    keep = round(4 * T / dt)                  # the last four periods: whole periods of steps
    mean = pw[-keep:].mean()
    A = L * L
    B33 = proc.B3[0]
    fit = steady_response(z, t, w)
    h = dt / math.ceil(dt * 64 / proc.period_min - 1e-9)
    assert mean == pytest.approx(B33 * w * w * abs(fit) ** 2 / 2 / A, rel=(w * h) ** 2)
    k = w * w / G
    d = RHO_I / RHO_W
    m = RHO_I * A
    F = RHO_W * G * a * math.exp(-k * d) * A * math.sin(k * L / 2) / (k * L / 2)
    X = F / (RHO_W * G * A - w * w * (m + 0.244 * RHO_W * A**1.5) - 1j * w * B33)
    assert mean == pytest.approx(B33 * w * w * abs(X) ** 2 / 2 / A, rel=2e-2)


def test_the_field_is_declared_with_units_and_its_total_is_a_diagnostic(tmp_path):
    import xarray as xr

    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    out = tmp_path / "a.nc"
    txt = block("initial_heave = 0.05", dt=0.05, duration=1.0,
                output={"file": str(out), "every": "0.5s", "writer": "netcdf"})
    sim = Simulation(scene_from_text(txt, str(tmp_path / "s.toml")), out=out, progress=False)
    sim.run()
    f = sim.context.fields["wave_radiated_power"]
    assert f[0] > 0
    assert sim.diagnostics()["wave_radiated_power"] == pytest.approx(
        f[0] * sim.processes[0].area[0], rel=1e-14)
    with xr.open_dataset(out) as ds:
        v = ds["wave_radiated_power"]
        assert v.attrs["units"] == "W m-2"
        assert float(v.isel(time=-1).values.ravel()[0]) == f[0]



def test_in_a_bending_strip_the_radiated_work_is_the_energy_lost():
    """Six jointed 2 m elements bending (``siku_plugins.floating.bending``), released with heave
    and pitch: the elements' radiated work is the loss of the modes' energy plus the beams'
    strain energy ``u·K u / 2``, within ``(omega h)²/4 (E0 + E)`` (``omega`` of the shortest
    period of the strip, ``h`` the sub-step; the damping's ``(b h)²`` term is far smaller); the
    mismatch falls fourfold when the sub-step halves."""
    from scipy.sparse import csr_matrix

    from tests.test_floating import strip

    errs = []
    for spp in (32, 64):
        s = strip(6, 2.0, E=1e6, dt=0.01, duration=4.0, unstable=True, params=(
            "initial_heave = 0.02, initial_pitch = 0.01, tilt_damping_ratio = 0.1, "
            f"steps_per_period = {spp}"))
        p, f, n = s.processes[0], s.context.fields, s.state.n
        K = csr_matrix((p.beams.data, p.beams.indices, p.beams.indptr), shape=(3 * n, 3 * n))
        M = np.column_stack([p.M3, p.M1, p.M2]).ravel()
        C = np.column_stack([p.C3, p.C1, p.C2]).ravel()

        def total():
            c, sn = p.cphi, p.sphi
            sx, sy, wx, wy = -f["pitch"], f["roll"], -f["pitch_rate"], f["roll_rate"]
            u = np.column_stack([f["heave"], sx * c + sy * sn, -sx * sn + sy * c]).ravel()
            v = np.column_stack([f["heave_rate"], wx * c + wy * sn, -wx * sn + wy * c]).ravel()
            return 0.5 * (M * v * v).sum() + 0.5 * (C * u * u).sum() + 0.5 * u @ (K @ u)

        e0, work = total(), 0.0
        for _ in range(s.n_steps):
            s.step()
            work += (f["wave_radiated_power"] * p.area).sum() * s.dt
        e1 = total()
        wh = 2 * math.pi / p.period_min * s.dt / math.ceil(s.dt * spp / p.period_min - 1e-9)
        err = abs(work - (e0 - e1))
        assert e1 < 0.1 * e0 and err <= wh**2 / 4 * (e0 + e1)
        errs.append(err)
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.25)
