"""Several writers per run ([[output.extra]]), the writer interface checked at load, and the
plugin guide's CSV writer run as written."""
from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from siku_core.errors import DataError, PluginError, SceneError
from siku_core.interfaces import Writer
from siku_core.plugins import Registry, check_component, get_registry
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text

ROOT = Path(__file__).resolve().parents[1]


def guide_writer():
    page = (ROOT / "docs" / "howto" / "plugins.md").read_text()
    block = [b for b in re.findall(r"```python\n(.*?)```", page, flags=re.S)
             if "class CentresCSV" in b]
    assert len(block) == 1
    ns: dict = {}
    exec(compile(block[0], "plugins.md (CentresCSV)", "exec"), ns)
    return ns["CentresCSV"]


def registry_with(cls) -> Registry:
    base = get_registry()
    reg = Registry(entries={k: dict(v) for k, v in base.entries.items()},
                   broken=dict(base.broken), plugins=dict(base.plugins))
    reg.add("writer", cls, "guide", "0")
    return reg


def scene(tmp_path, steps=20, nc="run.nc"):
    text = scene_text([(0.0, 80.0), (0.2, 80.0)], dt=60.0, duration=steps * 60.0,
                      thickness=0.5, extra=(
                          '[[process]]\nname = "thermodynamics"\nparams = { surface_temperature'
                          ' = -30.0 }\n\n[output]\nfile = "run.h5"\nevery = 300.0\n\n'
                          '[[output.extra]]\nwriter = "centres_csv"\nfile = "run.csv"\n\n'
                          f'[[output.extra]]\nwriter = "netcdf"\nfile = "{nc}"\n'))
    return scene_from_text(text, "<writers>")


def test_a_run_writes_every_writer_and_restarts_from_the_first(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    reg = registry_with(guide_writer())
    Simulation(scene(tmp_path), out=tmp_path / "run.h5", progress=False,
               registry=reg).run(steps=10)
    # the NetCDF writer continues its own file, as the HDF5 writer does: one file, whole
    # (main refused it, and a file given for the continuation held only the rows after it)
    before = xr.open_dataset(tmp_path / "run.nc").load()
    sim = Simulation(scene(tmp_path), out=tmp_path / "run.h5", restart=tmp_path / "run.h5",
                     progress=False, registry=reg)
    assert sim.restarted_from == 10
    sim.run()
    h5 = xr.open_dataset(tmp_path / "run.h5", engine="siku")
    nc = xr.open_dataset(tmp_path / "run.nc")
    assert list(h5["step"].values) == [0, 5, 10, 15, 20]
    assert list(nc["step"].values) == [0, 5, 10, 15, 20]
    assert np.array_equal(h5["thickness"].values, nc["thickness"].values)
    assert np.array_equal(h5["time"].values, (nc["time"].values - nc["time"].values[0])
                          / np.timedelta64(1, "s"))
    for k in before.data_vars:  # the rows before the restart: the old file's, value for value
        if "time" in before[k].dims:
            assert np.array_equal(before[k].values[:2], nc[k].values[:2], equal_nan=True), k
    rows = list(csv.reader(open(tmp_path / "run.csv")))[1:]  # after the writer's mark
    assert rows[0][2:] == ["lat [deg]", "lon [deg]", "flags [1]", "grown_volume [m3]",
                           "growth_rate [m s-1]", "mass [kg]", "thickness [m]"]
    assert len(rows) == 1 + 2 * h5.sizes["time"]
    last = [r for r in rows[1:] if float(r[0]) == sim.time]
    np.testing.assert_allclose([float(r[5]) for r in last], h5["grown_volume"].values[-1],
                               rtol=1e-15)


def test_two_writers_never_share_a_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    text = scene_text([(0.0, 80.0)], dt=60.0, duration=600.0, extra=(
        '[output]\nfile = "run.h5"\n\n[[output.extra]]\nwriter = "netcdf"\nfile = "run.h5"\n'))
    with pytest.raises(SceneError, match="already written by another writer"):
        Simulation(scene_from_text(text, "<same>"), progress=False)


class _NoWriteState(Writer):
    name = "broken_writer"

    def open(self, ctx):
        pass

    def close(self, ctx):
        pass


class _InstanceRestart(Writer):
    name = "instance_restart_writer"

    def open(self, ctx):
        pass

    def write_state(self, ctx):
        pass

    def close(self, ctx):
        pass

    def read_restart(self, path, ctx):  # not a classmethod
        return {}


def test_a_writer_missing_a_method_is_refused_at_load_in_one_line():
    with pytest.raises(PluginError, match=r"does not implement write_state\(\)") as e:
        check_component("writer", _NoWriteState, "bad_pkg")
    assert "\n" not in str(e.value)
    with pytest.raises(PluginError, match="read_restart must be a classmethod"):
        check_component("writer", _InstanceRestart, "bad_pkg")
    check_component("writer", guide_writer(), "guide")  # the guide's writer passes


def test_a_netcdf_file_of_another_layout_is_not_continued(tmp_path, monkeypatch):
    """A restart whose NetCDF writer would write other records (here without the outlines)
    refuses to continue the old file in one line and leaves it as it was."""
    monkeypatch.chdir(tmp_path)
    reg = registry_with(guide_writer())
    Simulation(scene(tmp_path), out=tmp_path / "run.h5", progress=False,
               registry=reg).run(steps=10)
    before = (tmp_path / "run.nc").read_bytes()
    text = scene(tmp_path).text.replace('file = "run.nc"\n',
                                        'file = "run.nc"\nparams = { outlines = false }\n')
    (tmp_path / "run.csv").unlink()
    with pytest.raises(DataError, match="run.nc: cannot continue this file in place") as ei:
        Simulation(scene_from_text(text, "<writers>"), out=tmp_path / "run.h5",
                   restart=tmp_path / "run.h5", progress=False, registry=reg,
                   force=True).run()
    assert "\n" not in str(ei.value)
    assert (tmp_path / "run.nc").read_bytes() == before


def test_every_writer_learns_whether_overwrite_was_given(tmp_path, monkeypatch):
    """``Writer.overwrite`` is set on the file's writer and every further writer before they
    open: False by default, True with ``overwrite=True`` (``--overwrite``)."""
    monkeypatch.chdir(tmp_path)
    reg = registry_with(guide_writer())
    for flag in (False, True):
        seen = []
        for name in ("hdf5", "centres_csv"):
            cls = reg.get("writer", name)

            def spy(self, ctx, _open=cls.open):
                seen.append((self.name, self.overwrite))
                return _open(self, ctx)

            monkeypatch.setattr(cls, "open", spy)
        Simulation(scene(tmp_path, steps=5), out=tmp_path / "run.h5", progress=False,
                   registry=reg, overwrite=flag).run()
        monkeypatch.undo()
        monkeypatch.chdir(tmp_path)
        assert {n for n, _ in seen} >= {"hdf5", "centres_csv"}
        assert all(o is flag for _, o in seen), seen
