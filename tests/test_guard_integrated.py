"""The guard watches every degree of freedom a component integrates
(``Component.integrates``): a floating element's heave rate above ``[run] max_speed`` or a
non-finite tilt stops the run at the last good snapshot and is never written."""
from __future__ import annotations

import h5py
import numpy as np
import pytest
from test_floating import block

from siku_core.errors import NonFiniteError, PluginError
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_plugins.floating.process import Floating


def test_a_heave_rate_above_max_speed_stops_the_run_and_is_not_written(tmp_path):
    """A vertical load of 1e28 N on a 10 m square (9.1e4 kg) drives its heave rate to
    ~F / (m + A33) dt ≈ 1e22 m/s in one step while it stays still in the horizontal: the
    horizontal guard alone passes it; the declared heave rate stops it."""
    out = tmp_path / "blow.h5"
    txt = block("loads = [[0, 1e28]]", dt=0.1, duration=2.0, output={"every": 0.5})
    sim = Simulation(scene_from_text(txt, "<block>"), out=out, progress=False)
    with pytest.raises(NonFiniteError, match=r"heave_rate of element 0 is .* m/s .*"
                                             r"above \[run\] max_speed = 100 m/s.* at step 1"):
        sim.run()
    with h5py.File(out, "r") as f:
        assert f["states/step"][:].tolist() == [0]
        assert np.all(np.abs(f["states/fields/heave_rate"][:]) <= 100.0)
    assert sim.step_index == 0 and sim.context.fields["heave_rate"][0] == 0.0


@pytest.mark.parametrize("name", ["heave", "heave_rate", "roll", "roll_rate", "pitch",
                                  "pitch_rate"])
def test_a_non_finite_degree_of_freedom_stops_the_run(name):
    sim = Simulation(scene_from_text(block(dt=0.1, duration=1.0), "<block>"), out=False,
                     progress=False)
    sim.step()
    sim.context.fields[name][0] = np.nan
    with pytest.raises(NonFiniteError, match=f"non-finite {name} of element 0"):
        sim.guard.check()
    assert np.isfinite(sim.context.fields[name]).all()  # back to the last good state


def test_floating_declares_what_it_integrates():
    owned = {f.name for f in Floating.owned_fields}
    assert set(Floating.integrates) == {"heave", "heave_rate", "roll", "roll_rate", "pitch",
                                        "pitch_rate"} <= owned
    assert Floating.integrates["heave_rate"] == "speed"


def test_a_declaration_of_a_field_not_owned_is_refused(monkeypatch):
    from siku_core.run.guard import integrated_fields
    sim = Simulation(scene_from_text(block(dt=0.1, duration=1.0), "<block>"), out=False,
                     progress=False)
    monkeypatch.setattr(Floating, "integrates", {"surge": "finite"})
    with pytest.raises(PluginError, match="integrates 'surge'.*owned_fields"):
        integrated_fields(sim)
