"""Only what a scene requires is built (docs/explanation/design.md, "Scene file").

* A free-drift scene (no ``[contact]`` table) has no contact model and allocates no contact
  arrays: traced memory stays well below that of the same pack with joints.
* A scene without gridded forcing opens no NetCDF file: after building and running such scenes
  (analytic wind, water drag, Coriolis; and a bonded pack), neither ``netCDF4`` nor ``xarray``
  is imported, and without an output file neither is ``h5py``.

Memory and imports only: no wall-clock assertion (``bench/`` measures times).
"""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import tracemalloc
from pathlib import Path

from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene
from siku_core.testing.contact_conformance import contact_scene, square_pack

ROOT = Path(__file__).resolve().parents[1]
WIND = {"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}}


def pack_scene(contact: bool):
    pack = square_pack(0.0, -1.0, 20, 20, 20000.0, left="static", right="steady",
                       right_velocity=[3.0, 0.0])
    if contact:
        return contact_scene("distributed_spring", {"tensile_strain": 0.05}, packs=[pack],
                             dt=2.0, steps=10, forcing=[WIND])
    return make_scene([], packs=[pack], forcing=[WIND], dt=2.0, duration=20.0)


def traced_contact_bytes(scene) -> tuple[int, Simulation]:
    """Bytes held, after building and running ``scene``, by arrays allocated in the engine's
    contact modules (``contact_model.py``, ``contacts.py``): what the process allocates
    elsewhere (caches, what earlier tests left) does not count."""
    Simulation(scene, out=False, progress=False).run(2)  # compile outside the traced region
    tracemalloc.start()
    try:
        sim = Simulation(scene, out=False, progress=False)
        sim.run(3)
        snap = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    snap = snap.filter_traces([tracemalloc.Filter(True, "*siku_core/contact/contact_model.py"),
                               tracemalloc.Filter(True, "*siku_core/contact/contact_forces.py")])
    return sum(s.size for s in snap.statistics("filename")), sim


def test_free_drift_allocates_no_contact_arrays():
    free_bytes, free = traced_contact_bytes(pack_scene(contact=False))
    bonded_bytes, bonded = traced_contact_bytes(pack_scene(contact=True))
    assert free.contacts is None
    assert bonded.contacts is not None and bonded.contacts.n_joints > 700
    assert free.state.n == bonded.state.n == 400
    # the free-drift scene holds none of the contact model's arrays; the bonded one holds at
    # least the per-joint and per-pair rows numpy allocates (tracemalloc does not see the ones
    # compiled code allocates)
    cm = bonded.contacts
    rows = cm.joint_rows.nbytes + cm.pair_rows.nbytes + cm.rm.nbytes + cm.hist.nbytes
    assert free_bytes == 0
    assert bonded_bytes >= rows, (bonded_bytes, rows)
    assert set(free.timings) == set(bonded.timings)
    assert free.timings["joints"] == free.timings["collisions"] == 0.0


def test_scenes_without_gridded_forcing_import_no_netcdf_library():
    code = textwrap.dedent("""
        import json, sys
        from siku_core.run.simulation import Simulation
        from siku_core.testing import make_scene
        from siku_core.testing.contact_conformance import contact_scene, square_pack
        wind = {"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}}
        pack = square_pack(0.0, -1.0, 6, 6, 20000.0, left="static")
        scenes = [
            make_scene([(-150.0, 75.0), (-149.0, 75.0)], dt=60.0, duration=600.0,
                       forcing=[{"source": "air_drag", "field": {"type": "cyclone"}},
                                {"source": "water_drag"}, {"source": "coriolis"}]),
            make_scene([], packs=[pack], forcing=[wind], dt=2.0, duration=20.0),
            contact_scene("distributed_spring", {}, packs=[pack], dt=2.0, steps=10,
                          forcing=[wind]),
        ]
        for sc in scenes:
            Simulation(sc, out=False, progress=False).run()
        print(json.dumps(sorted(m.split(".")[0] for m in sys.modules)))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    mods = set(json.loads(r.stdout.splitlines()[-1]))
    assert "siku_forcing" in mods  # the forcing plugins did load
    assert not mods & {"netCDF4", "xarray", "h5py"}, sorted(mods & {"netCDF4", "xarray", "h5py"})
