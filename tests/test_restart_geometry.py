"""What ``/geometry`` holds after a restart (``docs/explanation/outputs.md``): the elements at
the file's first snapshot. A restart that continues the file keeps its ``/geometry`` (the
same, bit for bit, as an uninterrupted run's); a restart written to another file starts that
file at the restored snapshot, and its ``/geometry`` holds the elements there. Held for the
HDF5 and the Zarr writer, in a scene whose process changes the thickness (and so the mass and
the moment of inertia)."""
from __future__ import annotations

import h5py
import numpy as np
import zarr

from siku_core.interfaces import Process
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_core.testing.process_checks import process_registry
from siku_io.output.layout import GEOMETRY


class _Grow(Process):
    """Every element thickens by 0.1 mm/s."""

    name = "test_grow_geometry"

    def apply(self, ctx, dt):
        ctx.state.thickness += 1e-4 * dt


def _open(path):
    return h5py.File(path, "r") if path.suffix == ".h5" else zarr.open_consolidated(str(path))


def test_geometry_holds_the_elements_at_the_files_first_snapshot_after_a_restart(tmp_path):
    registry = process_registry(_Grow)
    for writer, ext in (("hdf5", "h5"), ("zarr", "zarr")):
        scene = tmp_path / f"{writer}.toml"
        scene.write_text(scene_text(
            [(-150.0, 75.0), (-149.6, 75.0)], dt=60.0, duration=240.0, thickness=1.0,
            output={"file": str(tmp_path / f"whole.{ext}"), "every": 120.0, "writer": writer},
            extra=f'[[process]]\nname = "{_Grow.name}"\n'), encoding="utf-8")
        Simulation(str(scene), progress=False, registry=registry).run()
        part, other = tmp_path / f"part.{ext}", tmp_path / f"other.{ext}"
        Simulation(str(scene), out=part, progress=False, registry=registry).run(steps=2)
        Simulation(str(scene), out=other, restart=part, progress=False,
                   registry=registry).run()  # continued in another file
        Simulation(str(scene), out=part, restart=part, progress=False,
                   registry=registry).run()  # continued in the same file
        whole, part, other = _open(tmp_path / f"whole.{ext}"), _open(part), _open(other)
        thick = whole["states/fields/thickness"][:]
        assert thick[1, 0] > thick[0, 0], "the process thickens the ice"
        for k in GEOMETRY:  # in place: the uninterrupted run's /geometry, bit for bit
            assert np.array_equal(part["geometry"][k][...], whole["geometry"][k][...]), (
                writer, k)
        assert np.array_equal(part["geometry/thickness"][:], thick[0])
        # another file: the elements at the restored snapshot (step 2), its first
        assert other["states/step"][:].tolist()[0] == 2
        assert np.array_equal(other["geometry/thickness"][:], thick[1])
        assert np.array_equal(other["geometry/m"][:], whole["states/fields/mass"][1])
        assert not np.array_equal(other["geometry/m"][:], whole["geometry/m"][:])
