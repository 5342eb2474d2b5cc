"""Waves break a long floe into pieces: fragment size against wave amplitude.

A strip of ice (1 m thick, 200 m long, 2 m elements frozen together) lies along the path of
monochromatic deep-water waves (period 8 s, wavelength 100 m). With ``[[forcing]] source =
"waves"`` and ``breaking = true`` (``siku_forcing.waves.wave_breaking``) joints break where the
flexural strain the strip would carry exceeds the critical strain (3e-5); each check breaks the
most strained joint of every floe and judges the pieces again. The checks run at 32 phases of one
wave period with the ice held still (only the breaking acts), which is the quasi-static situation
the breaking model assumes.

Theory (module docstring of ``wave_breaking``): a piece shorter than ``L_c = (64 E h² eps_c /
(rho_w g a k²))^(1/4)`` cannot break, and a piece much longer than that does, so fragments end
between about ``L_c / 2`` and ``L_c`` (the elements' size rounds them), and shrink as
``a^(-1/4)``.

Run ``python examples/waves/breaking.py [OUT.png]`` (draws ``wave_breaking.png`` in the working
directory; ``docs/gallery/make_gallery.py`` draws the gallery's copy).
"""
from __future__ import annotations

import math

import numpy as np

R = 6_371_000.0
G = 9.81
RHO_W = 1026.0


def critical_length(a, period=8.0, E=1e9, h=1.0, eps=3e-5):
    """``L_c`` [m] of a strip under a crest of amplitude ``a`` [m] in deep water."""
    k = (2 * math.pi / period) ** 2 / G
    return (64 * E * h * h * eps / (RHO_W * G * a * k * k)) ** 0.25


def strip(L, D, a, period=8.0, E=1e9, eps=3e-5, phases=32):
    """Break a strip of ``L / D`` square elements of side ``D`` [m] with waves of amplitude
    ``a`` [m]: returns the run's contact model and the fragment lengths [m]."""
    from siku_core.run.simulation import Simulation
    from siku_core.testing import make_scene

    dlon, dlat = math.degrees(L / R), math.degrees(D / R)
    wave = {"type": "linear_wave", "params": {"amplitude": a, "period": period,
                                              "direction": 90.0, "origin": [0.0, 0.0]}}
    sc = make_scene([], packs=[{"lon": [-dlon / 2, dlon / 2], "lat": [-dlat / 2, dlat / 2],
                                "nx": int(round(L / D)), "ny": 1}],
                    thickness=1.0, dt=1e-4, duration=1e-4,
                    materials={"ice": {"youngs_modulus": E}},
                    forcing=[{"source": "waves", "params": {
                        "breaking": True, "drag": False, "slope": False,
                        "critical_strain": eps}, "field": wave}],
                    extra='[contact]\nlaw = "distributed_spring"\n'
                          'params = {tensile_strain = 1.0}\n',
                    run={"allow_unstable_dt": True})
    sim = Simulation(sc, out=False, progress=False)
    breaker = sim.forcing[0].breaker
    for t in np.linspace(0.0, period, phases + 1)[:-1]:
        breaker.check(t, sim.state.q)
    cm = sim.contacts
    _, label = cm.floe_labels()
    return cm, np.bincount(label) * D


def main(out="wave_breaking.png"):  # pragma: no cover - a demonstration
    import matplotlib.pyplot as plt

    amps = np.array([0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0])
    sizes = [strip(200.0, 2.0, a)[1] for a in amps]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for a, s in zip(amps, sizes):
        ax.plot(np.full(len(s), a), s, ".", color="0.6", ms=4)
    ax.plot(amps, [s.mean() for s in sizes], "o-", label="mean fragment length")
    aa = np.linspace(amps[0], amps[-1], 200)
    ax.plot(aa, critical_length(aa), "k--", label="critical length $L_c$")
    ax.plot(aa, critical_length(aa) / 2, "k:", label="$L_c / 2$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wave amplitude a [m] (period 8 s, deep water)")
    ax.set_ylabel("fragment length [m]")
    ax.set_title("A 200 m strip broken by waves (h = 1 m, E = 1 GPa, eps_c = 3e-5)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=150)
    print("wrote", out)
    for a, s in zip(amps, sizes):
        print(f"a = {a:5.2f} m: {len(s):3d} fragments, mean {s.mean():6.1f} m, "
              f"L_c = {critical_length(a):5.1f} m")


if __name__ == "__main__":  # pragma: no cover
    import sys

    main(*sys.argv[1:2])
