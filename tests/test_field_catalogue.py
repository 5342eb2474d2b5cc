"""One catalogue of per-element fields (``siku_core.fields``): every field the engine or a
shipped component writes has its units there, the files carry exactly those units, and a map's
colour bar of every catalogued field shows them.

The run: three free squares with thickness categories under thermodynamics with lateral growth
(so it writes the engine's ``speed``, the changing ``thickness``, ``mass``, ``flags``, the
category fields and the process's ``grown_volume``, ``growth_rate`` and ``lateral_volume``, the
last switched on by a parameter) and a contact phase without joints (``damage`` and the
stresses), for two steps to an HDF5 file.
"""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from siku_core.fields import (ENGINE_FIELDS, RESERVED_FIELDS, STATE_FIELDS, ElementField,
                              catalogue, declarations)
from siku_core.interfaces import ElementSource, ElementSpec
from siku_core.plugins import get_registry
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_core.testing.contact_cases import registry_with
from siku_core.testing.scenes import square


class _Squares(ElementSource):
    """Three squares of 2 km at 80 N, 4 km apart, with two thickness categories each."""

    name = "catalogue_squares"

    def build(self, scene, seed, where):
        return [ElementSpec(np.array(square((k * 0.25, 80.0), 2000.0)), thickness=1.0,
                            categories=(np.array([0.3, 0.5]), np.array([0.6, 1.4])))
                for k in range(3)]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("catalogue") / "run.h5"
    txt = scene_text([], dt=0.25, duration=0.5, output={"file": str(path), "every": 0.25},
                     extra='[[elements.source]]\nname = "catalogue_squares"\n\n'
                           '[contact]\nlaw = "distributed_spring"\njoints = "none"\n\n'
                           '[[process]]\nname = "thermodynamics"\n'
                           'params = { surface_temperature = -20.0, lateral = true }\n')
    reg = registry_with("element_source", _Squares)
    sim = Simulation(scene_from_text(txt, "<catalogue>"), progress=False, registry=reg).run()
    return sim, path


def _shipped() -> list[tuple[str, type]]:
    reg = get_registry()
    return [(f"{kind} '{n}'", e.cls) for kind, table in reg.entries.items()
            for n, e in sorted(table.items()) if e.package == "siku"]


def test_every_field_a_run_writes_has_units_in_the_catalogue_and_in_the_file(run):
    sim, path = run
    specs = catalogue(sim.components())
    written = sim.element_fields()
    # the run writes the engine's fields of every kind and a field a parameter switched on
    assert {"speed", "damage", "stress_ee", "thickness", "mass", "flags", "category_fraction",
            "grown_volume", "lateral_volume"} <= set(written)
    with h5py.File(path) as f:
        stored = f["states/fields"]
        assert set(stored) == set(written)
        for name in written:
            spec = specs[name]
            assert spec.units and spec.long_name, name
            assert stored[name].attrs["units"] == spec.units, name
            assert stored[name].attrs["long_name"] == spec.long_name, name
            if spec.standard_name:
                assert stored[name].attrs["standard_name"] == spec.standard_name, name
        # the restart carries the catalogue's restarted fields of the run, and no other
        kept = set(f["states/history/elements"])
    want = {n for n in written if specs[n].restart}
    assert kept == want and "mass" not in kept and "thickness" in kept


def test_every_field_a_shipped_component_declares_has_units_in_the_catalogue():
    known = get_registry().field_catalogue()
    found = 0
    for who, cls in _shipped():
        for f in declarations(cls):
            assert isinstance(f, ElementField), who
            f.check(who)  # units, long name, grid, a name not the engine's
            assert known[f.name] == f, (who, f.name)
            found += 1
    assert found >= 15  # thermodynamics, ridging, floating, the spectral field
    for name, spec in {**ENGINE_FIELDS, **STATE_FIELDS}.items():
        assert known[name] is spec and spec.units and name in RESERVED_FIELDS


def test_an_instance_owns_no_field_its_class_does_not_declare():
    from siku_plugins.processes import Thermodynamics

    on = Thermodynamics({"lateral": True})
    assert {f.name for f in on.owned_fields} == {f.name for f in declarations(Thermodynamics)}
    assert "lateral_volume" not in {f.name for f in Thermodynamics({}).owned_fields}


def test_the_colour_bar_of_every_catalogued_field_shows_its_units(run):
    pytest.importorskip("cartopy")
    import matplotlib.pyplot as plt

    from siku_io.plot.element_maps import MapPainter, Output

    _, path = run
    out = Output(path)
    n, N = len(out.time), len(out.flags)
    rows = np.linspace(0.1, 1.0, n * N).reshape(n, N)
    known = get_registry().field_catalogue()
    per_element = {k: s for k, s in known.items() if not k.startswith("category_")}
    assert "grown_volume" in per_element and "speed" in per_element
    for name, spec in per_element.items():
        out.fields.setdefault(name, rows)
        painter = MapPainter(out, name, land=False)
        assert painter.colorbar.ax.get_ylabel() == f"{name} [{spec.units}]", name
        plt.close(painter.fig)
    # a field no installed component declares: the file's own units
    out.fields["imported_albedo"], out.units["imported_albedo"] = rows, "1"
    painter = MapPainter(out, "imported_albedo", land=False)
    assert painter.colorbar.ax.get_ylabel() == "imported_albedo [1]"
    plt.close(painter.fig)
