"""The pan-Arctic run's last snapshot as a small picture: drift speed over the whole Arctic
(north polar stereographic, each element a dot at its centre, coast cells grey) and the cells
themselves around the Bering Strait; given the mesh file instead of an output, the mesh (ice
and coast cells).

    python examples/pan_arctic/picture.py pan_arctic.h5 pan_arctic.png
    python examples/pan_arctic/picture.py examples/pan_arctic/pan_arctic.mesh.npz mesh.png
"""
from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

from siku_io.output.xr import outlines_at  # noqa: E402

STATIC = 1
ZOOM = ((-172.0, -165.0), (64.8, 67.0))  # the Bering Strait: lon, lat [deg]


def stereo(lon, lat):
    """North polar stereographic coordinates [1000 km] on a sphere of 6371 km, the Greenwich
    meridian up."""
    r = 2 * 6371.0 * np.tan(np.radians(90.0 - np.asarray(lat)) / 2) / 1000.0
    t = np.radians(np.asarray(lon) + 90.0)
    return r * np.cos(t), r * np.sin(t)


def main(path: str, out: str) -> None:
    fig, (ax, az) = plt.subplots(1, 2, figsize=(9.0, 4.6), dpi=80,
                                 gridspec_kw={"width_ratios": [1.25, 1.0]})
    if path.endswith(".npz"):  # the mesh
        from siku_io.mesh.mesh_file import ICE, Mesh

        mesh = Mesh.load(path)
        every = mesh.polygons()
        lon, lat = mesh.seeds[:, 0], mesh.seeds[:, 1]
        static = mesh.kind != ICE
        x, y = stereo(lon, lat)
        ax.scatter(x[static], y[static], s=0.05, c="0.55", lw=0, rasterized=True)
        ax.scatter(x[~static], y[~static], s=0.05, c="steelblue", lw=0, rasterized=True)
        ax.set_title(f"{mesh.n} cells (grey: coast)", fontsize=9)
    else:
        ds = xr.open_dataset(path, engine="siku")
        last = ds.isel(time=-1)
        lon, lat = last["lon"].values, last["lat"].values
        speed = np.hypot(last["u"].values, last["v"].values)
        static = last["flags"].values == STATIC
        x, y = stereo(lon, lat)
        ax.scatter(x[static], y[static], s=0.05, c="0.55", lw=0, rasterized=True)
        sc = ax.scatter(x[~static], y[~static], s=0.05, c=speed[~static], cmap="viridis",
                        vmin=0.0, vmax=float(np.percentile(speed[~static], 99)), lw=0,
                        rasterized=True)
        hours = (ds["time"].values[-1] - ds["time"].values[0]) / np.timedelta64(1, "h")
        ax.set_title(f"{ds.sizes['element']} elements, speed after {hours:g} h", fontsize=9)
        fig.colorbar(sc, ax=ax, shrink=0.7, label="drift speed [m/s]")
        every = outlines_at(ds, -1)
    ax.set_aspect("equal")
    ax.set_axis_off()
    # the cells themselves around the Bering Strait
    (w, e), (s, n) = ZOOM
    pick = np.flatnonzero((lon > w) & (lon < e) & (lat > s) & (lat < n))
    polys = [every[i] for i in pick]
    colours = np.where(static[pick], "0.6", "lightsteelblue")
    az.add_collection(PolyCollection(polys, facecolors=colours, edgecolors="k", linewidths=0.2))
    az.set_xlim(w, e)
    az.set_ylim(s, n)
    az.set_aspect(1.0 / np.cos(np.radians(0.5 * (s + n))))
    az.set_title("cells at the Bering Strait (grey: coast)", fontsize=9)
    az.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__.split("\n\n")[1].strip())
    main(sys.argv[1], sys.argv[2])
