"""Run the ice-edge experiment (miz.toml) and draw what it shows.

    python examples/miz/run.py [--out DIR]      # about a minute

Writes DIR/miz.h5 (the run), DIR/miz.fsd.nc (siku fsd) and DIR/miz.png: (a) the significant
wave height at the elements against distance from the ice edge and time, with the breakup front
(the farthest broken joint); (b) the amplitude attenuation rate k_i against frequency fitted to
the spectrum in the ice at the end (ln E_j against x, k_i = -slope / (2 C)) beside the law the
scene uses and the range of Rogers et al. (2016) for pancake and frazil ice (k_i from 1e-6 to
1e-5 1/m over 0.05-0.15 Hz, as Orzech et al. 2018 quote it); (c) the floe size distribution at
the end with its power-law exponent (observed: 1.65-2.03 for areas 50 m2 to 5 km2, Denton &
Timmermans 2022). Prints the numbers.
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="folder for the files (default: here)")
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    h5 = out / "miz.h5"
    subprocess.run([sys.executable, "-m", "siku_core.cli", "run", str(HERE / "miz.toml"),
                    "--out", str(h5), "--overwrite", "--no-progress"], check=True)
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from siku_core.scene import load_scene
    from siku_core.simulation import Simulation
    from siku_io.analysis.fsd import output_distribution

    sim = Simulation(load_scene(HERE / "miz.toml"), out=False, progress=False)
    f = sim.forcing[0].field
    with h5py.File(h5, "r") as g:
        n = len(g["states/step"])
        t = g["states/time"][:n]
        lat, lon = np.radians(g["states/lat"][:n]), np.radians(g["states/lon"][:n])
        hs = g["states/fields/wave_height"][:n]
        E = g["states/history/field1_spectral/E"][n - 1]
        bt, blat, blon = (g[f"breaks/{k}"][()] for k in ("time", "lat", "lon"))
    x = np.array([f.plane(lat[i], lon[i])[0] for i in range(n)])
    bx = f.plane(np.radians(blat), np.radians(blon))[0] if len(bt) else np.zeros(0)
    front = [bx[bt <= s].max() if (bt <= s).any() else np.nan for s in t]

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    sc = ax[0].scatter(np.ravel(x), np.repeat(t, x.shape[1]), c=np.ravel(hs), s=4,
                       cmap="viridis")
    ax[0].plot(front, t, "r-", label="breakup front")
    fig.colorbar(sc, ax=ax[0], label="significant wave height [m]")
    ax[0].set(xlabel="distance from the ice edge [m]", ylabel="time [s]")
    ax[0].legend(loc="lower right")

    xc = f.x0 + (np.arange(f.nx) + 0.5) * f.dx
    ice = (xc > 0) & (xc < 600)
    C = f.C.mean(axis=0)[ice].mean()
    fit = []
    for j in range(E.shape[0]):
        e = E[j].mean(axis=0)[ice]
        fit.append(-np.polyfit(xc[ice], np.log(e), 1)[0] / (2 * C))
    freq = f.f
    law = f.law.rate(freq, 1.0, f.h)
    ax[1].loglog(freq, fit, "o", label="fitted to the spectrum in the ice")
    ax[1].loglog(freq, law, "k-", label=f"law: {f.law.name}, h = 1 m")
    ax[1].loglog([0.05, 0.15], [1e-6, 1e-5], "r--",
                 label="Rogers et al. (2016), pancake/frazil ice")
    ax[1].set(xlabel="frequency [Hz]", ylabel="amplitude attenuation rate k_i [1/m]")
    ax[1].legend(fontsize=8)

    ds = output_distribution(h5, min_tail=5)
    ds.attrs["kind"] = "siku floe size distribution"
    ds.to_netcdf(out / "miz.fsd.nc")
    last = ds.sizes["time"] - 1
    p, xb = ds["pdf"].values[last], ds["area_bin"].values
    ok = p > 0
    a, se, amin = (float(ds[k].values[last]) for k in ("alpha", "alpha_se", "area_min"))
    ax[2].loglog(xb[ok], p[ok], "o-", label=f"t = {t[-1]:g} s, {int(ds['n_floes'][last])} floes")
    ax[2].set(xlabel="floe area [m²]", ylabel="probability density [1/m²]",
              title=f"alpha = {a:.2f} ± {se:.2f} above {amin:.3g} m²\n(observed: 1.65-2.03)")
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "miz.png", dpi=110)

    print(f"front: {np.nanmax(front):.0f} m from the edge at the end; at each snapshot: "
          + ", ".join(f"{s:g} s {v:.0f} m" for s, v in zip(t, front) if math.isfinite(v)))
    print("k_i fitted / law at " + ", ".join(
        f"{q:.3f} Hz {u:.3g}/{w:.3g}" for q, u, w in zip(freq, fit, law)))
    print(f"floes at the end: {int(ds['n_floes'][last])}; alpha = {a:.3f} ± {se:.3f} above "
          f"{amin:.4g} m2 ({int(ds['n_tail'][last])} floes)")
    print(f"{out / 'miz.png'}")


if __name__ == "__main__":
    main()
