"""Run an ice-edge experiment (ice_edge.toml, or the small miz.toml) and draw what it shows.

    python examples/miz/run.py [SCENE] [--out DIR] [--maps T1 T2 ...]

SCENE: ``ice_edge.toml`` (default; the 3 km x 1.5 km Voronoi pack in a directional swell,
about 5.5 minutes on two idle cores) or ``miz.toml`` (the 600 m x 80 m flume, under a minute).
Writes DIR/STEM.h5 (the run), DIR/STEM.fsd.nc (the floe size distribution of every snapshot:
the bins and power-law fit of ``siku fsd``, without the calipers) and DIR/STEM.png:

* top row: the significant wave height of the spectral field's grid at four snapshots, with
  the ice's outline;
* middle row: every element coloured by the area of the floe it belongs to (elements joined by
  intact joints), at the same snapshots;
* bottom row: (a) the breakup front against time, in the middle third of the pack across the
  waves: where the unbroken pack (the largest floe) begins (the median over ten bands of its
  westernmost element) and the farthest broken joint; (b) the amplitude attenuation rate k_i
  against frequency fitted to the spectrum in the ice at the end (per component ``ln E_j``
  against ``x`` over the middle third and the first kilometre of ice, times the cosine of its
  direction, ``/ (2 C)``; the energy-weighted mean over the directions of a frequency) beside
  the law the scene uses, the law as the first-order upwind transport carries it on the grid's
  cells, and the range of Rogers et al. (2016) for pancake and frazil ice (k_i from 1e-6 to
  1e-5 1/m over 0.05-0.15 Hz, as Orzech et al. 2018 quote it); (c) the floe size distribution
  at the end with its power-law exponent, lower cut-off and standard error (Clauset et al.
  2009, as ``siku fsd``), beside the observed exponents 1.65-2.03 for areas 50 m2 to 5 km2
  (Denton & Timmermans 2022); (d) the number of floes and of broken joints over time. Prints the
  numbers.
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _fit_rates(f, E, ice, strip):
    """Per frequency of field ``f``: the amplitude attenuation rate [1/m] fitted to the
    spectrum ``E`` (``(n_comp, ny, nx)``) over the cells ``ice`` (x) and ``strip`` (y)."""
    xc = f.x0 + (np.arange(f.nx) + 0.5) * f.dx
    C = f.C[strip][:, ice].mean()
    cos = np.where(f.cg > 0, f.cx / f.cg, 0.0)  # cosine of the direction from the x axis
    rates = []
    freqs = np.unique(f.f)
    for q in freqs:
        num = den = 0.0
        for j in np.flatnonzero((f.f == q) & (cos > 0.1)):
            e = E[j][strip].mean(axis=0)[ice]
            if (e <= 0).any():
                continue
            k = -np.polyfit(xc[ice], np.log(e), 1)[0] * cos[j] / (2 * C)
            w = f.E_in[j]
            num, den = num + w * k, den + w
        rates.append(num / den if den > 0 else np.nan)
    return freqs, np.array(rates)


def _latlon(q):
    from siku_core.geometry.quat import latlon_of

    return latlon_of(q)


def _discrete_rates(f, dt, freqs, law):
    """The rate [1/m] that the upwind transport of field ``f`` with the engine's step ``dt``
    [s] (the sub-steps the Courant limit asks) gives under full ice of rate ``law``, per
    frequency: ``-ln r cos(theta) / (2 dx)`` of its steady cell-to-cell ratio ``r``
    (``siku_forcing.waves.spectral_transport.steady_ratio``) for a component along ``x`` at the
    angle theta, the energy-weighted mean over the directions, as :func:`_fit_rates` does."""
    from siku_forcing.waves.spectral_transport import steady_ratio

    rate = np.max(np.abs(f.cx) / f.dx + np.abs(f.cy) / f.dy)
    sub = dt / max(1, math.ceil(dt * rate / f.p["cfl"] - 1e-12))
    out = []
    for q, ki in zip(freqs, law):
        num = den = 0.0
        for j in np.flatnonzero((f.f == q) & (f.cx > 0.1 * f.cg)):
            r = steady_ratio(f.cx[j] * sub / f.dx, 2.0 * f.cg[j] * ki * sub)
            k = -math.log(r) * (f.cx[j] / f.cg[j]) / (2.0 * f.dx)
            num, den = num + f.E_in[j] * k, den + f.E_in[j]
        out.append(num / den)
    return np.array(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default="ice_edge.toml",
                    help="scene in examples/miz (default: ice_edge.toml)")
    ap.add_argument("--out", default=".", help="folder for the files (default: here)")
    ap.add_argument("--maps", type=float, nargs=4, help="times of the four maps [s]")
    ap.add_argument("--no-run", action="store_true", help="draw an existing DIR/STEM.h5")
    args = ap.parse_args(argv)
    scene = (HERE / args.scene) if not Path(args.scene).exists() else Path(args.scene)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    h5 = out / f"{scene.stem}.h5"
    if not args.no_run:
        subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(scene), "--out",
                        str(h5), "--overwrite", "--no-progress"], check=True)
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import LogNorm

    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation
    from siku_io.analysis.fsd import distribution, floe_areas, floe_labels
    from siku_core.geometry.element_geometry import polygons_lonlat

    sim = Simulation(load_scene(scene), out=False, progress=False)
    f = sim.forcing[0].field
    cm = sim.contacts
    with h5py.File(h5, "r") as g:
        n = len(g["states/step"])
        t = g["states/time"][:n]
        q = g["states/q"][:n]
        Es = g["states/history/field1_spectral/E"][:n]
        intact = g["states/history/contacts/intact"][:n].astype(bool)
        area = g["geometry/area"][()]
        off, verts = g["geometry/vert_offsets"][()], g["geometry/verts"][()]
        radius = float(g.attrs["radius"])
        bt, blat, blon = (g[f"breaks/{k}"][()] for k in ("time", "lat", "lon"))
    # the ice in the plane of the field (it does not move: no drag, no slope force)
    poly = polygons_lonlat(q[0], off, verts, radius)
    ll = np.concatenate(poly)
    vx, vy = f.plane(np.radians(ll[:, 1]), np.radians(ll[:, 0]))
    xy = np.column_stack([vx, vy])
    cells = [xy[off[i]:off[i + 1]] for i in range(len(area))]
    x_edge, x_end = float(vx.min()), float(vx.max())
    y_lo, y_hi = float(vy.min()), float(vy.max())
    third = (y_hi - y_lo) / 3.0
    bx, by = (f.plane(np.radians(blat), np.radians(blon)) if len(bt)
              else (np.zeros(0), np.zeros(0)))
    mid = np.abs(by - 0.5 * (y_lo + y_hi)) <= 0.5 * third
    reach = np.array([bx[mid & (bt <= s)].max() - x_edge if (mid & (bt <= s)).any()
                      else np.nan for s in t])

    floes = [floe_labels(len(area), cm.ji, cm.jj, intact[i]) for i in range(n)]
    areas = [floe_areas(lab, c, area) for c, lab in floes]
    # the front: where the unbroken pack (the largest floe) begins, the median over ten bands
    # of the middle third of the westernmost element of that floe in the band
    ex, ey = f.plane(*_latlon(q[0]))
    band = np.floor((ey - (0.5 * (y_lo + y_hi) - 0.5 * third)) / (third / 10)).astype(int)
    front = []
    for (c, lab), a_ in zip(floes, areas):
        big = lab == np.argmax(a_)
        xs = [ex[big & (band == b)].min() for b in range(10) if (big & (band == b)).any()]
        front.append(float(np.median(xs)) - x_edge if xs else np.nan)
    front = np.array(front)
    ds = distribution(areas, t, min_tail=10)
    ds.attrs["kind"] = "siku floe size distribution"
    ds.attrs["source"] = f"examples/miz/run.py {scene.name}"
    ds.to_netcdf(out / f"{scene.stem}.fsd.nc")

    if args.maps:
        snaps = [int(np.argmin(np.abs(t - s))) for s in args.maps]
    else:
        snaps = sorted({int(round(v)) for v in np.linspace(1, n - 1, 4)})
    fig, ax = plt.subplots(3, 4, figsize=(18, 12))
    xe = f.x0 + np.arange(f.nx + 1) * f.dx
    ye = f.y0 + np.arange(f.ny + 1) * f.dy
    hmax = 4.0 * math.sqrt(f.E_in.sum())
    anorm = LogNorm(vmin=float(area.min()), vmax=float(area.sum()))
    for c, i in enumerate(snaps):
        H = 4.0 * np.sqrt(np.maximum(Es[i].sum(axis=0), 0.0))
        m = ax[0, c].pcolormesh(xe, ye, H, vmin=0, vmax=hmax, cmap="viridis")
        ax[0, c].plot([x_edge, x_end, x_end, x_edge, x_edge], [y_lo, y_lo, y_hi, y_hi, y_lo],
                      "w-", lw=0.8)
        ax[0, c].set(title=f"significant wave height, t = {t[i]:g} s", aspect="equal")
        fig.colorbar(m, ax=ax[0, c], label="H_s [m]", shrink=0.7)
        c_, lab = floes[i]
        pc = PolyCollection(cells, array=areas[i][lab], cmap="plasma", norm=anorm,
                            linewidths=0)
        ax[1, c].add_collection(pc)
        ax[1, c].set(xlim=(xe[0], xe[-1]), ylim=(ye[0], ye[-1]), aspect="equal",
                     title=f"floe area, t = {t[i]:g} s ({c_} floes)")
        fig.colorbar(pc, ax=ax[1, c], label="floe area [m²]", shrink=0.7)
        for r in (0, 1):
            ax[r, c].set(xlabel="x (east) [m]", ylabel="y (north) [m]")

    ax[2, 0].plot(t, front, "o-", label="the unbroken pack begins (median)")
    ax[2, 0].plot(t, reach, "s:", label="the farthest broken joint")
    ax[2, 0].set(xlabel="time [s]", ylabel="distance from the ice edge [m]",
                 title="breakup front (middle third across the waves)")
    ax[2, 0].legend(fontsize=8)
    ax[2, 0].grid(alpha=0.3)

    xc = f.x0 + (np.arange(f.nx) + 0.5) * f.dx
    yc = f.y0 + (np.arange(f.ny) + 0.5) * f.dy
    # fitted over the first kilometre (or half the pack): beyond, the oblique components in
    # the middle third have entered across the pack's sides (ice_edge.toml: +-22.5 deg from
    # the middle third's edge reach the pack's side 1.2 km from the edge)
    x_fit = x_edge + min(1000.0, 0.5 * (x_end - x_edge))
    ice = (xc > x_edge + f.dx) & (xc < x_fit)
    strip = np.abs(yc - 0.5 * (y_lo + y_hi)) <= 0.5 * third
    f._ice(q[-1])
    freqs, fit = _fit_rates(f, Es[-1], ice, strip)
    h_ice = float(np.median(sim.state.thickness))
    law = f.law.rate(freqs, h_ice, f.h)
    disc = _discrete_rates(f, sim.dt, freqs, law)
    ax[2, 1].loglog(freqs, fit, "o", label="fitted to the spectrum in the ice")
    ax[2, 1].loglog(freqs, law, "k-", label=f"law: {f.law.name}, h = {h_ice:g} m")
    ax[2, 1].loglog(freqs, disc, "k:", label=f"the law in the upwind scheme ({f.dx:g} m cells)")
    ax[2, 1].loglog([0.05, 0.15], [1e-6, 1e-5], "r--",
                    label="Rogers et al. (2016), pancake/frazil ice")
    ax[2, 1].set(xlabel="frequency [Hz]", ylabel="amplitude attenuation rate k_i [1/m]",
                 title="attenuation at the end")
    ax[2, 1].legend(fontsize=8)

    last = n - 1
    p, xb = ds["pdf"].values[last], ds["area_bin"].values
    ok = p > 0
    a, se, amin = (float(ds[k].values[last]) for k in ("alpha", "alpha_se", "area_min"))
    ntail = int(ds["n_tail"].values[last])
    ax[2, 2].loglog(xb[ok], p[ok], "o", label=f"t = {t[-1]:g} s, {int(ds['n_floes'][last])} "
                    "floes")
    if math.isfinite(a):
        above = xb[ok & (xb >= amin)]
        frac = ntail / int(ds["n_floes"][last])
        ax[2, 2].loglog(above, frac * (a - 1) / amin * (above / amin) ** -a, "k-",
                        label=f"fit: alpha = {a:.2f} ± {se:.2f} above {amin:.3g} m²")
        for obs, style in ((1.65, ":"), (2.03, "--")):
            ax[2, 2].loglog(above, frac * (a - 1) / amin * (above / amin) ** -obs, "g" + style,
                            lw=1, label=f"slope {obs} (Denton & Timmermans 2022)")
    ax[2, 2].set(xlabel="floe area [m²]", ylabel="probability density [1/m²]",
                 title="floe size distribution at the end")
    ax[2, 2].legend(fontsize=8)

    nb = [int((bt <= s).sum()) for s in t]
    ax[2, 3].plot(t, [c for c, _ in floes], "o-", label="floes")
    ax[2, 3].plot(t, nb, "s-", label="broken joints")
    ax[2, 3].set(xlabel="time [s]", yscale="log", title="breakup over time")
    ax[2, 3].legend(fontsize=8)
    ax[2, 3].grid(alpha=0.3)
    fig.tight_layout()
    png = out / f"{scene.stem}.png"
    fig.savefig(png, dpi=80)

    print("farthest broken joint (middle third) from the ice edge: " + ", ".join(
        f"{s:g} s {v:.0f} m" for s, v in zip(t, reach) if math.isfinite(v)))
    print("front (the unbroken pack begins, middle third): " + ", ".join(
        f"{s:g} s {v:.0f} m" for s, v in zip(t, front) if math.isfinite(v)))
    print("k_i fitted / law / the law in the scheme at " + ", ".join(
        f"{u:.3f} Hz {v:.3g}/{w:.3g}/{d:.3g}" for u, v, w, d in zip(freqs, fit, law, disc)))
    print(f"floes at the end: {int(ds['n_floes'][last])} ({int((bt <= t[-1]).sum())} joints "
          f"broken); alpha = {a:.3f} ± {se:.3f} above {amin:.4g} m2 ({ntail} floes)")
    print(png)


if __name__ == "__main__":
    main()
