"""`siku plot`'s choices (snapshots, formats and resolution, extent, colour limits, projection,
coast) and the layout of every map: the colour bar beside the frame, as tall as it, clear of
the graticule's labels at any domain size."""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.run.cli import main
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene

matplotlib = pytest.importorskip("matplotlib")
pytest.importorskip("cartopy")
matplotlib.use("Agg")

#: two floes (10 km squares) spanning a domain: tens of km, thousands of km, tall and narrow
DOMAINS = {
    "small": [(-150.0, 75.0), (-149.8, 75.05)],
    "large": [(-175.0, 68.0), (-120.0, 82.0)],
    "tall": [(10.0, -20.0), (11.0, 20.0)],
}


def _run(folder, elements):
    path = folder / "run.h5"
    scene = make_scene(
        elements=elements,
        forcing=[{"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}},
                 {"source": "water_drag"}],
        duration=3600, dt=60, output={"every": "30min"})
    Simulation(scene, out=path, progress=False).run()
    return path


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("small"), DOMAINS["small"])


def _layout(painter):
    """Pixel boxes of the visible graticule labels, the map's frame and the colour bar."""
    from cartopy.mpl.gridliner import Gridliner

    fig = painter.fig
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    gl = next(a for a in painter.ax.artists if isinstance(a, Gridliner))
    labels = [lab.artist.get_window_extent(r) for lab in gl._labels
              if lab.artist.get_visible() and lab.artist.get_text()]
    return labels, painter.ax.get_window_extent(r), painter.colorbar.ax.get_window_extent(r)


def _check_layout(painter):
    labels, frame, bar = _layout(painter)
    assert labels, "the map has graticule labels"
    for box in labels:
        assert not box.overlaps(bar), f"a graticule label {box} runs into the colour bar {bar}"
    # the colour bar is exactly as tall as the frame (one pixel of rounding), right of it
    assert abs(bar.height - frame.height) <= 1.0 and bar.height <= frame.height + 1.0
    assert abs(bar.y0 - frame.y0) <= 1.0
    assert bar.x0 > frame.x1


def test_colorbar_is_as_tall_as_a_small_map_and_clear_of_its_labels(small):
    """The small domain (30 km across at 75°N) gave a colour bar twice the map's height."""
    from siku_io.plot.element_maps import MapPainter, Output

    p = MapPainter(Output(small), "speed")
    p.draw(-1)
    _check_layout(p)
    matplotlib.pyplot.close(p.fig)


@pytest.mark.slow
@pytest.mark.parametrize("domain", ["large", "tall"])
def test_colorbar_layout_at_other_domain_sizes(domain, tmp_path):
    from siku_io.plot.element_maps import MapPainter, Output

    p = MapPainter(Output(_run(tmp_path, DOMAINS[domain])), "speed")
    p.draw(0)
    _check_layout(p)
    matplotlib.pyplot.close(p.fig)


def test_select_snapshots_by_index_and_model_time():
    from siku_core.errors import InputError
    from siku_io.plot.mapdeco import select_snapshots

    t = np.arange(7) * 3600.0  # snapshots every hour, 0..6 h
    assert select_snapshots(t, ["0", "-1", "2h", "170min", "2"]) == [0, 6, 2, 3]
    assert select_snapshots(t, ["89min"]) == [1]  # within half a spacing of 1 h
    for bad in ("7", "-8", "6.6h", "-40min", "soon"):
        with pytest.raises(InputError):
            select_snapshots(t, [bad])


def test_siku_plot_times_formats_limits_extent_and_map(small, tmp_path):
    """Snapshots chosen by index and model time, drawn as PDF and SVG (vector, marked as
    siku's so that a second run replaces them) and PNG at the asked resolution, with the colour
    limits, extent, projection and coast asked for."""
    from PIL import Image

    from siku_io.output.marks import is_picture

    common = ["plot", str(small), "--out-dir", str(tmp_path), "--field", "speed"]
    for _ in range(2):  # the second run replaces its own pictures
        assert main(common + ["--time", "0", "--time", "30min,-1", "--format", "pdf"]) == 0
    pdfs = sorted(p.name for p in tmp_path.glob("*.pdf"))
    assert pdfs == ["run_speed_000.pdf", "run_speed_001.pdf", "run_speed_002.pdf"]
    assert not list(tmp_path.glob("*.gif"))  # chosen snapshots: maps only
    for name in pdfs:
        assert (tmp_path / name).read_bytes().startswith(b"%PDF") and is_picture(tmp_path / name)
    assert main(common + ["--time", "1h", "--format", "svg", "--projection", "platecarree",
                          "--coast", "on", "--vmin", "0", "--vmax", "0.5"]) == 0
    svg = tmp_path / "run_speed_002.svg"
    assert b"<svg" in svg.read_bytes()[:2000] and is_picture(svg)
    assert main(common + ["--time", "-1", "--dpi", "300",
                          "--extent", "-151", "-149", "74.5", "75.5"]) == 0
    with Image.open(tmp_path / "run_speed_002.png") as im:
        assert abs(im.info["dpi"][0] - 300) < 0.5


