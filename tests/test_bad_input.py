"""Inputs that used to end in a traceback, a hang or silent garbage: each now ends with exit
status 2 and one line naming the file and key (or runs, where the input is valid)."""
from __future__ import annotations

import h5py
import pytest

from siku_core.run.cli import main
from siku_core.run.limits import BYTES_PER_ELEMENT, MAX_ELEMENTS, MAX_STEPS, physical_memory
from siku_core.testing import scene_text

BASE = scene_text([(-150.0, 75.0), (-149.7, 75.0)], forcing=[{"source": "water_drag"}],
                  dt=60.0, duration=600.0)


def run(tmp_path, monkeypatch, capsys, text: str, *extra: str) -> tuple[int, str]:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    rc = main(["run", "s.toml", "--no-progress", "--no-plots", "--out", "o.h5", *extra])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if rc == 2:
        assert len([ln for ln in err.splitlines() if ln.startswith("siku: error:")]) == 1, err
    return rc, err


def with_time(text: str) -> str:
    return BASE.replace("duration = 600.0", text)


@pytest.mark.parametrize("time_keys", [
    "start = 2000-01-01T00:00:00Z\nend = 2000-01-01T01:00:00",
    "start = 2000-01-01T00:00:00\nend = 2000-01-01T01:00:00Z",
    "start = 2000-01-01T02:00:00+02:00\nend = 2000-01-01T01:00:00",
])
def test_naive_and_zoned_datetimes_mix_as_utc(tmp_path, monkeypatch, capsys, time_keys):
    rc, err = run(tmp_path, monkeypatch, capsys, with_time(time_keys))
    assert rc == 0, err
    with h5py.File(tmp_path / "o.h5") as f:
        assert f["states/time"][-1] == 3600.0  # one hour, all read as UTC
        assert f.attrs["start"] == "2000-01-01T00:00:00+00:00"


@pytest.mark.parametrize("value, message", [
    ("inf", "key 'time.duration' = inf: input should be a finite number"),
    ("nan", "key 'time.duration' = nan"),
    ("1e300", f"is 1.67e+298 steps, above the limit of {MAX_STEPS:.0e} steps"),
    ('"1e30d"', f"above the limit of {MAX_STEPS:.0e} steps"),
])
def test_infinite_or_absurd_durations(tmp_path, monkeypatch, capsys, value, message):
    rc, err = run(tmp_path, monkeypatch, capsys, with_time(f"duration = {value}"))
    assert rc == 2 and message in err, err
    assert not (tmp_path / "o.h5").exists()


def test_absurd_counts_and_memory(tmp_path, monkeypatch, capsys):
    pack = "\n[[elements.pack]]\nlon = [0.0, 1.0]\nlat = [70.0, 71.0]\nnx = {}\nny = {}\n"
    rc, err = run(tmp_path, monkeypatch, capsys, BASE + pack.format(10**9, 10**6))
    assert rc == 2 and f"about 1e+15 elements, above the limit of {MAX_ELEMENTS:.0e}" in err
    n = int((physical_memory() / BYTES_PER_ELEMENT) ** 0.5) + 10  # just past this machine
    if n * n < MAX_ELEMENTS:
        rc, err = run(tmp_path, monkeypatch, capsys, BASE + pack.format(n, n))
        assert rc == 2 and "of memory" in err and f"({BYTES_PER_ELEMENT} bytes each)" in err


def test_a_tiny_coast_spacing_is_refused_before_building_a_mesh(tmp_path, monkeypatch, capsys):
    mesh = ("\n[elements.mesh]\nlon = [-150.0, -140.0]\nlat = [70.0, 72.0]\nspacing = 10e3\n"
            "coast_spacing = 1.0\n")
    rc, err = run(tmp_path, monkeypatch, capsys, BASE + mesh)
    assert rc == 2 and "[elements.mesh]: spacing 1 m over this box needs a land raster" in err


@pytest.mark.parametrize("table, key", [("run", "seed"), ("elements.pack", "seed")])
def test_negative_seeds(tmp_path, monkeypatch, capsys, table, key):
    extra = (f"\n[run]\n{key} = -1\n" if table == "run" else
             "\n[[elements.pack]]\nlon = [0.0, 1.0]\nlat = [70.0, 71.0]\nnx = 2\nny = 2\n"
             "seed = -1\n")
    rc, err = run(tmp_path, monkeypatch, capsys, BASE + extra)
    assert rc == 2 and "= -1: input should be greater than or equal to 0" in err, err


def test_a_file_that_is_not_a_shapefile(tmp_path, monkeypatch, capsys):
    (tmp_path / "coast.shp").write_bytes(b"not a shapefile at all")
    mesh = ("\n[elements.mesh]\nlon = [-150.0, -149.0]\nlat = [70.0, 70.5]\nspacing = 10e3\n"
            'land = "none"\nlandfast = "coast.shp"\n')
    rc, err = run(tmp_path, monkeypatch, capsys, BASE + mesh)
    assert rc == 2 and "coast.shp: not a readable shapefile" in err, err


def test_nan_initial_velocity_is_refused_before_step_1(tmp_path, monkeypatch, capsys):
    text = BASE.replace("[[elements.polygon]]", "[[elements.polygon]]\nvelocity = [nan, 0.0]", 1)
    rc, err = run(tmp_path, monkeypatch, capsys, text)
    assert rc == 2 and "key 'elements.polygon[0].velocity[0]' = nan" in err
    assert not (tmp_path / "o.h5").exists()



def test_a_nul_character_in_a_scene_string(tmp_path, monkeypatch, capsys):
    text = BASE.replace('title = "siku test scene"', 'title = "ice\\u0000floe"')
    rc, err = run(tmp_path, monkeypatch, capsys, text)
    assert rc == 2 and "s.toml: key 'title' holds a NUL character" in err, err
    assert not list(tmp_path.glob("*.h5")) and not list(tmp_path.glob(".*.partial"))


def test_a_self_crossing_polygon_is_named_as_such(tmp_path, capsys):
    """A bow tie (vertices out of order) is reported as crossing itself, with the two edges,
    not as too large."""
    from siku_core.run.cli import main
    from siku_core.testing import scene_text

    text = scene_text(elements=[(-150.0, 75.0)], duration=600, dt=60)
    text += ("\n[[elements.polygon]]\nvertices = [[-149.0, 75.0], [-148.9, 75.05], "
             "[-148.9, 75.0], [-149.0, 75.05]]\n")
    path = tmp_path / "bow.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["run", str(path), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "polygon crosses itself (edge 0-1 crosses edge 2-3)" in err[0]
    assert "too large" not in err[0] and "bow.toml" in err[0]
