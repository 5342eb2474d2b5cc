"""Maps that tell the truth, checked on the figure objects and arrays (not on pixels): signed
fields on a diverging scale centred on zero, no land coloured as ice concentration, open water
in the legend, longitude and latitude labels each once, strain rates per day, 150 dpi."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from siku_core.run.simulation import Simulation

matplotlib = pytest.importorskip("matplotlib")
pytest.importorskip("cartopy")
matplotlib.use("Agg")

SCENE = """
title = "Barrow coast, frozen"
[time]
start = 2001-04-06T00:00:00Z
duration = "1h"
dt = 2
[elements.mesh]
lon = [-158.0, -154.0]
lat = [70.6, 72.0]
spacing = 15e3
land = "gshhg"
cache = false
thickness = 1.5
[[forcing]]
source = "air_drag"
field = { type = "uniform", params = { u = -15.0, v = 10.0 } }
[[forcing]]
source = "water_drag"
[contact]
law = "distributed_spring"
joints = "auto"
[output]
every = "30min"
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """An output of a frozen coastal mesh pushed onshore (stress of both signs), and its
    polar-stereographic grid (a frame that holds Alaska's north coast)."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_io.analysis.gridded_fields import grid_output
    from siku_forcing.gridded.regular_grid import GridCfg
    from siku_io.output.netcdf import write_netcdf

    folder = tmp_path_factory.mktemp("truth")
    out = folder / "coast.h5"
    Simulation(scene_from_text(SCENE), out=out, progress=False).run()
    cfg = GridCfg(kind="polar_stereographic", central_longitude=-156.0,
                  x=[-120000.0, 120000.0], y=[-2180000.0, -1980000.0], resolution=10000.0)
    grid = write_netcdf(grid_output(out, cfg), folder / "coast.grid.nc")
    return out, grid


def _labels(painter):
    from cartopy.mpl.gridliner import Gridliner

    painter.fig.canvas.draw()
    gl = next(a for a in painter.ax.artists if isinstance(a, Gridliner))
    return [(lab.xy, lab.artist.get_text()) for lab in gl._labels if lab.artist.get_visible()]


def test_a_signed_element_field_is_on_a_diverging_scale_centred_on_zero(files):
    from siku_io.plot.element_maps import MapPainter, Output

    out = Output(files[0])
    values = out.field("stress_ee")
    assert values.min() < 0 < values.max()  # compression and tension both present
    p = MapPainter(out, "stress_ee")
    levels = p.coll.norm.boundaries
    assert levels[0] == -levels[-1] and 0.0 in levels
    assert levels[0] <= values.min() and values.max() <= levels[-1]  # nothing clipped
    cmap = p.coll.cmap
    lo, mid, hi = cmap(0.0), cmap(0.5), cmap(1.0)
    assert lo[2] > lo[0] and hi[0] > hi[2]  # blue for compression, red for tension
    assert min(mid[:3]) > 0.85  # white at zero
    assert p.coll.norm(0.0) == (len(levels) - 1) // 2  # zero opens the middle bin
    matplotlib.pyplot.close(p.fig)
    unsigned = MapPainter(out, "speed")
    assert unsigned.coll.norm.boundaries[0] == 0.0
    matplotlib.pyplot.close(unsigned.fig)


def test_no_land_cell_is_coloured_as_ice_concentration(files):
    from siku_io.plot.grid_maps import GridPainter

    p = GridPainter(files[1], "concentration")
    land = p.on_land()
    raw = p.ds["concentration"].values
    assert land.sum() > 20 and (~land).sum() > 20  # the frame holds coast and sea
    painted = np.isfinite(p.values)
    assert not np.any(painted & land[None] & (raw == 0)), "land coloured as zero concentration"
    assert np.all(painted[:, ~land])  # every sea cell has its value
    land_layers = [c for c in p.ax.collections if c is not p.mesh and c.get_zorder() > 0]
    assert land_layers and min(c.get_zorder() for c in land_layers) > p.mesh.get_zorder()
    p.draw(0)
    labels = [h.get_label() for h in p.ax.get_legend().legend_handles]
    assert "open water (ocean, leads)" in labels and "land (GSHHG)" in labels
    matplotlib.pyplot.close(p.fig)


def test_grid_maps_label_longitudes_and_latitudes_once(files):
    from siku_io.plot.grid_maps import GridPainter

    p = GridPainter(files[1], "total_deformation")
    p.draw(1)
    labels = _labels(p)
    lon = [t for xy, t in labels if xy == "x"]
    lat = [t for xy, t in labels if xy == "y"]
    assert lon and all(t.endswith(("°W", "°E", "°")) for t in lon)
    assert lat and all(t.endswith("°N") for t in lat)
    assert len(set(lon + lat)) == len(lon + lat)  # no label twice
    matplotlib.pyplot.close(p.fig)


def test_strain_rates_are_mapped_per_day(files, tmp_path):
    import xarray as xr

    from siku_io.analysis.gridded_fields import grid_output
    from siku_forcing.gridded.regular_grid import GridCfg
    from siku_io.output.netcdf import write_netcdf
    from siku_io.plot.grid_maps import GridPainter

    cfg = GridCfg(kind="polar_stereographic", central_longitude=-156.0,  # cells of 3+ elements
                  x=[-135000.0, 135000.0], y=[-2205000.0, -1935000.0], resolution=45000.0)
    grid = write_netcdf(grid_output(files[0], cfg), tmp_path / "coarse.grid.nc")
    p = GridPainter(grid, "divergence")
    with xr.open_dataset(grid) as ds:
        assert ds["divergence"].attrs["units"] == "s-1"
        raw = ds["divergence"].values
    shown = np.isfinite(p.values)
    assert shown.any()
    np.testing.assert_allclose(p.values[shown], raw[shown] * 86400.0, rtol=1e-12)
    assert p.colorbar.ax.get_ylabel().startswith("divergence [day-1]")
    matplotlib.pyplot.close(p.fig)


def test_png_maps_are_drawn_at_150_dpi(files, tmp_path):
    from PIL import Image

    from siku_io.plot.element_maps import draw_map
    from siku_io.plot.grid_maps import draw_grid_map

    for png in (draw_map(files[0], tmp_path / "e.png", -1, "damage"),
                draw_grid_map(files[1], tmp_path / "g.png", "concentration", -1)):
        with Image.open(png) as im:
            assert min(im.info["dpi"]) >= 149.9 and im.size[0] >= 800  # was 650 px at 100 dpi


GALLERY = Path(__file__).resolve().parents[1] / "docs" / "gallery"


def _similar(a: Path, b: Path) -> float:
    """Share of pixels within 8 levels in every channel (images of one size)."""
    from PIL import Image

    with Image.open(a) as ia, Image.open(b) as ib:
        assert ia.size == ib.size, (a, ia.size, ib.size)
        x = np.asarray(ia.convert("RGB")).astype(int)
        y = np.asarray(ib.convert("RGB")).astype(int)
    return float(np.mean(np.all(np.abs(x - y) <= 8, axis=-1)))


def test_every_gallery_picture_is_drawn_by_the_gallery_command():
    text = (GALLERY / "make_gallery.py").read_text(encoding="utf-8")
    for png in GALLERY.glob("*.png"):
        stem = png.stem.replace("_24h", "_{tag}").replace("standin_{tag}", "standin_{hours:g}h")
        assert png.name in text or stem in text, f"{png.name}: not drawn by make_gallery.py"


@pytest.mark.slow
def test_the_gallery_pictures_are_those_the_current_code_draws(tmp_path):
    """The quick pictures redrawn now match the committed ones (a pixel tolerance: fonts and
    antialiasing may differ slightly between machines)."""
    import subprocess
    import sys

    subprocess.run([sys.executable, str(GALLERY / "make_gallery.py"), "--only", "waves",
                    "two_way", "--out", str(tmp_path)], check=True, timeout=900,
                   capture_output=True)
    for name in ("wave_breaking.png", "two_way_waves.png"):
        assert _similar(tmp_path / name, GALLERY / name) > 0.99, name


def test_grid_maps_take_the_map_options_and_keep_the_colour_bar_beside_the_frame(files,
                                                                                 tmp_path):
    """A gridded field with fixed colour limits, a lon/lat frame and plate carrée, drawn as
    SVG; its colour bar as tall as the frame, clear of the graticule's labels."""
    import cartopy.crs as ccrs
    from cartopy.mpl.gridliner import Gridliner

    from siku_io.output.marks import is_picture
    from siku_io.plot.grid_maps import GridPainter, draw_grid_map

    p = GridPainter(files[1], "concentration", vmin=0.2, vmax=0.9, projection="platecarree",
                    extent=(-158.0, -154.0, 70.6, 72.0))
    assert p.mesh.norm.vmin == 0.2 and p.mesh.norm.vmax == 0.9
    assert isinstance(p.proj, ccrs.PlateCarree)
    p.draw(0)
    p.fig.canvas.draw()
    r = p.fig.canvas.get_renderer()
    gl = next(a for a in p.ax.artists if isinstance(a, Gridliner))
    frame, bar = p.ax.get_window_extent(r), p.colorbar.ax.get_window_extent(r)
    for lab in gl._labels:
        if lab.artist.get_visible() and lab.artist.get_text():
            assert not lab.artist.get_window_extent(r).overlaps(bar)
    assert abs(bar.height - frame.height) <= 1.0 and bar.x0 > frame.x1
    matplotlib.pyplot.close(p.fig)
    svg = draw_grid_map(files[1], tmp_path / "g.svg", "concentration", -1, vmin=0.0, vmax=1.0)
    assert is_picture(svg) and b"<svg" in svg.read_bytes()[:2000]
