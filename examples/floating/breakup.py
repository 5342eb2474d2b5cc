"""A long floating strip in waves of slowly rising amplitude breaks in flexure: where, when, and
into what.

A strip of 150 square elements of 3 m (450 m; ice 1 m thick, E = 1 GPa, nu = 0.3:
characteristic length ``l = (D / rho_w g)^(1/4)`` = 9.8 m) lies along the path of 10 s
deep-water waves (wavelength 157 m, ``k l`` = 0.39) whose load grows as ``(1 - cos(pi t /
T_r)) / 2`` over ``T_r`` = 100 s to amplitude 0.5 m. The ``floating`` process (``bending =
true``, the scene's added mass and damping: ``coefficients = "scene"``) moves every element
in heave and pitch and breaks a joint in flexure when its bending
stress ``6 M / (w h²)`` exceeds 200 kPa. The ice is held still in the plane (the horizontal
forces are off and only the process is stepped, as ``examples/waves/breaking.py`` does for the
quasi-static criterion).

The script prints (``tests/test_floating_breakup.py`` asserts the same):

1. the first break against the prediction of ``siku_plugins.floating.steady`` (the strip's
   linear steady state with the ramp's adiabatic series), the infinite thin plate's closed form
   and the uncorrected estimates;
2. the fragments after 150 s (the ramp and five periods at full amplitude) against the
   quasi-static criterion (``[[forcing]] source = "waves"``, ``breaking = true``) on the same
   strip held still at full amplitude, its critical strain ``(1 - nu²) sigma_c / E``, the strain
   at which a thin plate that follows the surface carries the strength.

Run ``python examples/floating/breakup.py`` (about half a minute).
"""
from __future__ import annotations

import importlib.util
import math
import warnings
from pathlib import Path

import numpy as np

G, RHO_W, RHO_I = 9.81, 1026.0, 910.0
N, SIDE, H, E, NU = 150, 3.0, 1.0, 1e9, 0.3
PERIOD, AMP, T_R, STRENGTH, DT = 10.0, 0.5, 100.0, 2e5, 0.02
M_DEG = 1.0 / 111194.92664455873   # one metre of longitude at the equator [deg]


def strip_in_waves(strength: float = STRENGTH, duration: float = T_R, n: int = N,
                   dt: float = DT, ramp: float = T_R):
    """The strip of the module docstring as a ``Simulation`` (``n`` elements, steps ``dt``
    [s], the load's ramp ``ramp`` [s])."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    lon = n * SIDE * M_DEG / 2
    txt = f"""
