"""The ice-life example (examples/ice_life/cold_snap.toml) at small size: the cold snap grows
the ice, ridging moves volume without changing the total, the volume budget closes, and the
example's pictures are drawn."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from siku_core.scene.scene_file import load_scene
from siku_core.run.simulation import Simulation
from siku_core.testing.process_checks import ice_volume

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "ice_life"
SMALL = {"time.duration": "3h", "elements.mesh.spacing": "40e3",
         "elements.mesh.coast_spacing": "30e3"}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("ice_life")
    sim = Simulation(load_scene(EXAMPLE / "cold_snap.toml", SMALL), out=d / "cold_snap.h5",
                     progress=False)
    v0 = ice_volume(sim)
    sim.run()
    return sim, v0, d


def test_the_cold_snap_grows_ice_and_the_budget_closes(run):
    sim, v0, _ = run
    thermo, ridging = sim.processes[0], sim.processes[1]
    v1 = ice_volume(sim)  # [m³], sum A sum a_k h_k of the elements not melted
    grown = thermo.budget(sim.context)
    assert grown > 0  # 3 h at -40 °C on 0.5 m ice: growth beats the 20 W/m² ocean flux
    assert (v1 - v0) == pytest.approx(grown, rel=1e-10)
    assert ridging.budget(sim.context) == 0.0 and "volume" in ridging.conserves
    assert float(sim.context.fields["ridged_volume"].sum()) > 0  # floes pile up at the coast
    assert sim.context.categories.fraction.sum(1).min() < 1.0  # ... and open water where they did


def test_the_example_draws_its_pictures(run, capsys):
    _, _, d = run
    spec = importlib.util.spec_from_file_location("ice_life_budget", EXAMPLE / "budget.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main([str(d / "cold_snap.h5"), str(d / "pictures")]) == 0
    out = capsys.readouterr().out
    assert "budget closes to" in out
    b = mod.budget(d / "cold_snap.h5")
    np.testing.assert_allclose(b["change"], b["grown"], rtol=1e-9, atol=1e-6 * abs(b["grown"][-1]))
    for name in ("thickness_change.png", "volume_budget.png"):
        assert (d / "pictures" / name).stat().st_size > 10_000
    with pytest.raises(FileExistsError):  # never replaces a picture
        mod.draw(d / "cold_snap.h5", d / "pictures")
