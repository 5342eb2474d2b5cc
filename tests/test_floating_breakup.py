"""Breakup by waves (issue 42): a long floating strip in waves of slowly rising amplitude breaks
first at the joint and the step that the linear steady state of a thin plate following the wave
predicts, and the infinite plate's closed form predicts its stress in the strip's middle.

The case (``examples/floating/breakup.py`` prints the same numbers): a strip of 150 square
elements of 3 m (450 m; 1 m thick, E = 1 GPa, nu = 0.3: characteristic length ``l = (D / rho_w
g)^{1/4}`` = 9.77 m, so the strip is 46 l long and an element is 0.31 l) along the path of 10 s
deep-water waves (wavelength 157 m, ``k l`` = 0.39: long against l; the elements' heave period
2.6 s: slow against it) whose load rises as ``(1 - cos(pi t / T_r)) / 2`` over ``T_r`` = 100 s
(ten periods) to amplitude 0.5 m; flexural strength 200 kPa, reached at about 47 s. The
``floating`` process moves the elements in heave and pitch with the default constant added mass
and damping, steps of ``dt`` = 0.02 s (T / 500) and 8 sub-steps per shortest period (its
stiffest beam mode, 17 ms), and checks the joints' stress after every step. The ice is held
still in the plane (the process is applied step by step with the horizontal forces off, as
``examples/waves/breaking.py`` does for the quasi-static criterion): in linear theory the
vertical motion does not move the elements horizontally, and the engine's step for the 1 GPa
in-plane joints (4e-4 s) would cost 50 times as many steps.

**The prediction** (``siku_plugins.floating.steady``): the thin plate's equations as the model
discretises them (Hermite beams between the element centres on the elements' buoyancy, with
inertia and added mass, damping and the element-averaged Froude–Krylov load at the draft) are
solved for their steady state ``H(omega) F`` with the free ends, and the ramp enters by the
adiabatic series ``r H F + i r' H' F - r'' H'' F / 2``; the first step end at which a joint's
stress exceeds the strength is the predicted step and that joint the predicted place. In the
middle of the strip this is the closed form of an infinite thin plate
(``steady.thin_plate``): the stress of a plate that follows the wave, ``E h a k² e^{-k d} / (2
(1 - nu²))`` = 428.7 kPa, times the response ``|H| = 1 / |1 + (k l)^4 - omega² (m + A33) /
(rho_w g A) - i omega B33 / (rho_w g A)|`` = 1.0387 (its own stiffness 0.024, inertia and
added mass 0.065, damping 0.088 in quadrature), times ``sinc²(k s / 2)`` = 0.9988 (the load's
average over an element and the joint's curvature from the slope difference, ``s`` the
element), with the envelope delayed by the group delay ``tau = d arg H / d omega`` = 0.164 s
(eight steps): to 1.1e-4, the moment of the weight of the tilted thick elements (``A d (h -
d) / 2`` in their restoring, relative ``k² d (h - d) / 2`` = 8e-5) that thin-plate theory
leaves out.

**Neglected in the prediction, bounded** (test 1 computes each): the next term of the
adiabatic series ``r''' |H''' F| / 6`` (below 1e-8 of the strength at the break); the free
oscillation the start leaves (the series is not at rest at ``t = 0``: at most ``r''(0) |H'' F|
/ 2``, 3e-6, and damped since); the sub-steps' error on the forced response ``(omega
delta_t)² / 12`` (1e-7); the clamp of the buoyancy, never reached (the elements' heave
relative to the wave, 0.02 m, stays inside the 0.11 m freeboard). Their sum, 4e-6 of the
strength, is less than the margins by which the predicted stress stays below the strength at
the step before (-5e-4) and exceeds it at the predicted step (+3.5e-4): the strip must break at
the predicted step, at the predicted joint (the next highest joint then is below the strength
by more than the sum). Measured: the strip's stress at the step before the break is the
prediction's to 5e-6 of the strength, and it breaks at the predicted step (46.88 s) and joint
(87 m from the up-wave end).

The closed form alone predicts 46.914 s, two steps later: the strip breaks first where the
edge wave of its free up-wave end adds 0.19 % to the amplitude, which at the ramp's rate ``r' /
r`` = 0.035 /s is 0.053 s earlier (asserted: within that and one step). The test can fail: a
plate that follows the wave would break 48 steps later, with its stiffness alone 83 steps
later, without the group delay 9 steps earlier, and a strength 0.1 % higher one step later
(asserted).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from siku_core.scene import scene_from_text
from siku_core.simulation import Simulation
from siku_plugins.floating.steady import Steady, ramp, thin_plate

RHO_W, G, RHO_I = 1026.0, 9.81, 910.0
N, SIDE, H, E, NU = 150, 3.0, 1.0, 1e9, 0.3
PERIOD, AMP, T_R, STRENGTH, DT = 10.0, 0.5, 100.0, 2e5, 0.02
M_DEG = 1.0 / 111194.92664455873   # one metre of longitude at the equator [deg]


def strip_in_waves(strength=STRENGTH, duration=T_R):
    """The strip of the module docstring, its process and its contacts."""
    lon = N * SIDE * M_DEG / 2
    txt = f"""
