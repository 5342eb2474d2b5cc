"""Every example scene in ``examples/*.toml`` loads, builds and runs a few steps.

The examples are documentation: each starts with a comment block saying what it shows, and
must keep working as the code changes. Scenes of the example plugin
(``examples/siku_example_plugin/scenes``) need that plugin installed and are tested there.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from siku_core import Simulation
from siku_core.scene.scene_file import load_scene

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))
STEPS = 5


def test_the_examples_exist():
    names = {p.name for p in EXAMPLES}
    assert {"pack_pull.toml", "rheology_comparison.toml", "free_drift_cyclone.toml"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(path: Path):
    text = path.read_text(encoding="utf-8")
    assert text.lstrip().startswith("#"), f"{path.name}: start with a comment saying what it shows"
    scene = load_scene(path)
    sim = Simulation(scene, out=False, progress=False)
    assert sim.dt <= scene.cfg.run.dt_safety * sim.critical_dt
    sim.run(steps=STEPS)
    assert sim.step_index == STEPS
    st = sim.state
    for name in ("q", "V", "w", "F", "T"):
        assert np.isfinite(getattr(st, name)).all(), f"{path.name}: non-finite {name}"
    assert np.allclose(np.linalg.norm(st.q, axis=1), 1.0, atol=1e-12)
    if sim.contacts is not None and sim.contacts.law.uses_joints:
        assert sim.contacts.n_joints > 0, f"{path.name}: a joint law but no joints were found"
