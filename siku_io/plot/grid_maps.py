"""Maps of gridded fields (``siku grid`` files): ``siku plot RUN.grid.nc --field NAME``.

Each map shows one field of one time on the cells (their true outlines: lon/lat or polar
stereographic; cells without ice are left blank), with a colourbar in the field's units, land
from the GSHHG shorelines where the run's scene has a coast, graticule, scale bar, and the
leads found at that time (``siku_io.analysis.leads``) drawn end to end: from the deformation in
black, from broken joints in red.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from siku_core import DataError

#: fields drawn on a scale symmetric about zero
SIGNED = {"u", "v", "divergence", "vorticity", "stress_xx", "stress_yy", "stress_xy",
          "stress_1", "stress_2", "stress_I"}


def is_grid_file(path) -> bool:
    """Whether ``path`` is a NetCDF file ``siku grid`` wrote (told by its marks,
    :func:`siku_io.output.marks.netcdf_kind`; a damaged file whose attributes cannot be read
    is not one)."""
    from siku_io.output.marks import netcdf_kind

    return netcdf_kind(path) == "grid"


def _open(path):
    import xarray as xr

    from siku_forcing.gridded.regular_grid import Grid, GridCfg

    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: not a readable NetCDF file: {exc}") from None
    cfg = GridCfg(**json.loads(ds.attrs["grid"]))
    return ds, Grid(cfg, float(ds.attrs["earth_radius"]))


class GridPainter:
    """Draws one field of a gridded file at one time; reused for animation frames.

    ``vmin``, ``vmax`` [the field's units as drawn: strain rates per day] fix the colour
    scale; ``land``, ``extent`` and ``projection`` as for
    :class:`siku_io.plot.element_maps.MapPainter`. With ``ax``, a cartopy ``GeoAxes`` of the
    caller's figure, the map is drawn there in the axes' own projection (a panel of a larger
    figure); ``colorbar=False`` leaves the colour bar to the caller (``painter.mesh`` is the
    mappable)."""

    def __init__(self, path, field: str, *, vmin: float | None = None,
                 vmax: float | None = None, land: bool | None = None, extent=None,
                 projection: str = "auto", ax=None, colorbar: bool = True):
        import cartopy.crs as ccrs
        import matplotlib

        if ax is None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from . import mapdeco

        self.path = Path(path)
        self.ds, self.grid = _open(path)
        if field not in self.ds or self.ds[field].dims[0] != "time":
            have = [k for k, v in self.ds.data_vars.items() if v.dims[:1] == ("time",)
                    and v.ndim == 3]
            raise DataError(f"{path}: no gridded field '{field}'; available: "
                            f"{', '.join(have)}")
        self.field = field
        g = self.grid
        X, Y = np.meshgrid(g.x_edges, g.y_edges)
        lon, lat = g.to_lonlat(X, Y)
        ref = float(lon[lon.shape[0] // 2, lon.shape[1] // 2])
        self.lon = (lon - ref + 180.0) % 360.0 - 180.0 + ref
        self.lat = lat
        mapdeco.check_limits(vmin, vmax)
        frame_lon, frame_lat = ((self.lon.ravel(), lat.ravel()) if extent is None
                                else mapdeco.extent_outline(extent))
        if ax is None:
            self.proj = mapdeco.projection(float(frame_lat.mean()), float(frame_lon.mean()),
                                           projection)
            self.fig = plt.figure(figsize=(8, 6.5), dpi=100)
            self.ax = self.fig.add_subplot(1, 1, 1, projection=self.proj)
        else:
            self.ax, self.fig, self.proj = ax, ax.figure, ax.projection
        self.ax.set_facecolor(mapdeco.OCEAN)
        self.box = mapdeco.frame_for(self.ax, self.proj, frame_lon, frame_lat,
                                     pad=0.02 if extent is None else 0.0)
        if land is None:
            land = mapdeco.scene_has_coast(str(self.ds.attrs.get("scene", "")))
        # land over the cells: a cell is ocean or ice, never land coloured as a value
        self.land_level = (mapdeco.draw_land(self.ax, self.proj, self.box, zorder=1.2)
                           if land else None)
        mapdeco.graticule(self.ax, self.proj, self.box)
        mapdeco.scale_bar(self.ax, self.proj, self.box, float(self.ds.attrs["earth_radius"]))
        values = self.ds[field].values.astype(float)
        if field != "concentration" and "concentration" in self.ds:  # open water shows through
            values = np.where(self.ds["concentration"].values > 0, values, np.nan)
        elif field == "concentration" and land:  # no ice on land: land, not zero concentration
            values = np.where(self.on_land()[None] & (values == 0), np.nan, values)
        attrs = dict(self.ds[field].attrs)
        self.units = str(attrs.get("units", ""))
        if self.units == "s-1":  # strain rates per day, the unit of the lead threshold
            values = values * 86400.0
            self.units = "day-1"
        self.values = values
        scale = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 1.0
        scale = scale or 1.0
        signed = field in SIGNED
        cmap = matplotlib.colormaps["RdBu_r" if signed else "viridis"].with_extremes(
            bad=(0, 0, 0, 0))
        lo = vmin if vmin is not None else (-scale if signed else 0.0)
        hi = vmax if vmax is not None else (scale if lo < scale else lo + scale)
        if not hi > lo:
            from siku_core.errors import InputError

            raise InputError(f"colour limits: vmin {lo:g} must be below vmax {hi:g}")
        self.mesh = self.ax.pcolormesh(self.lon, self.lat, np.ma.masked_invalid(values[0]),
                                       cmap=cmap, vmin=lo, vmax=hi,
                                       transform=ccrs.PlateCarree(), zorder=1, shading="flat")
        self.colorbar = None
        if colorbar:
            self.colorbar = cb = mapdeco.colorbar_beside(self.fig, self.ax, self.mesh)
            cb.set_label(f"{field} [{self.units}]\n{attrs.get('long_name', '')}", fontsize=8)
        self.lines = []

    def on_land(self) -> np.ndarray:
        """``(ny, nx)``: whether each cell's centre is on land (the 1 km GLOBE mask)."""
        from global_land_mask import globe

        X, Y = np.meshgrid(self.grid.x, self.grid.y)
        lon, lat = self.grid.to_lonlat(X, Y)
        return globe.is_land(np.clip(lat, -90.0, 90.0), (lon + 180.0) % 360.0 - 180.0)

    def draw(self, index: int) -> None:
        import cartopy.crs as ccrs

        ds = self.ds
        self.mesh.set_array(np.ma.masked_invalid(self.values[index]).ravel())
        for ln in self.lines:
            ln.remove()
        self.lines = []
        t = ds["time"].values[index]
        if "lead_time" in ds and ds.sizes.get("lead", 0):
            now = ds["lead_time"].values == t
            for k in np.flatnonzero(now):
                kind = int(ds["lead_kind"].values[k])
                lons = [float(ds["lead_start_lon"][k]), float(ds["lead_end_lon"][k])]
                lats = [float(ds["lead_start_lat"][k]), float(ds["lead_end_lat"][k])]
                (ln,) = self.ax.plot(lons, lats, color="k" if kind == 1 else "crimson",
                                     linewidth=1.5, transform=ccrs.Geodetic(), zorder=4,
                                     label="lead (deformation)" if kind == 1 else
                                     "lead (broken joints)")
                self.lines.append(ln)
        handles = {ln.get_label(): ln for ln in self.lines}
        from siku_io.plot.mapdeco import legend

        legend(self.ax, land=self.land_level is not None, static=False,
               extra=list(handles.values()))
        if self.ax.get_legend() is not None:
            self.lines.append(self.ax.get_legend())
        if not np.issubdtype(np.asarray(t).dtype, np.datetime64):
            when = f"t = {float(t) / 3600:.1f} h"
        elif not ds.attrs.get("start"):  # model time written as seconds since 1970
            when = f"t = {(t - np.datetime64('1970-01-01')) / np.timedelta64(1, 'h'):.1f} h"
        else:
            when = np.datetime_as_string(t, unit="m").replace("T", " ") + " UTC"
        title = str(ds.attrs.get("title", "")) or self.path.name
        self.ax.set_title(f"{title}\n{self.field}, {when}", fontsize=10)


def grid_seconds(ds) -> np.ndarray:
    """Model time [s] of a gridded file's times (from its ``start``; model time written as
    seconds since 1970 without one)."""
    t = ds["time"].values
    if not np.issubdtype(t.dtype, np.datetime64):
        return t.astype(float)
    start = str(ds.attrs.get("start", "")).replace("+00:00", "").replace("Z", "")
    origin = np.datetime64(start, "ns") if start else np.datetime64("1970-01-01", "ns")
    return (t - origin) / np.timedelta64(1, "s")


def draw_grid_map(path, out_png, field: str, index: int = -1, *, dpi: float | None = None,
                  **map_options) -> Path:
    """A map of one gridded field at time ``index``, in the format the file's suffix names
    (``.png``, ``.pdf``, ``.svg``); ``map_options`` are :class:`GridPainter`'s."""
    import matplotlib.pyplot as plt

    from siku_io.plot.mapdeco import DPI, picture_format, save_picture

    picture_format(out_png)
    p = GridPainter(path, field, **map_options)
    try:
        n = p.ds.sizes["time"]
        p.draw(index if index >= 0 else n + index)
        return save_picture(p.fig, Path(out_png), dpi=DPI if dpi is None else dpi,
                            bbox_inches="tight")
    finally:
        plt.close(p.fig)


def plot_grid(path, out_dir=None, field: str | None = None, animation: bool = True, *,
              times=None, fmt: str = "png", dpi: float | None = None, **map_options
              ) -> list[Path]:
    """Maps of the first and last times of a gridded file (or of the times ``times`` selects,
    as :func:`siku_io.plot.element_maps.plot_all`) and an animation."""
    from siku_io.plot.mapdeco import check_options, picture_targets, select_snapshots

    check_options(dpi=dpi, **map_options)
    path = Path(path)
    out_dir = Path(out_dir) if out_dir else path.parent
    field = field or "total_deformation"
    stem = path.name.removesuffix(".nc").replace(".", "_")
    ds, _ = _open(path)
    with ds:
        seconds = grid_seconds(ds)
    if times is None:
        indices = [0, len(seconds) - 1]
        names = [f"{stem}_{field}_first.{fmt}", f"{stem}_{field}_last.{fmt}"]
    else:
        indices = select_snapshots(seconds, times)
        names = [f"{stem}_{field}_{k:03d}.{fmt}" for k in indices]
    targets = picture_targets(out_dir, names + ([f"{stem}_{field}.gif"] if animation else []))
    files = [draw_grid_map(path, t, field, k, dpi=dpi, **map_options)
             for k, t in zip(indices, targets)]
    if animation:
        import matplotlib.pyplot as plt

        from siku_io.plot.mapdeco import save_gif

        p = GridPainter(path, field, **map_options)
        try:
            files.append(save_gif(p.fig, p.draw, p.ds.sizes["time"], targets[-1], fps=4))
        finally:
            plt.close(p.fig)
    return files