title = "floating strip in waves of rising amplitude"
[time]
duration = {duration}
dt = {DT}
[materials.ice]
density = {RHO_I}
youngs_modulus = {E}
poisson_ratio = {NU}
[elements]
thickness = {H}
[[elements.pack]]
lon = [{-lon}, {lon}]
lat = [{-SIDE * M_DEG / 2}, {SIDE * M_DEG / 2}]
nx = {N}
ny = 1
[contact]
law = "distributed_spring"
[run]
allow_unstable_dt = true
[[forcing]]
source = "waves"
params = {{ drag = false, slope = false }}
[forcing.field]
type = "linear_wave"
params = {{ amplitude = {AMP}, period = {PERIOD}, direction = 90.0, origin = [0.0, 0.0] }}
[[process]]
name = "floating"
params = {{ bending = true, ramp = {T_R}, flexural_strength = {strength}, steps_per_period = 8 }}
"""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*allow_unstable_dt = true")
        return Simulation(scene_from_text(txt, "<breakup>"), out=False, progress=False)


def advance(sim) -> None:
    """One step of the floating process alone, the ice held still in the plane."""
    sim.step_index += 1
    sim.processes[0].apply(sim.context, sim.dt)


@pytest.fixture(scope="module")
def first_break():
    """Run the strip to its first break: the prediction, the step and joints of the break,
    and the stresses [Pa] at the step before it."""
    sim = strip_in_waves()
    proc, cm = sim.processes[0], sim.contacts
    pred = Steady(proc, sim.context)
    before = None
    while cm.intact.all() and sim.step_index < sim.n_steps:
        before = proc.stresses(sim.context)
        advance(sim)
    return sim, pred, sim.step_index, np.flatnonzero(~cm.intact), before


def plate(proc, pred):
    mu, beta = proc.M3[0] / proc.C3[0], proc.B3[0] / proc.C3[0]
    sig, Hc, tau = thin_plate(E, NU, H, AMP, pred.omega, pred.k, RHO_W, G, RHO_I, mu, beta)
    ks = pred.k * SIDE
    return sig, abs(Hc) * (math.sin(ks / 2) / (ks / 2)) ** 2, tau


def crossing(amplitude, delay=0.0):
    """Time [s] at which ``amplitude ramp(t - delay)`` reaches the strength."""
    return delay + T_R / math.pi * math.acos(1 - 2 * STRENGTH / amplitude)


def test_the_strip_breaks_first_at_the_predicted_joint_and_step(first_break):
    sim, pred, step, broken, before = first_break
    proc = sim.processes[0]
    n, j, low, high = pred.first_break(STRENGTH, T_R, DT, T_R)
    assert n > 0 and 10 * PERIOD / 4 < n * DT < T_R          # many periods into the ramp
    # the neglected terms, bounded, relative to the strength (module docstring)
    t = n * DT
    fourth = np.max(np.abs(ramp(t, T_R, 4) * pred.S[4])) / 24
    gamma = np.min(np.r_[proc.B3 / proc.M3, proc.B1 / proc.M1, proc.B2 / proc.M2]) / 2
    assert np.all(gamma * np.r_[proc.B3, proc.B1, proc.B2] < np.r_[proc.C3, proc.C1, proc.C2])
    start = (math.pi / T_R) ** 2 / 4 * np.max(np.abs(pred.S[2])) * math.exp(-gamma * t)
    sub = pred.omega * DT / math.ceil(DT * 8 / proc.period_min)
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
    from siku_core.contact_law import BreakMode
    assert np.all(sim.contacts.break_mode[broken] == int(BreakMode.FLEXURE))


def test_the_middle_of_the_strip_is_the_infinite_thin_plate(first_break):
    """The prediction's stress amplitude and group delay in the middle of the strip are the
    closed form's, within the weight-moment term it leaves out (and the discreteness beyond
    sinc², ``(k s)^4 / 10``); the closed form's break time is the strip's within the edge
    wave's gain at the ramp's rate and one step."""
    sim, pred, step, broken, _ = first_break
    proc = sim.processes[0]
    sig, gain, tau = plate(proc, pred)
    m = len(pred.S[0]) // 2
    d = H * RHO_I / RHO_W
    ks = pred.k * SIDE
    tol = pred.k**2 * d * (H - d) + ks**4 / 10
    assert abs(abs(pred.S[0][m]) / (sig * gain) - 1) < tol
    assert abs((pred.S[1][m] / pred.S[0][m]).imag / tau - 1) < tol + ks**2 / 12
    edge = np.max(np.abs(pred.S[0])) / abs(pred.S[0][m]) - 1
    t_c = crossing(sig * gain, tau)
    rate = ramp(t_c, T_R, 1) / ramp(t_c, T_R)
    assert 0 <= t_c - step * DT <= edge / rate + DT


def test_the_uncorrected_predictions_miss(first_break):
    """A plate that follows the wave, one with only its own stiffness, the steady state without
    the ramp's group delay, and a strength 0.2 % higher: each misses the break by more than a
    step."""
    sim, pred, step, _, _ = first_break
    sig, gain, tau = plate(sim.processes[0], pred)
    kl4 = E * H**3 / (12 * (1 - NU**2)) / (RHO_W * G) * pred.k**4
    for t in (crossing(sig), crossing(sig / (1 + kl4))):
        assert abs(math.ceil(t / DT) - step) > 1
    assert abs(pred.first_break(STRENGTH, T_R, DT, T_R, order=0)[0] - step) > 1
    assert abs(pred.first_break(STRENGTH * 1.002, T_R, DT, T_R)[0] - step) > 1
