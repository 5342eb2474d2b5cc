"""Pictures of an ice-life run (``cold_snap.toml``): the thickness change of every element and
the ice volume budget.

    python examples/ice_life/budget.py cold_snap.h5 OUT_DIR

writes ``OUT_DIR/thickness_change.png`` (the change of each element's thickness over the run
[cm], a diverging colour scale centred on zero: red thinner, blue thicker) and
``OUT_DIR/volume_budget.png`` (the change of the total ice volume since the start [km³] beside
what thermodynamics grew or melted and what ridging moved, which leaves the total unchanged),
and prints the budget's closure. Existing pictures are never replaced.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np


def budget(path) -> dict[str, np.ndarray]:
    """Per snapshot: model time [h], total ice volume change since the start (``area sum_k
    a_k h_k`` of the elements not melted), volume grown by thermodynamics and volume moved by
    ridging [m³]."""
    import xarray as xr

    ds = xr.open_dataset(path, engine="siku")
    live = ds["flags"].values != 3
    # ice per area: sum_k a_k h_k (the concentration counted; ridging opens water)
    per_area = (ds["category_fraction"] * ds["category_thickness"]).sum("category").values \
        if "category_fraction" in ds else ds["thickness"].values
    vol = np.array([math.fsum(v) for v in
                    np.where(live, per_area * ds["area"].values, 0.0)])
    grown = np.array([math.fsum(v) for v in ds["grown_volume"].values])
    ridged = np.array([math.fsum(v) for v in ds["ridged_volume"].values]) + np.array(
        [math.fsum(v) for v in ds["rafted_volume"].values])
    hours = (ds["step"].values - ds["step"].values[0]) * float(ds.attrs["dt"]) / 3600.0
    return {"hours": hours, "change": vol - vol[0], "grown": grown, "ridged": ridged}


def draw(path, out_dir) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import xarray as xr
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import TwoSlopeNorm

    from siku_io.output.xr import outlines_at

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    targets = [out_dir / "thickness_change.png", out_dir / "volume_budget.png"]
    for t in targets:
        if t.exists():
            raise FileExistsError(f"{t} exists; choose another folder")
    ds = xr.open_dataset(path, engine="siku")
    dh = 100.0 * (ds["thickness"].values[-1] - ds["thickness"].values[0])  # cm
    polys = outlines_at(ds, ds.sizes["time"] - 1)
    lim = max(float(np.abs(dh).max()), 1e-6)
    fig, ax = plt.subplots(figsize=(10, 5), dpi=150)
    pc = PolyCollection(polys, array=dh, cmap="RdBu", norm=TwoSlopeNorm(0.0, -lim, lim),
                        edgecolors="none")
    ax.add_collection(pc)
    ax.autoscale_view()
    ax.set_xlabel("longitude [degrees east]")
    ax.set_ylabel("latitude [degrees north]")
    hours = budget(path)["hours"][-1]
    ax.set_title(f"{ds.attrs.get('title', '')}\nthickness change after {hours:g} h")
    fig.colorbar(pc, ax=ax, label="thickness change [cm] (blue: thicker)")
    fig.savefig(targets[0], bbox_inches="tight")
    plt.close(fig)
    b = budget(path)
    fig, ax = plt.subplots(figsize=(7, 4), dpi=150)
    ax.plot(b["hours"], b["change"] / 1e9, "k-", lw=2.5, label="total ice volume change")
    ax.plot(b["hours"], b["grown"] / 1e9, "C0--", label="grown minus melted (thermodynamics)")
    ax.plot(b["hours"], b["ridged"] / 1e9, "C3:", label="moved into ridges (conserves volume)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time [h]")
    ax.set_ylabel("volume [km³]")
    ax.legend()
    ax.set_title("ice volume budget")
    fig.savefig(targets[1], bbox_inches="tight")
    plt.close(fig)
    return targets


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    b = budget(argv[0])
    gap = abs(b["change"][-1] - b["grown"][-1])
    print(f"volume change {b['change'][-1]:.6e} m3, grown {b['grown'][-1]:.6e} m3, ridged "
          f"{b['ridged'][-1]:.6e} m3; budget closes to {gap / max(abs(b['grown'][-1]), 1):.1e}")
    for p in draw(argv[0], argv[1]):
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
