"""The wave–ice paper's two floating tests, run in siku and printed beside its values.

Orzech et al. (2018) report for a 10 m × 10 m × 1 m ice block (their Figs. 4 and 6):

* released about 0.2 m above its floating position in still water, it bounces with a period
  of 2.2–2.4 s and a ratio between successive peaks of 0.82–0.92;
* in 0.5 m waves of 0.2 Hz, it heaves at about half the wave amplitude and lags the waves by
  about 1 s.

This script runs ``bouncing_block.toml`` and ``floe_in_waves.toml`` (the ``floating`` process
with capytaine's coefficients: the optional extra ``siku[hydro]``), measures the period and peak
ratio, and the steady heave amplitude and lag, and prints them beside the damped oscillator and
the response amplitude operator (RAO) built from capytaine's coefficients and beside the
paper's values. ``--plot FILE.png`` also draws both time series.

Run from anywhere: ``python examples/floating/table.py [--plot floating.png]`` (the first run
computes capytaine's coefficients, a few tens of seconds; later runs read them from the cache).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def run(scene: str, old: str = "", new: str = ""):
    """Run a scene of this folder in memory (its text with ``old`` replaced by ``new``);
    times [s], heave [m] and the simulation."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    path = HERE / scene
    text = path.read_text().replace(old, new) if old else path.read_text()
    sim = Simulation(scene_from_text(text, str(path)), out=False, progress=False)
    t, z = [], []
    for _ in range(sim.n_steps):
        sim.step()
        t.append(sim.time)
        z.append(sim.context.fields["heave"][0])
    return np.array(t), np.array(z), sim


def peaks(t, z):
    """Times and values of the maxima (parabola through three samples)."""
    k = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:])) + 1
    a, b, c = z[k - 1], z[k], z[k + 1]
    off = 0.5 * (a - c) / (a - 2 * b + c)
    return t[k] + off * (t[1] - t[0]), b - 0.25 * (a - c) * off


def bouncing():
    t, z, sim = run("bouncing_block.toml")
    p = sim.processes[0]
    M, B, C = p.M3[0], p.B3[0], p.C3[0]
    wn = math.sqrt(C / M)
    zeta = B / (2 * math.sqrt(M * C))
    Td = 2 * math.pi / (wn * math.sqrt(1 - zeta**2))
    tp, zp = peaks(t, z)
    rows = [("period [s]", np.mean(np.diff(tp[:4])), None, Td, "2.2–2.4"),
            ("ratio of successive peaks", np.mean(zp[1:4] / zp[:3]), None,
             math.exp(-zeta * wn * Td), "0.82–0.92")]
    extra = (f"(m = {sim.state.m[0]:.4g} kg, A33 = "
             f"{M - sim.state.m[0]:.4g} kg, B33 = {B:.4g} kg/s, damping ratio {zeta:.3f})")
    return rows, extra, (t, z)


def steady(t, z, w):
    """Complex amplitude X of the last four periods, z = Re(X e^{-i w t})."""
    keep = t >= t[-1] - 4 * 2 * math.pi / w
    Mx = np.column_stack([np.cos(w * t[keep]), np.sin(w * t[keep])])
    c, s = np.linalg.lstsq(Mx, z[keep], rcond=None)[0]
    return complex(c, s)


def waves():
    t, z, sim = run("floe_in_waves.toml")
    p = sim.processes[0]
    fld = p.field
    a, w = float(fld.amp[0]), float(fld.omega[0])
    X = steady(t, z, w) / a                # eta = a cos(w t) at the floe's centre
    # the same floe in 2 cm waves: within its freeboard, the linear response
    t2, z2, _ = run("floe_in_waves.toml", "amplitude = 0.25", "amplitude = 0.02")
    X2 = steady(t2, z2, w) / 0.02
    from siku_plugins.floating import hydro

    # capytaine's RAO of the same prism, at the wave's frequency
    poly = sim.state.polygon(0)
    width = 2 * float(np.min(np.abs(poly).max(axis=0)))
    bod = hydro.body(poly, p.draft[0], p.h[0], width / 16.0)
    rho, g = p.p["rho_water"], p.p["g"]
    A33, B33 = hydro.radiation(bod, "Heave", w, rho, g)
    fk, dif = hydro.excitation(bod, w, rho, g)["Heave"]
    den = p.C3[0] - w * w * (sim.state.m[0] + A33) - 1j * w * B33
    rao, rao_fk = (fk + dif) / den, fk / den
    lag = lambda x: (np.angle(x) % (2 * math.pi)) / w  # noqa: E731 - seconds behind eta
    rows = [("heave amplitude / wave amplitude", abs(X), abs(X2), abs(rao), "about 1/2"),
            ("lag behind the waves [s]", lag(X), lag(X2), lag(rao), "about 1")]
    extra = (f"(0.2 Hz, amplitude {a:g} m; Froude–Krylov load alone would give "
             f"{abs(rao_fk):.3f} and {lag(rao_fk):.2f} s)")
    return rows, extra, (t, z, a * np.cos(w * t))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", type=Path, help="also draw both time series to this PNG")
    args = ap.parse_args(argv)
    out = []
    for title, (rows, extra, series) in (("bouncing block (Fig. 4)", bouncing()),
                                         ("floe in waves (Fig. 6)", waves())):
        print(f"\n{title} {extra}")
        print(f"  {'':34s} {'siku':>8s} {'siku, 2 cm':>10s} {'capytaine':>10s}  "
              "Orzech et al. 2018")
        for name, got, small, ref, paper in rows:
            mid = f"{small:10.3f}" if small is not None else f"{'':10s}"
            print(f"  {name:34s} {got:8.3f} {mid} {ref:10.3f}  {paper}")
        out.append(series)
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(2, 1, figsize=(7, 5), constrained_layout=True)
        t, z = out[0]
        ax[0].plot(t, z)
        ax[0].set(title="bouncing block", xlabel="t [s]", ylabel="heave [m]")
        t, z, eta = out[1]
        ax[1].plot(t, eta, label="wave elevation at the floe")
        ax[1].plot(t, z, "--", label="heave")
        ax[1].set(title="floe in 0.2 Hz waves", xlabel="t [s]", ylabel="[m]")
        ax[1].legend(loc="lower right")
        fig.savefig(args.plot, dpi=110)


if __name__ == "__main__":
    main()
