"""Broad-phase plugins through a Simulation (docs/explanation/physics.md §4.1, §4.4).

* The three registered broad phases (brute force, the reference; sweep and prune; cell grid)
  give the same candidate pairs as an independent reference (great-circle angles by
  ``arctan2``) on jittered packs at mid-latitude, across the antimeridian and around the north
  pole, static and steady columns included.
* Candidate lists reused within a skin give exactly the forces of a rebuild every step.
* Static (and steady) elements never interact with each other.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.geometry.quat import centers, latlon_of
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import contact_scene, square_pack

R = 6_371_000.0
PHASES = ("brute_force", "sweep_and_prune", "cell_grid")
SKIN = 500.0  # [m]

POLE_CAP = {"vertices": [[-180.0 + 30.0 * k, 89.7] for k in range(12)]}

LAYOUTS = {
    # 2 km cells, a static west column and a steady east column
    "mid-latitude": {"packs": [square_pack(10.0, 45.0, 8, 6, 2000.0, jitter=0.3, gap=0.05,
                                           seed=1, left="static", right="steady",
                                           right_velocity=[0.2, 0.0])]},
    # lon 179 -> 181, written [179, -179]; cells ~11 km x 22 km
    "antimeridian": {"packs": [{"lon": [179.0, -179.0], "lat": [60.0, 61.0], "nx": 10, "ny": 5,
                                "jitter": 0.3, "gap": 0.02, "seed": 2, "left": "static"}]},
    # a ring of 12 x 3 cells from 88°N to 89.7°N and a 12-gon cap over the pole
    "north pole": {"packs": [{"lon": [-180.0, 180.0], "lat": [88.0, 89.7], "nx": 12, "ny": 3,
                              "jitter": 0.2, "seed": 3}],
                   "elements": [POLE_CAP]},
}


def simulation(layout: str, phase: str) -> Simulation:
    scene = contact_scene("collision", broad_phase=phase, skin=SKIN, dt=0.05, steps=10,
                          **LAYOUTS[layout])
    return Simulation(scene, out=False, progress=False)


def reference_pairs(sim) -> np.ndarray:
    """Pairs whose bounding circles, each grown by half the skin, meet: great-circle angle by
    ``arctan2`` (accurate for tiny angles), pairs of two non-free elements left out."""
    st = sim.state
    c = centers(st.q)
    rho = st.radius / R + 0.5 * SKIN / R
    cross = np.linalg.norm(np.cross(c[:, None, :], c[None, :, :]), axis=-1)
    ang = np.arctan2(cross, c @ c.T)
    fixed = st.flags != 0
    i, j = np.nonzero(np.triu(ang <= rho[:, None] + rho[None, :], k=1))
    keep = ~(fixed[i] & fixed[j])
    return np.stack([i[keep], j[keep]], axis=1)


@pytest.fixture(scope="module", params=list(LAYOUTS))
def layout_pairs(request):
    out = {}
    for phase in PHASES:
        sim = simulation(request.param, phase)
        sim.step()  # candidates come from the engine's own call of the broad phase
        out[phase] = (sim, sim.contacts.pairs.copy())
    return request.param, out


def test_layouts_span_the_hard_places(layout_pairs):
    layout, out = layout_pairs
    sim = out["brute_force"][0]
    lat, lon = np.degrees(latlon_of(sim.state.q))
    if layout == "antimeridian":
        assert (lon > 179.0).any() and (lon < -179.0).any()
    if layout == "north pole":
        assert lat.max() > 89.99  # the cap is centred on the pole
        assert np.ptp(lon) > 300
    assert len(out["brute_force"][1]) > sim.state.n  # a few neighbours each


def test_broad_phases_give_identical_candidates(layout_pairs):
    layout, out = layout_pairs
    ref = reference_pairs(out["brute_force"][0])
    for phase in PHASES:
        got = out[phase][1]
        assert got.dtype == np.int64 and got.shape[1] == 2
        assert np.array_equal(got, ref), f"{layout}, {phase}: {len(got)} pairs vs {len(ref)}"


def test_no_pair_of_two_fixed_elements(layout_pairs):
    _, out = layout_pairs
    sim, pairs = out["sweep_and_prune"]
    fixed = sim.state.flags[pairs] != 0
    assert not (fixed[:, 0] & fixed[:, 1]).any()


# ------------------------------------------------------------------ skin reuse

def fleet(skin: float) -> Simulation:
    """Two jittered 4 × 3 fleets of 2 km floes with 200 m of water between them, spinning and
    driven into each other at 2 m/s: contacts open and close within and between the fleets."""
    east = square_pack(20.0, 70.0, 4, 3, 2000.0, jitter=0.2, gap=0.1, seed=4, spin=2e-3,
                       velocity=[1.0, 0.2])
    west = square_pack(east["lon"][1] + 0.002, 70.0, 4, 3, 2000.0, jitter=0.2, gap=0.1, seed=5,
                       spin=-2e-3, velocity=[-1.0, -0.1])
    scene = contact_scene("collision", {"friction": 0.2}, packs=[east, west], skin=skin,
                          broad_phase="cell_grid", dt=0.2, steps=500)
    return Simulation(scene, out=False, progress=False)


def record(sim, steps):
    F, T, overlaps = [], [], 0
    for _ in range(steps):
        sim.step()
        F.append(sim.state.F.copy())
        T.append(sim.state.T.copy())
        overlaps += sim.contacts.n_overlap
    return np.array(F), np.array(T), overlaps


def test_skin_reuse_gives_the_forces_of_rebuilding_every_step():
    steps = 400
    every, reuse = fleet(0.0), fleet(30.0)
    F0, T0, n0 = record(every, steps)
    F1, T1, n1 = record(reuse, steps)
    assert n0 > 50 and n0 == n1  # the fleets collide, pair contacts come and go
    assert every.contacts.rebuilds == steps  # skin 0: a new list every step
    assert 1 < reuse.contacts.rebuilds < steps / 5  # reused for many steps
    # extra candidates contribute nothing and the overlapping pairs come in the same
    # (lexicographic) order, so the sums agree bit for bit
    assert np.array_equal(F0, F1) and np.array_equal(T0, T1)
    assert np.array_equal(every.state.q, reuse.state.q)


# ------------------------------------------------------------------ static pairs

@pytest.mark.parametrize("phase", PHASES)
def test_static_elements_never_interact(phase):
    """Two static floes overlapping by 300 m, a steady one overlapping the second by 300 m,
    and a free one overlapping the first: only the free one's contact exists."""
    dlon = np.degrees(1700.0 / (R * np.cos(np.radians(50.0))))
    elements = [
        {"center": (-dlon, 50.0), "flag": "free", "velocity": (0.1, 0.0)},
        {"center": (0.0, 50.0), "flag": "static"},
        {"center": (dlon, 50.0), "flag": "static"},
        {"center": (2 * dlon, 50.0), "flag": "steady", "velocity": (-0.1, 0.0)},
    ]
    sim = Simulation(contact_scene("collision", elements=elements, broad_phase=phase, dt=0.05,
                                   steps=10), out=False, progress=False)
    sim.step()
    assert sim.contacts.pairs.tolist() == [[0, 1]]
    assert sim.contacts.n_overlap == 1
    F, T = sim.state.F, sim.state.T
    assert np.any(F[0]) and np.any(F[1])
    assert not np.any(F[2:]) and not np.any(T[2:])
