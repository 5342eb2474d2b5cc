"""Maps and animations from an output file (`siku plot`)."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from siku_core.cli import main
from siku_core.testing import make_scene
from siku_core.simulation import Simulation

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
