"""Maps and animations of siku output files (matplotlib + cartopy projections).

Elements are drawn as their polygons, coloured by a per-element field written by the HDF5
writer (``/states/fields/NAME``: ``speed`` [m/s], ``damage`` [1] = share of an element's
joints that have broken); static elements (coast, landfast ice) are grey. Polar regions use a
polar stereographic projection. Maps carry a labelled graticule, a scale bar, a legend and the
date; land from the GSHHG shorelines is drawn for scenes that have a coast
(:mod:`siku_io.plot.mapdeco`; nothing is downloaded).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from siku_core import DataError
from siku_core.fields import units_label
from siku_core.state import STATIC
from siku_core.geometry.element_geometry import polygons_lonlat


def field_units(out: "Output", field: str) -> str:
    """The units of ``field`` for its colour bar: the field catalogue's
    (:meth:`siku_core.plugins.Registry.field_catalogue`: the engine's fields and every
    registered component's), else the file's own ``units`` attribute (a field of a component
    not installed here), else ``"1"``."""
    from siku_core.plugins import get_registry

    spec = get_registry().field_catalogue().get(field)
    if spec is not None:
        return spec.units
    return out.units.get(field) or "1"


class Output:
    """Read-only view of a run's snapshots for plotting: an output file (its path), or a run
    held in memory (a :class:`~siku_core.run.simulation.Simulation` made with
    ``out="memory"``: the snapshots it has kept so far, no file written)."""

    def __init__(self, path):
        from contextlib import nullcontext

        from siku_core.run.simulation import Simulation
        from siku_io.output.results import open_results

        if isinstance(path, Simulation):
            kept = next((w for w in path.writers if w.in_memory), None)
            if kept is None or not kept.holds_snapshots():
                raise DataError("the run keeps no snapshot in memory: make it with "
                                "Simulation(scene, out=\"memory\") and run it, or give an "
                                "output file")
            kept.f.flush()
            self.path = Path("<memory>")
            source = nullcontext(kept.f)
        else:
            self.path = Path(path)
            source = open_results(self.path)
        with source as f:
            self._read(f)

    def _read(self, f) -> None:
        from siku_io.output.results import n_snapshots

        if "states" not in f or "q" not in f["states"]:
            raise DataError(f"{self.path}: no element states (is it a siku output file?)")
        n = n_snapshots(f)  # complete snapshots only (a killed run may leave one more row)
        if n == 0:
            raise DataError(f"{self.path}: holds no complete snapshot yet, nothing to draw "
                            "(a run killed before its first snapshot; rerun the scene)")
        self.title = str(f.attrs.get("title", ""))
        self.radius = float(f.attrs["radius"])
        self.start = str(f.attrs.get("start", ""))
        geo = f["geometry"]
        self.offsets = geo["vert_offsets"][...]
        self.verts = geo["verts"][...]
        self.flags = geo["flags"][...]
        self.time = f["states/time"][:n]
        self.q = f["states/q"][:n]
        self.fields = {k: v[:n] for k, v in f["states"].get("fields", {}).items()
                       if v.ndim == 2}  # one value per element (not per category)
        #: the fields' ``units`` attributes as the file holds them (empty: none)
        self.units = {k: _text(v.attrs.get("units", ""))
                      for k, v in f["states"].get("fields", {}).items() if v.ndim == 2}
        scene = f["scene"][()] if "scene" in f else b""
        from siku_io.plot.mapdeco import scene_has_coast

        #: whether the run's scene has a coast (a mesh against land data): land is drawn
        self.has_coast = scene_has_coast(scene.decode() if isinstance(scene, bytes) else scene)

    def field(self, name: str) -> np.ndarray:
        if name not in self.fields:
            raise DataError(
                f"{self.path}: no field '{name}'; available: {', '.join(sorted(self.fields))}"
            )
        return self.fields[name]


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _projection(lat_mean: float, lon_mean: float):
    from siku_io.plot.mapdeco import projection

    return projection(lat_mean, lon_mean)


def _levels(vmax: float, field: str) -> np.ndarray:
    """Colour levels: tenths for damage, about ten round steps up to ``vmax`` otherwise."""
    if field == "damage":
        return np.linspace(0.0, 1.0, 11)
    from siku_io.plot.mapdeco import nice_step

    step = nice_step(vmax / 10.0) if vmax > 0 else 0.1
    return np.arange(0.0, vmax + step * 1.0001, step)


def _levels_between(lo: float, hi: float) -> np.ndarray:
    """Ten colour bins from ``lo`` to ``hi``: the limits asked for, exactly."""
    return np.linspace(lo, hi, 11)


class MapPainter:
    """Draws one snapshot of an output file; reused for animation frames.

    ``field`` colours the elements; ``vmin``, ``vmax`` [the field's units] fix the colour
    scale (default: zero, or symmetric about zero for a signed field, to the largest value);
    ``land`` draws the GSHHG land (default: when the scene has a coast); ``extent`` frames the
    map on a lon/lat box ``(lon0, lon1, lat0, lat1)`` [deg] (default: the elements);
    ``projection`` one of :data:`siku_io.plot.mapdeco.PROJECTIONS`. With ``ax``, a cartopy
    ``GeoAxes`` of the caller's figure, the map is drawn there in the axes' own projection
    (a panel of a larger figure); ``colorbar=False`` leaves the colour bar to the caller
    (``painter.coll`` is the mappable).
    """

    def __init__(self, out: Output, field: str = "damage", vmax: float | None = None,
                 land: bool | None = None, *, vmin: float | None = None, extent=None,
                 projection: str = "auto", ax=None, colorbar: bool = True):
        import matplotlib

        if ax is None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.collections import PolyCollection
        from matplotlib.colors import BoundaryNorm

        from . import mapdeco

        mapdeco.check_limits(vmin, vmax)
        self.out = out
        self.field_name = field
        self.values = out.field(field)
        if extent is not None:
            lonw, lat = mapdeco.extent_outline(extent)
        else:
            allv = np.concatenate([
                np.concatenate(polygons_lonlat(out.q[k], out.offsets, out.verts, out.radius))
                for k in sorted({0, len(out.time) // 2, len(out.time) - 1})
            ])
            lon_ref = float(allv[0, 0])
            lonw = (allv[:, 0] - lon_ref + 180) % 360 - 180 + lon_ref
            lat = allv[:, 1]
        if ax is None:
            self.proj = mapdeco.projection(float(lat.mean()), float(lonw.mean()), projection)
            self.fig = plt.figure(figsize=(8, 6.5), dpi=100)
            self.ax = self.fig.add_subplot(1, 1, 1, projection=self.proj)
        else:
            self.ax, self.fig, self.proj = ax, ax.figure, ax.projection
        self.ax.set_facecolor(mapdeco.OCEAN)
        self.box = mapdeco.frame_for(self.ax, self.proj, lonw, lat,
                                     pad=0.0 if extent is not None else 0.08)
        self.land = out.has_coast if land is None else land
        self.land_level = (mapdeco.draw_land(self.ax, self.proj, self.box) if self.land
                           else None)
        mapdeco.graticule(self.ax, self.proj, self.box)
        mapdeco.scale_bar(self.ax, self.proj, self.box, out.radius)
        self.static = out.flags == STATIC
        mapdeco.legend(self.ax, land=self.land_level is not None, static=bool(self.static.any()))
        # a signed field (stress, a velocity component) on a diverging scale centred on zero:
        # compression and tension alike stand out from the unstressed ice
        self.signed = field != "damage" and (bool(np.nanmin(self.values) < 0)
                                             or (vmin is not None and vmin < 0))
        if vmin is not None or (vmax is not None and not self.signed):
            lo = vmin if vmin is not None else (0.0 if not self.signed else -abs(vmax))
            hi = vmax if vmax is not None else (
                1.0 if field == "damage" else float(np.nanmax(self.values)))
            if not hi > lo:
                from siku_core.errors import InputError

                raise InputError(f"colour limits: vmin {lo:g} must be below vmax {hi:g} "
                                 f"(the largest {field} is {hi:g})")
            levels = _levels_between(lo, hi)
            cmap = matplotlib.colormaps["RdBu_r" if lo < 0 < hi else
                                       "viridis" if field != "damage" else "magma_r"]
        elif self.signed:
            levels = (mapdeco.signed_levels(self.values) if vmax is None
                      else mapdeco.signed_levels(np.array([vmax])))
            cmap = matplotlib.colormaps["RdBu_r"]
        else:
            vmax = vmax if vmax is not None else (1.0 if field == "damage" else
                                                  float(np.nanmax(self.values)) or 1.0)
            levels = _levels(vmax, field)
            cmap = matplotlib.colormaps["viridis" if field != "damage" else "magma_r"]
        self.levels = levels
        cmap = cmap.resampled(len(levels) - 1).with_extremes(bad=mapdeco.STATIC_GREY)
        self.coll = PolyCollection([], cmap=cmap, norm=BoundaryNorm(levels, len(levels) - 1),
                                   edgecolors="0.25", linewidths=0.15, zorder=2)
        self.ax.add_collection(self.coll)
        self.colorbar = None
        if colorbar:
            self.colorbar = cb = mapdeco.colorbar_beside(self.fig, self.ax, self.coll,
                                                         ticks=levels[::2])
            cb.set_label(units_label(field, field_units(out, field)))

    def draw(self, index: int) -> None:
        import cartopy.crs as ccrs

        from siku_io.plot.mapdeco import when

        out = self.out
        polys = polygons_lonlat(out.q[index], out.offsets, out.verts, out.radius)
        allv = np.concatenate(polys)
        xy = self.proj.transform_points(ccrs.PlateCarree(), allv[:, 0], allv[:, 1])[:, :2]
        segs = [xy[out.offsets[i]:out.offsets[i + 1]] for i in range(len(polys))]
        self.coll.set_verts(segs)
        vals = np.ma.masked_array(self.values[index], mask=self.static)
        self.coll.set_array(vals)
        self.ax.set_title(f"{out.title or out.path.name}\n"
                          f"{when(out.start, float(out.time[index]))}", fontsize=10)


def draw_map(path: str | Path, out_png: str | Path, index: int = -1,
             field: str = "damage", *, dpi: float | None = None, **map_options) -> Path:
    """Write a map of snapshot ``index`` coloured by ``field``, in the format the file's
    suffix names (``.png``, ``.pdf``, ``.svg``; ``dpi`` [dots per inch], default
    :data:`~siku_io.plot.mapdeco.DPI`); ``map_options`` are :class:`MapPainter`'s (``vmin``,
    ``vmax``, ``land``, ``extent``, ``projection``)."""
    import matplotlib.pyplot as plt

    from siku_io.plot.mapdeco import DPI, picture_format, save_picture

    picture_format(out_png)
    out = Output(path)
    painter = MapPainter(out, field, **map_options)
    try:
        painter.draw(index if index >= 0 else len(out.time) + index)
        return save_picture(painter.fig, Path(out_png), dpi=DPI if dpi is None else dpi,
                            bbox_inches="tight")
    finally:
        plt.close(painter.fig)


def animate(path: str | Path, out_gif: str | Path, field: str = "damage", fps: int = 6,
            **map_options) -> Path:
    """Write a GIF animation of every snapshot coloured by ``field`` (tight frames)."""
    import matplotlib.pyplot as plt

    from siku_io.plot.mapdeco import save_gif

    out = Output(path)
    painter = MapPainter(out, field, **map_options)
    try:
        return save_gif(painter.fig, painter.draw, len(out.time), Path(out_gif), fps)
    finally:
        plt.close(painter.fig)


def plot_all(path: str | Path, out_dir: str | Path | None = None, field: str | None = None,
             animation: bool = True, *, times=None, fmt: str = "png", dpi: float | None = None,
             **map_options) -> list[Path]:
    """Maps of the first and last snapshots (``STEM_FIELD_first.png``, ``_last``), or of the
    snapshots ``times`` selects (:func:`~siku_io.plot.mapdeco.select_snapshots`; files
    ``STEM_FIELD_NNN.FMT``, ``NNN`` the snapshot's index), in format ``fmt`` (png, pdf, svg),
    and an animation; returns the files written. ``map_options``: :class:`MapPainter`'s."""
    from siku_io.plot.mapdeco import check_options, picture_targets, select_snapshots

    check_options(dpi=dpi, **map_options)
    path = Path(path)
    out_dir = Path(out_dir) if out_dir else path.parent
    out = Output(path)
    if field is None:
        field = "damage" if "damage" in out.fields else "speed"
    out.field(field)
    stem = path.stem
    if times is None:
        indices = [0, len(out.time) - 1]
        names = [f"{stem}_{field}_first.{fmt}", f"{stem}_{field}_last.{fmt}"]
    else:
        indices = select_snapshots(out.time, times)
        names = [f"{stem}_{field}_{k:03d}.{fmt}" for k in indices]
    maps = picture_targets(out_dir, names + ([f"{stem}_{field}.gif"] if animation else []))
    files = [draw_map(path, target, k, field, dpi=dpi, **map_options)
             for k, target in zip(indices, maps)]
    if animation:
        files.append(animate(path, maps[-1], field, **map_options))
    return files
