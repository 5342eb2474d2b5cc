"""Maps and animations from an output file (`siku plot`)."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from siku_core.run.cli import main
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene

matplotlib = pytest.importorskip("matplotlib")
pytest.importorskip("cartopy")


@pytest.fixture(scope="module")
def output(tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "run.h5"
    scene = make_scene(
        elements=[(-150.0, 75.0), (-149.8, 75.05)],
        forcing=[{"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}},
                 {"source": "water_drag"}],
        duration=6 * 3600, dt=60, output={"every": "1h"},
    )
    Simulation(scene, out=path, progress=False).run()
    return path


def test_output_has_fields_for_maps(output):
    with h5py.File(output) as f:
        speed = f["states/fields/speed"][...]
        V = f["states/V"][...]
    assert speed.shape == V.shape[:2]
    np.testing.assert_allclose(speed, np.hypot(V[..., 0], V[..., 1]), rtol=0, atol=0)


def test_siku_plot_writes_maps_and_animation(output, tmp_path):
    assert main(["plot", str(output), "--out-dir", str(tmp_path), "--field", "speed"]) == 0
    pngs = sorted(tmp_path.glob("*.png"))
    gif = list(tmp_path.glob("*.gif"))
    assert [p.name for p in pngs] == ["run_speed_first.png", "run_speed_last.png"]
    assert len(gif) == 1
    from PIL import Image

    with Image.open(gif[0]) as im:
        assert im.n_frames == 7  # snapshots at 0..6 h
    for p in pngs:
        with Image.open(p) as im:
            arr = np.asarray(im.convert("RGB"))
        # the floes are coloured (not only white background, grey and black lines)
        rgb = arr.reshape(-1, 3).astype(int)
        coloured = np.ptp(rgb, axis=1) > 60
        assert coloured.sum() > 50


def test_siku_plot_unknown_field_is_a_clear_error(output, tmp_path, capsys):
    assert main(["plot", str(output), "--out-dir", str(tmp_path), "--field", "stress"]) == 2
    err = capsys.readouterr().err
    assert "no field 'stress'" in err and "speed" in err


def test_siku_plot_missing_file(tmp_path, capsys):
    assert main(["plot", str(tmp_path / "nope.h5")]) == 2
    assert "output file not found" in capsys.readouterr().err


# ---------------------------------------------------------------------------- land, frames
LAND_RGB = (0xD9, 0xD0, 0xC1)


def _land_pixels(png) -> int:
    from PIL import Image

    with Image.open(png) as im:
        rgb = np.asarray(im.convert("RGB")).reshape(-1, 3).astype(int)
    return int(np.sum(np.all(np.abs(rgb - np.array(LAND_RGB)) <= 2, axis=1)))


@pytest.fixture(scope="module")
def coast_output(tmp_path_factory):
    """A small mesh against the GSHHG shoreline off Point Barrow (a scene with a coast)."""
    from siku_core.scene.scene_file import scene_from_text

    text = """
title = "Barrow coast"
[time]
start = 2001-04-06T00:00:00Z
duration = "2h"
dt = 60
[elements.mesh]
lon = [-158.0, -154.0]
lat = [70.6, 72.0]
spacing = 15e3
land = "gshhg"
cache = false
thickness = 1.5
velocity = [0.05, 0.0]
[output]
every = "1h"
"""
    path = tmp_path_factory.mktemp("coast") / "coast.h5"
    Simulation(scene_from_text(text), out=path, progress=False).run()
    return path


def test_scene_has_coast_only_for_a_mesh_against_land_data():
    from siku_io.plot.mapdeco import scene_has_coast

    assert scene_has_coast('[elements.mesh]\nlon = [0, 1]\nlat = [70, 71]\nspacing = 1e4\n')
    assert scene_has_coast('[elements.mesh]\nland = "gshhg"\n')
    assert not scene_has_coast('[elements.mesh]\nland = "none"\n')
    assert not scene_has_coast('[[elements.pack]]\nlon = [0, 10]\nlat = [0, 5]\n')
    assert not scene_has_coast("not = [toml")


def test_land_is_drawn_only_where_the_scene_has_a_coast(output, coast_output, tmp_path):
    """The idealised pair of floes (no mesh) has no land on its map although its frame lies
    off Alaska; the mesh scene's map fills land in the shoreline colour. Both have the
    graticule labels, a scale bar and the date in the title."""
    from siku_io.plot.element_maps import MapPainter, Output, draw_map

    plain = draw_map(output, tmp_path / "plain.png", -1, "speed")
    coast = draw_map(coast_output, tmp_path / "coast.png", -1, "speed")
    assert _land_pixels(plain) == 0
    assert _land_pixels(coast) > 2000
    p = MapPainter(Output(coast_output), "speed")
    p.draw(1)
    # a frame about 150 km wide: GSHHG points at most 150 km / 170 apart, the 1 km level
    assert p.land_level == "intermediate"
    assert p.ax.get_title().endswith("2001-04-06 01:00 UTC (t = 1 h)")
    texts = [t.get_text() for t in p.ax.texts]
    assert any(t.endswith(" km") for t in texts)  # scale bar
    labels = [h.get_label() for h in p.ax.get_legend().legend_handles]
    assert "land (GSHHG)" in labels and "static cells (coast, landfast ice)" in labels
    matplotlib.pyplot.close(p.fig)


def test_animation_frames_are_tight_and_equal(coast_output, tmp_path):
    """Every GIF frame has the same size and at most a few pixels of white margin."""
    from PIL import Image, ImageSequence

    from siku_io.plot.element_maps import animate

    gif = animate(coast_output, tmp_path / "a.gif", "speed")
    with Image.open(gif) as im:
        sizes = set()
        for frame in ImageSequence.Iterator(im):
            rgb = np.asarray(frame.convert("RGB")).astype(int)
            sizes.add(rgb.shape)
            blank_cols = np.all(rgb >= 250, axis=(0, 2))
            blank_rows = np.all(rgb >= 250, axis=(1, 2))
            for blank in (blank_cols, blank_rows):
                assert np.argmin(blank) <= 8 and np.argmin(blank[::-1]) <= 8
    assert len(sizes) == 1
