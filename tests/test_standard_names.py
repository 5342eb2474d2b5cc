"""Every declared CF ``standard_name`` reaches every output: the HDF5 file's attributes, the
Zarr store's, the NetCDF writer's variables, both exports (NetCDF, Zarr) and the xarray engine.

The declarations: a component's :class:`~siku_core.fields.ElementField` ``standard_name`` and the
engine's own catalogue (``siku_core.fields.STANDARD_NAMES``). A tiny scene with a process that
declares one field with a standard name (and so writes the changing thickness too) is run once
with the three writers; each output is read and compared with the declarations.
"""
from __future__ import annotations

import h5py
import netCDF4
import pytest
import xarray as xr
import zarr

from siku_core.fields import STANDARD_NAMES, ElementField
from siku_core.interfaces import Process
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_core.testing.process_checks import process_registry
from siku_io.output.netcdf import export
from siku_io.output.zarr_store import export_zarr


class _Albedo(Process):
    """Declares a field with a CF standard name and keeps it at 0.6."""

    name = "test_albedo"
    owned_fields = (ElementField("test_albedo", "1", "surface albedo of the element",
                                 initial=0.6, standard_name="surface_albedo"),)

    def apply(self, ctx, dt):
        ctx.fields["test_albedo"][:] = 0.6


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("standard_names")
    text = scene_text([(-150.0, 75.0), (-149.6, 75.0)], dt=60.0, duration=120.0,
                      output={"file": str(d / "run.h5"), "every": 60.0, "extra": [
                          {"writer": "zarr", "file": str(d / "run.zarr")},
                          {"writer": "netcdf", "file": str(d / "run.nc")}]},
                      extra='[[process]]\nname = "test_albedo"\n')
    (d / "scene.toml").write_text(text, encoding="utf-8")
    sim = Simulation(str(d / "scene.toml"), progress=False,
                     registry=process_registry(_Albedo)).run()
    declared = {f.name: f.standard_name for c in sim.components() for f in c.owned_fields
                if f.standard_name}
    fields = sim.element_fields()
    declared.update({k: v for k, v in STANDARD_NAMES.items() if k in fields})
    export(d / "run.h5", d / "export.nc")
    export_zarr(d / "run.h5", d / "export.zarr")
    return d, declared


def test_every_declared_standard_name_is_in_every_output(run):
    d, declared = run
    assert declared["test_albedo"] == "surface_albedo"
    assert {"speed", "thickness"} <= set(declared)  # the engine's own, thickness changing
    with h5py.File(d / "run.h5", "r") as f:
        store = zarr.open_consolidated(str(d / "run.zarr"), mode="r")
        for name, standard in declared.items():
            assert f[f"states/fields/{name}"].attrs["standard_name"] == standard, name
            assert store[f"states/fields/{name}"].attrs["standard_name"] == standard, name
        assert f["geometry/thickness"].attrs["standard_name"] == declared["thickness"]
        assert store["geometry/thickness"].attrs["standard_name"] == declared["thickness"]
    for path in ("run.nc", "export.nc"):
        with netCDF4.Dataset(d / path) as nc:
            for name, standard in declared.items():
                assert nc[name].getncattr("standard_name") == standard, (path, name)
    for ds in (xr.open_zarr(d / "export.zarr"), xr.open_dataset(d / "run.h5", engine="siku"),
               xr.open_dataset(d / "run.zarr", engine="siku")):
        for name, standard in declared.items():
            assert ds[name].attrs["standard_name"] == standard, name
