"""Output as science data: the self-describing HDF5 file, xarray, CF-NetCDF, gridded files.

* Every dataset of a real output file carries ``units`` and ``long_name`` and is on the
  reference page ``docs/reference/output.md``; coded ones carry CF flag meanings; time has its
  epoch.
* ``xr.open_dataset(path, engine="siku")`` gives dims ``time`` x ``element``, ``datetime64``
  time, lon/lat coordinates, units, and the values of the file exactly (round trip).
* ``siku export`` and ``siku grid`` files, and the NetCDF writer's, pass the IOOS compliance
  checker's CF 1.8 suite with no high-priority failures (its errors), and open in xarray with
  decoded times and units; their values equal the HDF5 file's.
"""
from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from siku_core.run.cli import main

ROOT = Path(__file__).resolve().parents[1]
START = "2001-04-06T00:00:00Z"
RUN = ["--no-progress", "--no-plots", "--set", "time.duration=40min",
       "--set", "contact.params.tensile_strain=0.003",
       "--set", f"time.start={START}"]


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """The pack pull (joints, breaks, collisions) for 40 min as HDF5 and as NetCDF."""
    d = tmp_path_factory.mktemp("formats")
    scene = str(ROOT / "examples" / "pack_pull.toml")
    assert main(["run", scene, "--out", str(d / "run.h5"), *RUN]) == 0
    assert main(["run", scene, "--out", str(d / "run_writer.nc"), *RUN,
                 "--set", "output.writer=netcdf"]) == 0
    return d


def leaves(f):
    out = []
    f.visititems(lambda name, obj: out.append((name, obj)) if isinstance(obj, h5py.Dataset)
                 else None)
    return out


def test_every_dataset_explains_itself_and_is_on_the_reference_page(outputs):
    page = (ROOT / "docs" / "reference" / "output.md").read_text(encoding="utf-8")
    with h5py.File(outputs / "run.h5") as f:
        for name in f.attrs:
            assert f"`{name}`" in page, name
        for name, ds in leaves(f):
            assert "units" in ds.attrs and ds.attrs["long_name"], name
            parts = name.split("/")
            if parts[0] == "diagnostics" and parts[1] not in ("step", "time"):
                key = "/diagnostics/NAME"
                assert key in page
            elif parts[:2] == ["states", "history"]:
                assert "/states/history/KEY/NAME" in page
                if parts[2] == "contacts":
                    assert f"`{parts[3]}`" in page, name
            elif parts[:2] == ["states", "fields"]:
                assert f"`{parts[2]}`" in page, name
            else:
                assert f"`/{name}`" in page, name
        assert f["states/time"].attrs["units"] == "seconds since 2001-04-06 00:00:00"
        flags = f["geometry/flags"].attrs
        assert flags["flag_meanings"].split() == ["free", "static", "steady", "melted"]
        assert flags["flag_values"].dtype == f["geometry/flags"].dtype
        assert "breaks" in f and f["breaks/time"].shape[0] > 0
        assert f["breaks/mode"].attrs["flag_meanings"].split()[1] == "strain"


def test_xarray_reads_the_file_exactly(outputs):
    path = outputs / "run.h5"
    ds = xr.open_dataset(path, engine="siku")
    assert ds["u"].dims == ("time", "element")
    assert np.issubdtype(ds["time"].dtype, np.datetime64)
    assert ds["time"].values[0] == np.datetime64("2001-04-06T00:00:00")
    assert ds["u"].attrs["units"] == "m s-1" and ds["area"].attrs["units"] == "m2"
    with h5py.File(path) as f:
        s = f["states"]
        seconds = (ds["time"].values - ds["time"].values[0]) / np.timedelta64(1, "s")
        assert np.array_equal(seconds, s["time"][...])
        for a, b in (("lon", "lon"), ("lat", "lat"), ("spin", "w"), ("q", "q"), ("V", "V"),
                     ("damage", "fields/damage"), ("stress_ee", "fields/stress_ee")):
            assert np.array_equal(ds[a].values, s[b][...]), a
        assert np.array_equal(ds["area"].values, f["geometry/area"][...])
        # east/north velocity: the local velocity turned by the element's frame, |V| kept
        assert np.allclose(np.hypot(ds["u"], ds["v"]), np.hypot(*np.moveaxis(s["V"][...], -1,
                                                                               0)),
                           rtol=1e-14, atol=1e-15)
    diag = xr.open_dataset(path, engine="siku", group="diagnostics")
    assert diag["kinetic_energy"].attrs["units"] == "J"
    breaks = xr.open_dataset(path, engine="siku", group="breaks")
    assert breaks.sizes["break"] > 0
    # the outlines: each element's nodes lie around its centre
    from siku_io.output.xr import outlines_at

    polys = outlines_at(ds, -1)
    assert len(polys) == ds.sizes["element"]
    centre = np.array([p.mean(axis=0) for p in polys])
    assert np.allclose(centre, np.column_stack([ds["lon"][-1], ds["lat"][-1]]), atol=0.05)


