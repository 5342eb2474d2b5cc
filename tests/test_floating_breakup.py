"""Breakup by waves (issue 42): a long floating strip in waves of slowly rising amplitude breaks
first at the joint and the step that the linear steady state of a thin plate following the wave
predicts, and the infinite plate's closed form predicts its stress in the strip's middle.

The case (``examples/floating/breakup.py``, which prints the numbers below): a strip of 150
square elements of 3 m (450 m; 1 m thick, E = 1 GPa, nu = 0.3: characteristic length ``l = (D /
rho_w g)^{1/4}`` = 9.77 m, so the strip is 46 l long and an element 0.31 l) along the path of
10 s deep-water waves (wavelength 157 m, ``k l`` = 0.39: long against l; the elements' heave
period, 2.6 s, is short against 10 s) whose load rises as ``(1 - cos(pi t / T_r)) / 2`` over
``T_r`` = 100 s (ten periods) to amplitude 0.5 m; flexural strength 200 kPa, reached at about
47 s. The ``floating`` process moves the elements in heave and pitch with the constant
added mass and damping of ``coefficients = "scene"`` (the natural-frequency fit), in steps of
``dt`` = 0.02 s (T / 500) of 8 sub-steps per shortest period (its stiffest beam mode, 17 ms),
and checks the joints' stress after every step. The ice is held still in the plane (only the
process is stepped, the horizontal forces being off,
as ``examples/waves/breaking.py`` does for the quasi-static criterion): in linear theory the
vertical motion does not move the elements horizontally, and the engine's stable step for the
1 GPa in-plane joints (6e-4 s) would take 30 times as many steps (the last test checks, on a
short strip, that holding the ice still is the engine's run to within the bound its in-plane
drift from round-off sets, 4 % and 1 % of it measured).

**The prediction** (``siku_plugins.floating.steady``): the thin plate's equations as the model
discretises them (Hermite beams between the element centres on the elements' buoyancy, with
inertia and added mass, damping and the element-averaged Froude–Krylov load at the draft) are
solved for their steady state ``H(omega) F`` with the free ends, and the ramp enters by the
adiabatic series ``sum_m i^m r^(m) H^(m) F / m!`` to ``m = 3``; the first step whose end sees a
joint's stress above the strength is the predicted step and that joint the predicted place. In
the middle of the strip this is the closed form of an infinite thin plate
(``steady.thin_plate``): the stress of a plate that follows the wave, ``E h a k² e^{-k d} / (2
(1 - nu²))`` = 429.3 kPa, times the response ``|H| = 1 / |1 + (k l)^4 - omega² (m + A33) /
(rho_w g A) - i omega B33 / (rho_w g A)|`` = 1.0387 (its own stiffness 0.024, inertia and
added mass 0.065, damping 0.088 in quadrature), times ``sinc²(k s / 2)`` = 0.9988 (the load's
average over an element, and the joint's curvature from the difference of the elements'
slopes; ``s`` the element), its envelope delayed by the group delay ``tau = d arg H / d omega``
= 0.164 s (eight steps). They agree to 1.1e-4: the moment of the weight of the tilted thick
elements (``A d (h - d) / 2`` in their restoring, relative ``k² d (h - d) / 2`` = 8e-5), which
thin-plate theory leaves out, and ``O((k s)^4)`` (asserted within ``k² d (h - d) + (k s)^4 /
10``).

**Neglected in the prediction, bounded** (relative to the strength, computed by test 1): the
next term of the adiabatic series ``r'''' |H'''' F| / 24`` (5e-9 at the break); the free
oscillation the start leaves (the series is not at rest at ``t = 0``): at most ``r''(0) |H''
F| / 2`` = 2.2e-4, decayed by ``e^{-gamma t}``, ``gamma = min B / (2 M)`` = 0.255 /s, to 1e-9;
the sub-steps' error on the forced response ``(omega delta_t)² / 12`` (3e-7); the clamp of the
buoyancy is not reached (heave relative to the wave at most 0.054 m at the break, inside the
0.113 m freeboard). Their sum, 3e-7, is far below the margins by which the predicted stress
stays below the strength at the step before (-5.35e-4) and exceeds it at the predicted step
(+3.45e-4), and below the next highest joint's (-1.06e-3): the strip must break at the
predicted step and joint. Measured: the strip's stresses at the step before the break are the
prediction's to 3e-8 of the strength, and it breaks at the predicted step (46.88 s) and joint
(96 m from the up-wave end) alone.

The closed form alone predicts 46.914 s, two steps later: the strip breaks first where the edge
wave of its free up-wave end adds 0.19 % to the amplitude, which at the ramp's rate ``r' / r``
= 0.035 /s is 0.054 s earlier (asserted: within that and one step). The test can fail: a plate
that follows the wave would break 48 steps later, one with its own stiffness only 83 steps
later, the steady state without the group delay 9 steps earlier, and a strength 0.2 % higher
3 steps later (asserted: each more than one step off).
"""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from siku_core.contact_law import BreakMode
from siku_plugins.floating.steady import Steady, ramp

