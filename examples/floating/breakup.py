"""A long floating strip in waves of rising amplitude breaks in flexure: where and when.

A strip of ice (1 m thick, 2 m elements frozen together, E = 1 GPa: characteristic length
``l = (D / rho_w g)^(1/4)`` = 9.8 m) 160 m long lies along the path of monochromatic deep-water
waves (period 8 s, wavelength 100 m) whose load grows as ``(1 - cos(pi t / T_r)) / 2`` over
``T_r`` = 24 s to amplitude 0.5 m. The ``floating`` process with ``bending = true`` moves every
element in heave and pitch and breaks a joint in flexure when its bending stress ``6 M /
(w h²)`` exceeds 150 kPa (the horizontal forces are off).

A thin plate that follows the wave has curvature ``a k² e^{-k d} cos(psi)`` and bending stress
``sigma = E h a k² e^{-k d} / (2 (1 - nu²))`` at crests and troughs; its own stiffness makes it
follow less, by ``1 / (1 + (k l)^4)``. The script prints when and where the first joint breaks
beside the time at which those two predictions reach the strength, and the crests and troughs
at that time. Reported, not asserted (``tests/test_floating.py`` checks the beam's statics and
the break criterion).

Run ``python examples/floating/breakup.py`` (about a minute).
"""
from __future__ import annotations

import math

import numpy as np

G, RHO_W, RHO_I = 9.81, 1026.0, 910.0
E, NU, H, A_EL, N = 1e9, 0.3, 1.0, 2.0, 80
PERIOD, AMP, RAMP, STRENGTH = 8.0, 0.5, 24.0, 1.5e5
M_DEG = 1.0 / 111194.92664455873


def scene(duration: float) -> str:
    lon = N * A_EL * M_DEG / 2
    return f"""
title = "floating strip in waves"
[time]
duration = {duration}
dt = 4e-4
[materials.ice]
density = {RHO_I}
youngs_modulus = {E}
poisson_ratio = {NU}
[elements]
thickness = {H}
[[elements.pack]]
lon = [{-lon}, {lon}]
lat = [{-A_EL * M_DEG / 2}, {A_EL * M_DEG / 2}]
nx = {N}
ny = 1
[contact]
law = "distributed_spring"
[[forcing]]
source = "waves"
params = {{ drag = false, slope = false }}
[forcing.field]
type = "linear_wave"
params = {{ amplitude = {AMP}, period = {PERIOD}, direction = 90.0, origin = [0.0, 0.0] }}
[[process]]
name = "floating"
params = {{ bending = true, ramp = {RAMP}, flexural_strength = {STRENGTH} }}
"""


def main() -> None:
    from siku_core.scene import scene_from_text
    from siku_core.simulation import Simulation

    sim = Simulation(scene_from_text(scene(RAMP), "<breakup>"), out=False, progress=False)
    cm = sim.contacts
    first = None
    while sim.step_index < sim.n_steps:
        sim.step()
        if not cm.intact.all():
            first = sim.time
            break
    w = 2 * math.pi / PERIOD
    k = w * w / G
    d = H * RHO_I / RHO_W
    D = E * H**3 / (12 * (1 - NU**2))
    ell = (D / (RHO_W * G)) ** 0.25
    s_full = E * H * AMP * k * k * math.exp(-k * d) / (2 * (1 - NU**2))

    def when(factor):
        r = STRENGTH / (s_full * factor)
        return RAMP / math.pi * math.acos(1 - 2 * r) if r < 1 else math.inf

    print(f"strip {N * A_EL:g} m of {A_EL:g} m elements, l = {ell:.1f} m, waves {PERIOD:g} s "
          f"(wavelength {2 * math.pi / k:.0f} m), amplitude up to {AMP:g} m over {RAMP:g} s")
    print(f"thin plate following the wave reaches {STRENGTH / 1e3:g} kPa at t = "
          f"{when(1.0):.3f} s; with its stiffness, 1 / (1 + (k l)^4) = "
          f"{1 / (1 + (k * ell) ** 4):.3f}: t = {when(1 / (1 + (k * ell) ** 4)):.3f} s")
    if first is None:
        print("no joint broke")
        return
    k_b = np.flatnonzero(~cm.intact)
    x = (0.5 * (cm.ji[k_b] + cm.jj[k_b]) - (N - 1) / 2) * A_EL
    print(f"siku: first break at t = {first:.3f} s at x = "
          f"{', '.join(f'{v:.0f}' for v in x)} m from the centre (joints every {A_EL:g} m)")
    # crests and troughs of the wave at that time: k x - w t = n pi
    ext = [(n * math.pi + w * first) / k for n in range(-20, 21)]
    ext = [e for e in ext if abs(e) <= N * A_EL / 2]
    print("crests and troughs then at x = " + ", ".join(f"{e:.0f}" for e in ext) + " m")


if __name__ == "__main__":
    main()
