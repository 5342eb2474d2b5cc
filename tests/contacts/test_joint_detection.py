"""Frozen joints: automatic detection of shared edges, explicit pair lists, rejected links."""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation

BASE = """
[time]
duration = 60
dt = 0.1
[elements]
[[elements.pack]]
lon = [0.0, 0.3]
lat = [0.0, 0.3]
nx = 3
ny = 3
{pack}
[contact]
law = "distributed_spring"
{contact}
"""


def build(pack: str = "", contact: str = "") -> Simulation:
    return Simulation(scene_from_text(BASE.format(pack=pack, contact=contact)), out=False,
                      progress=False)


def pairs(sim) -> set[tuple[int, int]]:
    return set(zip(sim.contacts.ji.tolist(), sim.contacts.jj.tolist()))


def grid_neighbours(nx: int, ny: int) -> set[tuple[int, int]]:
    """Edge-sharing pairs of a pack ordered column by column (index i * ny + j)."""
    out = set()
    for i in range(nx):
        for j in range(ny):
            k = i * ny + j
            if j + 1 < ny:
                out.add((k, k + 1))
            if i + 1 < nx:
                out.add((k, k + ny))
    return out


def test_auto_detection_finds_exactly_the_edge_sharing_neighbours():
    sim = build()
    assert pairs(sim) == grid_neighbours(3, 3)  # 12 joints; the 8 corner-touching pairs: none
    c = sim.contacts
    # joint length = the shared edge (0.1° ≈ 11.1 km), rest length = centre distance
    np.testing.assert_allclose(c.width, 11_119.5, rtol=2e-3)
    np.testing.assert_allclose(c.L0, 11_119.5, rtol=2e-3)


def test_jittered_pack_keeps_its_shared_edges():
    sim = build(pack='jitter = 0.2\nseed = 7')
    assert pairs(sim) == grid_neighbours(3, 3)


def test_static_elements_get_no_joints_among_themselves():
    sim = build(pack='left = "static"')
    static = {0, 1, 2}
    assert all(not (a in static and b in static) for a, b in pairs(sim))
    assert pairs(sim) == {p for p in grid_neighbours(3, 3) if not set(p) <= static}


def test_explicit_pairs_accept_neighbours_and_report_rejected_links():
    with pytest.warns(UserWarning, match=r"1 listed pair\(s\) share no edge within tolerance "
                      r"0\.01 and were not jointed: \[0, 4\]"):
        sim = build(contact='joints = "pairs"\npairs = [[0, 1], [4, 0], [3, 4]]')
    assert pairs(sim) == {(0, 1), (3, 4)}
    assert sim.contacts.rejected == [(0, 4)]


def test_tolerance_tells_explicit_lists_from_automatic_detection():
    """A vertex moved by 5 % of the edge: within the automatic 10 %, outside the listed 1 %.
    (Polygons come before packs: the two polygons are elements 0 and 1.)"""
    moved = """
[[elements.polygon]]
vertices = [[0.4, 0.0], [0.5, 0.0], [0.5, 0.1], [0.4, 0.1]]
[[elements.polygon]]
vertices = [[0.5, 0.005], [0.6, 0.0], [0.6, 0.1], [0.5, 0.1]]
"""
    text = BASE.format(pack="", contact="").replace("[contact]", moved + "[contact]")
    sim = Simulation(scene_from_text(text), out=False, progress=False)
    assert (0, 1) in pairs(sim)
    text_pairs = text.replace('law = "distributed_spring"',
                              'law = "distributed_spring"\njoints = "pairs"\npairs = [[0, 1]]')
    with pytest.warns(UserWarning, match=r"\[0, 1\]"):
        sim = Simulation(scene_from_text(text_pairs), out=False, progress=False)
    assert sim.contacts.n_joints == 0


def test_pairs_naming_missing_elements_are_an_error():
    from siku_core.errors import SceneError

    with pytest.raises(SceneError, match=r"pair \[0, 99\] does not name two distinct elements"):
        build(contact='joints = "pairs"\npairs = [[0, 99]]')


def test_collision_law_has_no_joints():
    text = BASE.format(pack="", contact="").replace('"distributed_spring"', '"collision"')
    sim = Simulation(scene_from_text(text), out=False, progress=False)
    assert sim.contacts.n_joints == 0