_path = Path(__file__).resolve().parents[1] / "examples" / "floating" / "breakup.py"
_spec = importlib.util.spec_from_file_location("breakup_example", _path)
ex = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ex)
H, RHO_I, RHO_W, E, NU = ex.H, ex.RHO_I, ex.RHO_W, ex.E, ex.NU
STRENGTH, T_R, DT = ex.STRENGTH, ex.T_R, ex.DT


@pytest.fixture(scope="module")
def first_break():
    """Run the strip to its first break: the prediction, the step and joints of the break,
    and the stresses [Pa] at the step before it."""
    sim = ex.strip_in_waves()
    proc, cm = sim.processes[0], sim.contacts
    pred = Steady(proc, sim.context)
    before = None
    while cm.intact.all() and sim.step_index < sim.n_steps:
        before = proc.stresses(sim.context)
        ex.advance(sim)
    return sim, pred, sim.step_index, np.flatnonzero(~cm.intact), before


def test_the_strip_breaks_first_at_the_predicted_joint_and_step(first_break):
    """The neglected terms of the prediction (module docstring), summed, are below its margins
    at the steps before and at the predicted one and below the next joint's; the strip's
    stresses before the break are the prediction's within that sum, and it breaks at the
    predicted step and joint (asserted: within one step and one element), in flexure."""
    sim, pred, step, broken, before = first_break
    proc = sim.processes[0]
    n, j, low, high = pred.first_break(STRENGTH, T_R, DT, T_R)
    assert n > 0 and 4 * ex.PERIOD < n * DT < T_R          # many periods into the ramp
    # the neglected terms, bounded, relative to the strength (module docstring)
    t = n * DT
    fourth = np.max(np.abs(ramp(t, T_R, 4) * pred.S[4])) / 24
    gamma = np.min(np.r_[proc.B3 / proc.M3, proc.B1 / proc.M1, proc.B2 / proc.M2]) / 2
    assert np.all(gamma * np.r_[proc.B3, proc.B1, proc.B2] < np.r_[proc.C3, proc.C1, proc.C2])
    start = (math.pi / T_R) ** 2 / 4 * np.max(np.abs(pred.S[2])) * math.exp(-gamma * t)
    spp = proc.p["steps_per_period"]
    sub = pred.omega * DT / math.ceil(DT * spp / proc.period_min - 1e-9)     # omega delta_t
    verlet = sub**2 / 12 * np.max(np.abs(pred.S[0]))
    bound = (fourth + start + verlet) / STRENGTH
    assert bound < 1e-6
    # the clamp is never reached: heave relative to the averaged wave inside the freeboard
    d = H * RHO_I / RHO_W
    assert ramp(t, T_R) * np.max(np.abs(pred.heave - pred.head)) < min(d, H - d)
    # the margins of the prediction exceed the bound: the break must be at step n, joint j
    assert low < -bound and high > bound
    s_n = np.abs(pred.stress(t, T_R))
    assert np.sort(s_n)[-2] < STRENGTH * (1 - bound) or abs(np.argsort(s_n)[-2] - j) <= 1
    # the strip's stress before the break is the prediction's within the bound
    np.testing.assert_allclose(before, pred.stress((step - 1) * DT, T_R), rtol=0,
                               atol=bound * STRENGTH)
    assert abs(step - n) <= 1                                 # within one step
    assert len(broken) and np.all(np.abs(broken - j) <= 1)    # within one element
    assert np.all(sim.contacts.break_mode[broken] == int(BreakMode.FLEXURE))