def cf_errors(path: Path) -> list[str]:
    """High-priority failures of the IOOS compliance checker's CF 1.8 suite."""
    from compliance_checker.runner import CheckSuite

    cs = CheckSuite()
    cs.load_all_available_checkers()
    ds = cs.load_dataset(str(path))
    results = cs.run_all(ds, ["cf:1.8"], skip_checks=[])["cf:1.8"][0]
    bad = []
    for r in results:
        score, out_of = r.value if isinstance(r.value, tuple) else (r.value, True)
        if r.weight == 3 and score < out_of:
            bad.append(f"{r.name}: {r.msgs}")
    return bad


def test_siku_export_writes_cf_netcdf_with_the_same_values(outputs, capsys):
    pytest.importorskip("compliance_checker")
    out = outputs / "run.nc"
    assert main(["export", str(outputs / "run.h5"), "--to", "netcdf", "--out", str(out)]) == 0
    assert cf_errors(out) == []
    nc = xr.open_dataset(out)
    h5 = xr.open_dataset(outputs / "run.h5", engine="siku")
    assert nc.attrs["featureType"] == "trajectory"
    assert np.issubdtype(nc["time"].dtype, np.datetime64)
    assert nc["time"].values[0, 0] == np.datetime64("2001-04-06T00:00:00")
    assert nc["u"].attrs["units"] == "m s-1"
    assert np.array_equal(nc["u"].values, h5["u"].values.T)
    assert np.array_equal(nc["lon"].values, h5["lon"].values.T)
    assert np.array_equal(nc["node_lon"].values, h5["node_lon"].values[0])
    # an existing file is never replaced without --overwrite
    assert main(["export", str(outputs / "run.h5"), "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err


def test_the_netcdf_writer_holds_the_run(outputs):
    pytest.importorskip("compliance_checker")
    path = outputs / "run_writer.nc"
    assert cf_errors(path) == []
    nc = xr.open_dataset(path)
    h5 = xr.open_dataset(outputs / "run.h5", engine="siku")
    assert np.array_equal(nc["time"].values, h5["time"].values)
    for k in ("u", "v", "lon", "lat", "damage", "stress_nn"):
        assert np.array_equal(nc[k].values, h5[k].values), k
    assert np.array_equal(nc["node_lon_t"].values, h5["node_lon"].values)
    from siku_io.output.netcdf import complete_records

    assert complete_records(path) == h5.sizes["time"]


def test_every_format_records_the_versions_of_siku_its_plugin_api_and_the_plugins(outputs):
    """HDF5 root attributes, the NetCDF writer's and siku export's global attributes: siku's
    version, the plugin API version (siku_core.PLUGIN_API_VERSION) and the plugins'."""
    import json

    import netCDF4

    from siku_core import PLUGIN_API_VERSION, __version__

    with h5py.File(outputs / "run.h5") as f:
        assert f.attrs["siku_version"] == __version__
        assert f.attrs["siku_plugin_api"] == PLUGIN_API_VERSION
        assert f["plugins"].attrs["siku"] == __version__
    out = outputs / "versions.nc"
    assert main(["export", str(outputs / "run.h5"), "--to", "netcdf", "--out", str(out)]) == 0
    for path in (outputs / "run_writer.nc", out):
        with netCDF4.Dataset(path) as nc:
            assert nc.getncattr("siku_siku_version") == __version__, path
            assert nc.getncattr("siku_siku_plugin_api") == PLUGIN_API_VERSION, path
            assert json.loads(nc.getncattr("siku_plugins"))["siku"] == __version__, path


def test_siku_grid_writes_cf_netcdf(outputs, capsys):
    pytest.importorskip("compliance_checker")
    out = outputs / "run.grid.nc"
    assert main(["grid", str(outputs / "run.h5"), "--lon", "-1", "11", "--lat", "-3", "3",
                 "--resolution", "0.5", "--no-progress"]) == 0
    line = capsys.readouterr().out
    assert re.search(r"run\.grid\.nc: \d+ times on a lonlat grid of 12 x 24 cells", line)
    assert cf_errors(out) == []
    g = xr.open_dataset(out)
    assert np.issubdtype(g["time"].dtype, np.datetime64)
    assert g["concentration"].attrs["standard_name"] == "sea_ice_area_fraction"
    assert g["stress_xx"].attrs["units"] == "N m-1"
    h5 = xr.open_dataset(outputs / "run.h5", engine="siku")
    ice = (g["concentration"] * g["cell_area"]).sum(("lat", "lon")).values
    assert np.allclose(ice, h5["area"].sum().item(), rtol=1e-9)
    ps = outputs / "ps.nc"
    assert main(["grid", str(outputs / "run.h5"), "--kind", "polar_stereographic",
                 "--central-longitude", "5", "--x", "-6000000", "6000000", "--y", "-6000000",
                 "6000000", "--resolution", "100000", "--out", str(ps), "--no-progress",
                 "--no-leads"]) == 0
    assert cf_errors(ps) == []


def test_bad_grid_requests_are_refused_with_one_line(outputs, capsys):
    h5 = str(outputs / "run.h5")
    assert main(["grid", h5, "--no-progress"]) == 2  # no grid given, none in the scene
    assert "[output.grid]" in capsys.readouterr().err
    assert main(["grid", h5, "--lon", "0", "10", "--lat", "5", "-5", "--resolution", "1"]) == 2
    err = capsys.readouterr().err
    assert "south" in err and len(err.strip().splitlines()) == 1
    assert main(["grid", h5, "--lon", "0", "10", "--lat", "0", "5", "--resolution", "0.3"]) == 2
    assert "whole number" in capsys.readouterr().err
    assert main(["grid", str(outputs / "missing.h5"), "--lon", "0", "1", "--lat", "0", "1",
                 "--resolution", "1"]) == 2
    assert "not found" in capsys.readouterr().err


def test_a_scene_grid_table_is_checked_before_the_run_and_written_after_it(tmp_path, capsys):
    from siku_core.testing.scenes import scene_text

    grid = ('[output.grid]\nkind = "lonlat"\nlon = [-1, 1]\nlat = [69, 71]\nresolution = 0.5\n'
            'every = "10min"\n')
    text = scene_text([(0.0, 70.0), (0.2, 70.0)], duration="20min", dt=60.0,
                      output={"every": "5min"}, extra=grid)
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o.h5"),
                 "--no-progress"]) == 0
    assert "derived:" in capsys.readouterr().err
    g = xr.open_dataset(tmp_path / "o.grid.nc")
    assert g.sizes["time"] == 3  # 0, 10, 20 min of the 5-minute snapshots
    bad = text.replace('kind = "lonlat"', 'kind = "lonlat"\ncolour = 3')
    (tmp_path / "bad.toml").write_text(bad, encoding="utf-8")
    assert main(["run", str(tmp_path / "bad.toml"), "--out", str(tmp_path / "b.h5")]) == 2
    err = capsys.readouterr().err
    assert "[output.grid]" in err and "colour" in err
    assert not (tmp_path / "b.h5").exists()