def test_map_options_reach_the_map(small):
    import cartopy.crs as ccrs

    from siku_io.plot.element_maps import MapPainter, Output

    out = Output(small)
    p = MapPainter(out, "speed", vmin=0.1, vmax=0.3, projection="platecarree", land=False,
                   extent=(-151.0, -149.0, 74.5, 75.5))
    assert p.coll.norm.boundaries[0] == 0.1 and p.coll.norm.boundaries[-1] == 0.3
    assert isinstance(p.proj, ccrs.PlateCarree) and p.land_level is None
    x0, x1, y0, y1 = p.ax.get_extent(crs=ccrs.PlateCarree())
    np.testing.assert_allclose([x0, x1, y0, y1], [-151.0, -149.0, 74.5, 75.5], atol=1e-6)
    matplotlib.pyplot.close(p.fig)
    q = MapPainter(out, "speed", projection="polar")
    assert isinstance(q.proj, ccrs.NorthPolarStereo)
    matplotlib.pyplot.close(q.fig)


def test_element_and_grid_maps_draw_into_the_callers_cartopy_axes(small, tmp_path):
    """``ax=``: both painters draw in the caller's panels, in the axes' projection, and add no
    figure and (``colorbar=False``) no colour bar of their own."""
    import cartopy.crs as ccrs
    import matplotlib.pyplot as plt

    from siku_io.analysis.gridded_fields import grid_output
    from siku_forcing.gridded.regular_grid import GridCfg
    from siku_io.output.netcdf import write_netcdf
    from siku_io.plot.element_maps import MapPainter, Output
    from siku_io.plot.grid_maps import GridPainter

    cfg = GridCfg(kind="lonlat", lon=(-150.4, -149.4), lat=(74.9, 75.2), resolution=0.05)
    grid = write_netcdf(grid_output(small, cfg), tmp_path / "run.grid.nc")
    proj = ccrs.NorthPolarStereo(central_longitude=-150)
    fig, axes = plt.subplots(1, 2, subplot_kw={"projection": proj})
    figures = plt.get_fignums()
    p = MapPainter(Output(small), "speed", ax=axes[0], colorbar=False)
    p.draw(-1)
    g = GridPainter(grid, "concentration", ax=axes[1], colorbar=False)
    g.draw(-1)
    assert plt.get_fignums() == figures  # no figure of their own
    assert (p.ax, p.fig, g.ax, g.fig) == (axes[0], fig, axes[1], fig)
    assert p.proj is proj and g.proj is proj and len(fig.axes) == 2  # no colour bar added
    assert p.coll in axes[0].collections and g.mesh in axes[1].collections
    assert np.isfinite(g.values).any() and g.colorbar is None
    fig.colorbar(g.mesh, ax=axes[1])  # the caller's own colour bar takes the painter's mappable
    assert len(fig.axes) == 3
    plt.close(fig)


def test_a_run_held_in_memory_maps_as_its_file(small):
    """``Output(sim)`` of a run made with ``out="memory"`` holds what ``Output(FILE)`` reads
    from the file of the same scene (the same snapshots, geometry and fields, bit for bit), so
    the map painter draws it without a file; a run that keeps nothing in memory is refused
    with siku's error."""
    import matplotlib.pyplot as plt

    from siku_core import DataError
    from siku_core.scene.scene_file import scene_from_text
    from siku_io.output.results import open_results
    from siku_io.plot.element_maps import MapPainter, Output

    with open_results(small) as f:
        scene = f["scene"][()].decode()
    sim = Simulation(scene_from_text(scene, "small"), out="memory", progress=False).run()
    mem, disk = Output(sim), Output(small)
    assert mem.path.name == "<memory>" and len(mem.time) == len(disk.time) == 3
    for name in ("time", "q", "offsets", "verts", "flags"):
        np.testing.assert_array_equal(getattr(mem, name), getattr(disk, name), err_msg=name)
    assert mem.fields.keys() == disk.fields.keys() and mem.units == disk.units
    for name in disk.fields:
        np.testing.assert_array_equal(mem.fields[name], disk.fields[name], err_msg=name)
    assert (mem.title, mem.radius, mem.start, mem.has_coast) == (
        disk.title, disk.radius, disk.start, disk.has_coast)
    painter = MapPainter(mem, "speed")
    painter.draw(-1)
    assert len(painter.coll.get_paths()) == 2 and "<memory>" not in painter.ax.get_title()
    plt.close(painter.fig)
    with pytest.raises(DataError, match='out="memory"'):
        Output(Simulation(scene_from_text(scene, "small"), out=False, progress=False))


@pytest.mark.parametrize("args, says", [
    (["--time", "9"], "snapshot index out of range"),
    (["--time", "5h"], "no snapshot at 18000 s"),
    (["--time", "later"], "time 'later'"),
    (["--vmin", "1", "--vmax", "0.5"], "vmin 1 must be below vmax 0.5"),
    (["--extent", "10", "0", "70", "80"], "LON0 10 must be below LON1 0"),
    (["--extent", "0", "10", "80", "95"], "-90 <= LAT0 < LAT1 <= 90"),
    (["--dpi", "0"], "dpi 0"),
    (["--format", "jpg"], "invalid choice: 'jpg'"),
    (["--projection", "robinson"], "invalid choice: 'robinson'"),
])
def test_bad_plot_options_exit_2_with_one_line(small, tmp_path, capsys, args, says):
    assert main(["plot", str(small), "--out-dir", str(tmp_path), "--field", "speed"]
                + args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("siku: error:") and says in err, err
    assert not list(tmp_path.iterdir())  # nothing drawn
