"""A run held in memory as an xarray Dataset (``Simulation.to_xarray``): the same variables,
units, coordinates and values as the siku xarray engine gives for the output file of the same
run."""
from __future__ import annotations

import pytest

from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene

xr = pytest.importorskip("xarray")


def _scene():
    return make_scene(
        elements=[(-150.0, 75.0), (-149.8, 75.05)],
        forcing=[{"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}},
                 {"source": "water_drag"}],
        duration=3600, dt=60, output={"every": "20min"},
        start=__import__("datetime").datetime(2001, 4, 6))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same scene written to a file, kept in memory, and run with no output at all."""
    path = tmp_path_factory.mktemp("xr") / "run.h5"
    Simulation(_scene(), out=path, progress=False).run()
    kept = Simulation(_scene(), out="memory", progress=False).run()
    bare = Simulation(_scene(), out=False, progress=False).run()
    return path, kept, bare


def _without_source(ds):
    ds = ds.copy()
    ds.attrs.pop("source")
    return ds


@pytest.mark.parametrize("group", [None, "diagnostics"])
def test_a_run_kept_in_memory_is_its_file_in_xarray(runs, group):
    path, kept, _ = runs
    assert not list(path.parent.glob("*memory*"))  # nothing written for the kept run
    with xr.open_dataset(path, engine="siku", group=group) as on_disk:
        in_memory = kept.to_xarray(group=group)
        assert in_memory.attrs["source"].endswith("run held in memory")
        xr.testing.assert_identical(_without_source(in_memory), _without_source(on_disk.load()))
    if group is None:
        assert in_memory.sizes["time"] == 4  # 0, 20, 40, 60 min
        assert in_memory["u"].attrs["units"] == "m s-1"
        assert str(in_memory["time"].values[-1]).startswith("2001-04-06T01:00")


def test_a_run_without_output_gives_its_state_now(runs):
    """``out=False``: the state after the run, equal to the file's last snapshot."""
    path, _, bare = runs
    with xr.open_dataset(path, engine="siku") as on_disk:
        last = on_disk.isel(time=[-1]).load()
    xr.testing.assert_identical(_without_source(bare.to_xarray()), _without_source(last))


def test_a_kept_run_continues_its_snapshots_over_two_runs(tmp_path):
    """``run(30)`` then ``run()``: the snapshots kept are those the file of the same two runs
    holds (the second run does not repeat the state it starts from)."""
    sim = Simulation(_scene(), out="memory", progress=False)
    sim.run(30)
    assert sim.to_xarray().sizes["time"] == 2  # 0 and 20 min
    sim.run()
    ds = sim.to_xarray(outlines=False)
    assert "node_lon" not in ds
    filed = Simulation(_scene(), out=tmp_path / "two.h5", progress=False)
    filed.run(30)
    filed.run()
    with xr.open_dataset(tmp_path / "two.h5", engine="siku", outlines=False) as on_disk:
        xr.testing.assert_identical(_without_source(ds), _without_source(on_disk.load()))
    assert list(ds["step"].values) == [0, 20, 40, 60]


def test_the_memory_writer_is_refused_for_a_file(tmp_path):
    from siku_core.errors import SceneError

    scene = make_scene(elements=[(-150.0, 75.0)], duration=120, dt=60,
                       output={"every": "1min", "writer": "memory"})
    with pytest.raises(SceneError, match="writer 'memory' keeps a run's snapshots for Python"):
        Simulation(scene, out=tmp_path / "x.h5", progress=False).run()
    assert not list(tmp_path.iterdir())