def test_gridded_fields_are_drawn_with_their_units(outputs):
    from siku_io.plot.grid_maps import plot_grid

    grid = outputs / "run.grid.nc"
    if not grid.exists():
        assert main(["grid", str(outputs / "run.h5"), "--lon", "-1", "11", "--lat", "-3", "3",
                     "--resolution", "0.5", "--no-progress"]) == 0
    files = plot_grid(grid, outputs / "pictures", "stress_I", animation=False)
    assert [f.name for f in files] == ["run_grid_stress_I_first.png",
                                       "run_grid_stress_I_last.png"]
    assert all(f.stat().st_size > 10_000 for f in files)
    assert main(["plot", str(grid), "--field", "colour"]) == 2


def test_every_grid_key_is_on_the_scene_reference():
    from siku_forcing.gridded.regular_grid import GridCfg

    text = (ROOT / "docs" / "reference" / "scene.md").read_text(encoding="utf-8")
    section = text.split("## `output.grid`")[1].split("\n## ")[0]
    for key in GridCfg.model_fields:
        assert f"| `{key}` |" in section, key


def test_the_results_guide_runs(outputs, monkeypatch):
    """The python blocks of docs/howto/results.md run on a real output (its file names
    replaced), and its [output.grid] tables validate."""
    import tomllib

    import matplotlib

    matplotlib.use("Agg")
    from siku_forcing.gridded.regular_grid import GridCfg

    guide = (ROOT / "docs" / "howto" / "results.md").read_text(encoding="utf-8")
    grid = outputs / "run.grid.nc"
    if not grid.exists():
        assert main(["grid", str(outputs / "run.h5"), "--lon", "-1", "11", "--lat", "-3", "3",
                     "--resolution", "0.5", "--no-progress"]) == 0
    blocks = re.findall(r"^```python\s*\n(.*?)^```", guide, re.MULTILINE | re.DOTALL)
    assert len(blocks) >= 2
    scope: dict = {}
    for code in blocks:
        code = code.replace("siku_default.grid.nc", str(grid)).replace(
            "siku_default.h5", str(outputs / "run.h5"))
        exec(compile(code, "results.md", "exec"), scope)
    tables = re.findall(r"^```toml\s*\n(.*?)^```", guide, re.MULTILINE | re.DOTALL)
    assert tables
    for t in tables:
        GridCfg(**tomllib.loads(t)["output"]["grid"])