def test_the_middle_of_the_strip_is_the_infinite_thin_plate(first_break):
    """The prediction's stress amplitude in the middle of the strip is the closed form's,
    within twice the weight-moment term it leaves out and ``(k s)^4 / 10`` (discreteness
    beyond sinc², of that order: 2e-5 measured between elements of 1.5 and 6 m); its group
    delay within the same and ``(k s)² /
    12``, the size of the elements' correction to the amplitude, which the closed form's delay
    does not carry (measured 5e-4). The closed form's break time is the strip's within the
    edge wave's gain at the ramp's rate and one step."""
    sim, pred, step, broken, _ = first_break
    proc = sim.processes[0]
    sig, gain, tau = ex.closed_form(proc, pred)
    m = len(pred.S[0]) // 2
    d = H * RHO_I / RHO_W
    ks = pred.k * ex.SIDE
    tol = pred.k**2 * d * (H - d) + ks**4 / 10
    assert abs(abs(pred.S[0][m]) / (sig * gain) - 1) < tol
    assert abs((pred.S[1][m] / pred.S[0][m]).imag / tau - 1) < tol + ks**2 / 12
    edge = np.max(np.abs(pred.S[0])) / abs(pred.S[0][m]) - 1
    t_c = ex.crossing(sig * gain, tau)
    rate = ramp(t_c, T_R, 1) / ramp(t_c, T_R)
    assert 0 <= t_c - step * DT <= edge / rate + DT


def test_the_uncorrected_predictions_miss(first_break):
    """A plate that follows the wave, one with only its own stiffness, the steady state without
    the ramp's group delay, and a strength 0.2 % higher: each misses the break by more than a
    step."""
    sim, pred, step, _, _ = first_break
    sig, gain, tau = ex.closed_form(sim.processes[0], pred)
    kl4 = E * H**3 / (12 * (1 - NU**2)) / (RHO_W * ex.G) * pred.k**4
    for t in (ex.crossing(sig), ex.crossing(sig / (1 + kl4))):
        assert abs(math.ceil(t / DT) - step) > 1
    assert abs(pred.first_break(STRENGTH, T_R, DT, T_R, order=0)[0] - step) > 1
    assert abs(pred.first_break(STRENGTH * 1.002, T_R, DT, T_R)[0] - step) > 1


def test_holding_the_ice_still_is_the_engines_run():
    """Stepping the process alone (the ice held still) gives the vertical motion of the full
    engine's run at its stable step, whose in-plane joints' forces from round-off move the ice
    by a fraction of a micrometre: a 60 m strip, 2 s of waves ramped over 1 s. The loads are
    linear in the wave and change with the shift ``dx`` of the element's centre by at most a
    phase ``k dx``, with its turn ``dtheta`` by at most ``dtheta (1 + k R)`` (the principal axes
    and the quadrature points, ``R`` the element's radius), so heave and pitch agree within
    that share of their largest value."""
    from siku_plugins.floating.kernels import centres_and_frames

    runs, moved = [], [0.0, 0.0]
    for engine in (True, False):
        sim = ex.strip_in_waves(duration=2.0, n=20, dt=5e-4, ramp=1.0)
        assert sim.dt <= sim.scene.cfg.run.dt_safety * sim.critical_dt
        fld = sim.processes[0].field
        lat, lon, _, e1 = centres_and_frames(sim.state.q)
        x0, e10 = np.array(fld.plane(lat, lon)), e1
        while sim.step_index < sim.n_steps:
            if engine:
                sim.step()
                lat, lon, _, e1 = centres_and_frames(sim.state.q)
                moved[0] = max(moved[0], np.max(np.abs(np.array(fld.plane(lat, lon)) - x0)))
                moved[1] = max(moved[1], np.max(np.abs(e1 - e10)))
            else:
                ex.advance(sim)
        f = sim.context.fields
        runs.append(np.r_[f["heave"], f["pitch"]])
    k, R = float(fld.k[0]), float(np.max(sim.state.radius))
    assert 0 < moved[0] < 1e-6
    share = k * moved[0] + moved[1] * (1 + k * R)
    n = len(runs[0]) // 2
    for part in (slice(0, n), slice(n, None)):
        np.testing.assert_allclose(runs[1][part], runs[0][part], rtol=0,
                                   atol=share * np.max(np.abs(runs[0][part])))
