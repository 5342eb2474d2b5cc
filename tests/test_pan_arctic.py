"""The pan-Arctic example (``examples/pan_arctic/``) keeps working.

Its real mesh (about 400 000 cells) takes a minute and more than a gigabyte to build, so the
fast checks run the scene as shipped on a crop of its box: the Bering Strait at the scene's own
spacing, land and seed. The crop must mesh into a strait between two coasts, with cells as
dense as a maximal Poisson-disc set of the scene's spacing can be, and run a few steps at the
scene's step, which the crop's cells must allow.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from siku_core import Simulation
from siku_core.scene.scene_file import load_scene

SCENE = Path(__file__).resolve().parents[1] / "examples" / "pan_arctic" / "pan_arctic.toml"
CROP = {"elements.mesh.lon": "[-172.0, -166.0]", "elements.mesh.lat": "[65.0, 66.6]",
        "elements.mesh.cache": "false"}


def test_the_scene_as_shipped_covers_the_arctic_at_5_km():
    scene = load_scene(SCENE)
    mc = scene.cfg.elements.mesh
    assert (list(mc.lon), list(mc.lat)) == ([-180.0, 180.0], [65.0, 90.0])  # the whole cap
    assert mc.land == "gshhg"
    assert (SCENE.parent / "README.md").is_file()


@pytest.mark.slow
def test_the_whole_mesh_has_at_least_300_000_cells():
    """The real thing: about a minute and 1.5 GB on one core (not written to the cache)."""
    from siku_io.mesh.cache import mesh_for_scene

    scene = load_scene(SCENE, {"elements.mesh.cache": "false"})
    mesh, built = mesh_for_scene(scene)
    assert built and mesh.n >= 300_000
    counts = mesh.counts()
    assert counts["ice"] > 10 * counts["coast"]


@pytest.fixture(scope="module")
def crop():
    scene = load_scene(SCENE, CROP)
    return scene, Simulation(scene, out=False, progress=False)


def test_a_crop_of_it_meshes_the_bering_strait(crop):
    from siku_core.geometry.quat import latlon_of
    from siku_core.state import STATIC

    scene, sim = crop
    st = sim.state
    lat, lon = np.degrees(latlon_of(st.q))
    static = st.flags == STATIC
    # coast cells on both sides of the strait (Chukotka west of -169°, Alaska east of -168.3°)
    assert (static & (lon < -170.0)).any() and (static & (lon > -168.3)).any()
    assert (~static).sum() > 100
    # free cells between the packing and covering bounds of a maximal Poisson-disc set with
    # minimum distance s: mean area per seed in [√3/2 s², 3√3/2 s²]
    s = scene.cfg.elements.mesh.spacing
    free = ~static
    inner = free & (lat > 65.3) & (lat < 66.3) & (lon > -171.4) & (lon < -166.6)
    mean = st.area[inner].mean()
    assert math.sqrt(3) / 2 * s ** 2 <= mean <= 1.5 * math.sqrt(3) * s ** 2


def test_a_crop_of_it_runs_at_the_scenes_step(crop):
    scene, sim = crop
    assert sim.dt == scene.cfg.time.dt
    assert sim.dt <= scene.cfg.run.dt_safety * sim.critical_dt
    assert sim.contacts.n_joints > 0
    sim.run(steps=3)
    assert sim.step_index == 3
    for name in ("q", "V", "w"):
        assert np.isfinite(getattr(sim.state, name)).all()