title = "floating strip in waves of rising amplitude"
[time]
duration = {duration}
dt = {dt}
[materials.ice]
density = {RHO_I}
youngs_modulus = {E}
poisson_ratio = {NU}
[elements]
thickness = {H}
[[elements.pack]]
lon = [{-lon}, {lon}]
lat = [{-SIDE * M_DEG / 2}, {SIDE * M_DEG / 2}]
nx = {n}
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
[process.params]
bending = true
ramp = {ramp}
flexural_strength = {strength}
steps_per_period = 8
coefficients = "scene"
"""
    with warnings.catch_warnings():     # dt is above the in-plane joints' step: never stepped
        warnings.filterwarnings("ignore", message=".*allow_unstable_dt = true")
        return Simulation(scene_from_text(txt, "<breakup>"), out=False, progress=False)


def advance(sim) -> None:
    """One step of the floating process alone, the ice held still in the plane."""
    sim.step_index += 1
    sim.processes[0].apply(sim.context, sim.dt)


def closed_form(proc, pred):
    """The infinite thin plate (``steady.thin_plate``) of the strip: the stress [Pa] of a plate
    that follows the wave, its gain ``|H| sinc²(k s / 2)`` and group delay [s]."""
    from siku_plugins.floating.steady import thin_plate

    mu, beta = proc.M3[0] / proc.C3[0], proc.B3[0] / proc.C3[0]
    sig, Hc, tau = thin_plate(E, NU, H, AMP, pred.omega, pred.k, RHO_W, G, RHO_I, mu, beta)
    ks = pred.k * SIDE
    return sig, abs(Hc) * (math.sin(ks / 2) / (ks / 2)) ** 2, tau


def crossing(amplitude: float, delay: float = 0.0) -> float:
    """Time [s] at which ``amplitude r(t - delay)`` reaches the strength."""
    return delay + T_R / math.pi * math.acos(1 - 2 * STRENGTH / amplitude)


def fragments(cm) -> np.ndarray:
    """Lengths [m] of the pieces of the strip, in order along it."""
    cut = np.flatnonzero(~cm.intact)
    edges = np.sort(np.maximum(cm.ji[cut], cm.jj[cut]))
    return np.diff(np.r_[0, edges, N]) * SIDE


def quasi_static() -> tuple[np.ndarray, float]:
    """The same strip broken by the quasi-static criterion at full amplitude (32 phases of a
    period, ``examples/waves/breaking.py``): its fragment lengths [m] and ``L_c`` [m]."""
    path = Path(__file__).resolve().parents[1] / "waves" / "breaking.py"
    spec = importlib.util.spec_from_file_location("breaking_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    eps = (1 - NU**2) * STRENGTH / E
    cm, _ = mod.strip(N * SIDE, SIDE, AMP, period=PERIOD, E=E, eps=eps)
    return fragments(cm), mod.critical_length(AMP, PERIOD, E, H, eps)


def main() -> None:  # pragma: no cover - a demonstration
    from siku_plugins.floating.steady import Steady

    sim = strip_in_waves(duration=150.0)
    proc, cm = sim.processes[0], sim.contacts
    pred = Steady(proc, sim.context)
    n, j, low, high = pred.first_break(STRENGTH, T_R, DT, T_R)
    while cm.intact.all():
        advance(sim)
    step, broken = sim.step_index, np.flatnonzero(~cm.intact)
    x0 = pred.x_joint[0] - SIDE              # the up-wave end (joint 0 is one element in)
    sig, gain, tau = closed_form(proc, pred)
    D = E * H**3 / (12 * (1 - NU**2))
    ell = (D / (RHO_W * G)) ** 0.25
    mid = np.abs(pred.S[0][len(pred.S[0]) // 2])
    edge = np.max(np.abs(pred.S[0])) / mid - 1
    print(f"strip {N * SIDE:g} m of {SIDE:g} m elements, l = {ell:.2f} m; waves {PERIOD:g} s "
          f"(k l = {pred.k * ell:.3f}), amplitude up to {AMP:g} m over {T_R:g} s; strength "
          f"{STRENGTH / 1e3:g} kPa; steps of {DT:g} s")
    print(f"strip:      first break at t = {step * DT:.3f} s (step {step}), joint(s) "
          f"{', '.join(str(b) for b in broken)}, {pred.x_joint[broken[0]] - x0:.1f} m from "
          "the up-wave end")
    print(f"prediction: t = {n * DT:.3f} s (step {n}), joint {j}; margins at the steps before "
          f"and at it {low:+.2e}, {high:+.2e} of the strength")
    print(f"thin plate: following the wave {sig / 1e3:.1f} kPa, x |H| sinc^2 = {gain:.5f} "
          f"(the strip's middle: {mid / sig:.5f}), group delay {tau:.3f} s: "
          f"t = {crossing(sig * gain, tau):.3f} s (the edge wave of the free end adds "
          f"{100 * edge:.2f} % near it)")
    kl4 = D * pred.k**4 / (RHO_W * G)
    print(f"uncorrected: a plate following the wave t = {crossing(sig):.3f} s, with its "
          f"stiffness only t = {crossing(sig / (1 + kl4)):.3f} s, steady state without the "
          f"group delay t = {pred.first_break(STRENGTH, T_R, DT, T_R, order=0)[0] * DT:.3f} s")
    while sim.step_index < sim.n_steps:
        advance(sim)
    mine = fragments(cm)
    qs, L_c = quasi_static()
    for name, f in (("floating, 150 s", mine), ("quasi-static", qs)):
        print(f"{name:16s} {len(f):3d} fragments, mean {f.mean():5.1f} m, median "
              f"{np.median(f):5.1f} m, {f.min():g}-{f.max():g} m")
    print(f"quasi-static critical length L_c = {L_c:.1f} m")
    print("floating pieces [m]: " + " ".join(f"{v:g}" for v in mine))
    print("quasi-static pieces [m]: " + " ".join(f"{v:g}" for v in qs))


if __name__ == "__main__":  # pragma: no cover
    main()
