"""The smallest free cells of a mesh: what they cost in step (``siku_core.scene.cells``, the mesh
build's report, the run summary) and ``[elements.mesh] min_area_share`` (``siku_io.mesh.relax``).

Tolerances and why:

* the free cells' union is unchanged by the relaxation (no seed bordering a cell outside the
  mesh moves), so the sum of the cells' spherical areas is the same up to round-off: ``1e-12``
  relative (a sum of a few hundred areas, each exact to ~1e-15);
* the shares computed from the elements' areas (each polygon projected on its tangent plane)
  differ from the spherical areas by the projection, ~``(L / R)^2`` ~ 1e-5 for 30 km cells:
  ``1e-4`` relative taken;
* the vertices of the mesh's edge are those of the unrelaxed mesh, recomputed by qhull from
  other point sets: within 1e-6 m (round-off of unit vectors times the radius, ~1e-9 m);
* overlaps of relaxed cells: round-off, below ``1e-9`` of the smaller cell's area (as for the
  meshes of tests/test_mesh.py).
"""
from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from scipy.spatial import cKDTree

from siku_core.scene.cells import small_cell_report
from siku_core.run.elements import build_elements
from siku_core.geometry.sphere import lonlat_to_xyz
from siku_core.errors import SceneError
from siku_core.scene.scene_file import load_scene, scene_from_text
from siku_core.state import FREE, STATIC
from siku_core.run.summary import RunSummary, format_summary
from siku_io.mesh.build import build_mesh
from siku_io.mesh.cache import load_or_build, mesh_for_scene
from siku_io.mesh.land import LandGrid
from siku_io.mesh.mesh_file import COAST, ICE, LANDFAST
from siku_io.mesh.params import MeshParams

from test_mesh import R, WINDOW, cell_samples, elements_of, max_overlap_share, wavy_land

BOX = {"lon": [-10.0, 10.0], "lat": [70.0, 74.0], "land": "none", "seed": 1}


def graded(lon, lat):
    """A spacing of 20 km at the centre of BOX (0 E, 72 N) rising to 30 km 150 km from it,
    and beyond: the small cells lie inside the mesh, away from its edge [m]."""
    d = np.hypot(np.asarray(lon) * 111.2 * math.cos(math.radians(72.0)),
                 (np.asarray(lat) - 72.0) * 111.2)
    return 20e3 + 10e3 * np.clip(d / 150.0, 0.0, 1.0)


def shares(mesh):
    """Every free cell's area over the median free-cell area, from the spherical areas."""
    a = mesh.spherical_areas()[mesh.kind == ICE]
    return a / np.median(a)


def cell_set(mesh, kinds):
    """The cells of the given kinds as byte strings of their vertices."""
    return {mesh.lonlat[a:b].tobytes() for a, b, k in
            zip(mesh.offsets[:-1], mesh.offsets[1:], mesh.kind) if k in kinds}


def outside_seams(mesh):
    """The cells of the mesh's edge: those with an edge no other cell shares."""
    nb = mesh.neighbours()
    deg = np.bincount(nb.ravel(), minlength=mesh.n)
    return deg < np.diff(mesh.offsets)


def edge_vertices(mesh):
    """The vertices of the mesh's edge (ends of edges of one cell only), ``(k, 3)``."""
    nxt = np.arange(1, len(mesh.vertex_id) + 1)
    nxt[mesh.offsets[1:] - 1] = mesh.offsets[:-1]
    a, b = mesh.vertex_id, mesh.vertex_id[nxt]
    key = np.sort(np.stack([a, b], axis=1), axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = count[inv.ravel()] == 1
    ids = np.unique(np.concatenate([a[once], b[once]]))
    first = np.unique(mesh.vertex_id, return_index=True)[1]
    return lonlat_to_xyz(*mesh.lonlat[first[ids]].T)


@pytest.fixture(scope="module")
def graded_pair():
    kw = {**BOX, "spacing": 30e3, "spacing_fn": graded, "spacing_bounds": (20e3, 30e3)}
    return build_mesh(**kw), build_mesh(**kw, min_area_share=0.6)


@pytest.fixture(scope="module")
def coast_pair():
    land = LandGrid.from_function(wavy_land, WINDOW, 1000.0, R, name="wavy")
    p = {"lon": [0.0, 12.0], "lat": [60.0, 64.0], "spacing": 30e3, "coast_spacing": 12e3,
         "coast_distance": 80e3, "seed": 5, "land": "none",
         "landfast": [[[2.0, 61.3], [5.0, 61.3], [5.0, 62.0], [2.0, 62.0]]]}
    base = build_mesh(MeshParams(**p), land_grid=land)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        relaxed = build_mesh(MeshParams(**p, min_area_share=0.6), land_grid=land)
    return base, relaxed, land, [str(w.message) for w in caught]


# ---------------------------------------------------------------------------- the report
def test_small_cell_report_is_the_share_of_the_median_free_area():
    areas = np.array([4.0, 1.0, 2.0, 9.0, 0.5, 3.0, 5.0])
    flags = np.array([FREE, FREE, FREE, FREE, STATIC, FREE, FREE])  # the 0.5 is static
    r = small_cell_report(areas, flags)
    free = np.sort([4.0, 1.0, 2.0, 9.0, 3.0, 5.0])
    med = 0.5 * (free[2] + free[3])
    assert r.n_free == 6 and r.median == med
    assert r.smallest == pytest.approx(1.0 / med, rel=1e-15)
    assert r.step_factor == pytest.approx(math.sqrt(1.0 / 3.5), rel=1e-15)
    p5 = free[0] + 0.05 * (len(free) - 1) * (free[1] - free[0])  # linear interpolation
    assert r.p5 == pytest.approx(p5 / med, rel=1e-12)
    assert r.line(p5=False) == "smallest free cell 0.29 x median area (step x0.53 of the " \
                               "median cell's)"
    assert small_cell_report(areas, np.full(7, STATIC)) is None


def test_the_run_summary_shows_the_smallest_free_cell_and_its_step():
    row = {"title": "", "steps": 1, "n_steps": 1, "dt": 1.0, "time": 1.0}
    areas = np.array([1.0, 4.0, 4.0, 4.0, 0.1])
    flags = np.array([FREE, FREE, FREE, FREE, STATIC])
    text = format_summary(RunSummary(flags=flags, areas=areas, **row))
    line = re.search(r"^  cells\s+(.*)$", text, re.M).group(1)
    assert line == (f"smallest free cell {1.0 / 4.0:.2f} x median area (step "
                    f"x{math.sqrt(1.0 / 4.0):.2f} of the median cell's)")
    assert "cells" not in format_summary(RunSummary(flags=flags, **row))  # areas not known


def test_the_mesh_build_and_the_cache_read_say_what_the_smallest_cells_cost(tmp_path, capsys):
    text = ('[time]\nduration = "1h"\ndt = 60\n[elements.mesh]\nlon = [-10.0, 10.0]\n'
            'lat = [70.0, 74.0]\nspacing = 40000.0\nland = "none"\n')
    path = tmp_path / "sea.toml"
    path.write_text(text, encoding="utf-8")
    st = build_elements(load_scene(path))
    first = capsys.readouterr().err
    mesh, built = mesh_for_scene(load_scene(path))
    again = capsys.readouterr().err
    assert "mesh built" in first and not built and "read from" in again
    s = shares(mesh)
    want = (f"smallest free cell {s.min():.2f} x median area (step x{math.sqrt(s.min()):.2f} "
            f"of the median cell's; 5th percentile {np.percentile(s, 5):.2f} x median)")
    assert want in first and want in again
    # the elements' own (tangent-plane) areas give the same shares
    r = small_cell_report(st.area, st.flags)
    assert r.smallest == pytest.approx(s.min(), rel=1e-4)
    assert r.p5 == pytest.approx(np.percentile(s, 5), rel=1e-4)


# ---------------------------------------------------------------------------- the relaxation
def test_min_area_share_keeps_every_free_cell_above_the_share(graded_pair):
    base, relaxed = graded_pair
    x = relaxed.stats["relaxed"]
    assert shares(base).min() < 0.6  # there was work to do
    assert x["reached"] and x["moved"] > 0 and x["rounds"] <= 24
    assert shares(relaxed).min() >= 0.6
    assert x["before"] == pytest.approx(shares(base).min(), rel=1e-12)
    assert x["after"] == pytest.approx(shares(relaxed).min(), rel=1e-12)
    # the same from the elements' areas
    _, _, _, area = elements_of(relaxed)
    assert small_cell_report(area, np.full(relaxed.n, FREE)).smallest >= 0.6 * (1 - 1e-4)


def test_relaxed_cells_partition_the_same_water_without_overlaps(graded_pair, coast_pair):
    for base, relaxed in (graded_pair, coast_pair[:2]):
        a0, a1 = base.spherical_areas().sum(), relaxed.spherical_areas().sum()
        assert a1 == pytest.approx(a0, rel=1e-12)
        assert relaxed.n == base.n - relaxed.stats["relaxed"]["merged"]
        q, off, verts, area = elements_of(relaxed)
        worst, n = max_overlap_share(q, off, verts, area)
        assert n > 2 * relaxed.n and worst < 1e-9, worst
        # the edge of the mesh is where it was: the same vertices, to round-off
        e0, e1 = edge_vertices(base), edge_vertices(relaxed)
        d, _ = cKDTree(e0).query(e1)
        assert len(e0) == len(e1) and d.max() * R < 1e-6, d.max() * R  # m


def test_static_cells_keep_their_seeds_kinds_and_the_coast_rule(coast_pair):
    base, relaxed, land, caught = coast_pair
    assert relaxed.stats["relaxed"]["moved"] > 0
    # static seeds never move, and static cells stay static of the same kind
    for k in (COAST, LANDFAST):
        s0 = {tuple(s) for s in base.seeds[base.kind == k]}
        assert s0 == {tuple(s) for s in relaxed.seeds[relaxed.kind == k]}
    # no ice cell touches land, every coast cell does, every cell has water (as in
    # tests/test_mesh.py: samples every 250 m along and inside the cells)
    lon, lat, owner = cell_samples(relaxed, range(relaxed.n), 250.0)
    on = land.is_land(lon, lat)
    touching = np.zeros(relaxed.n, dtype=bool)
    touching[owner[on]] = True
    assert np.all(relaxed.kind[touching] == COAST)
    assert touching[relaxed.kind == COAST].mean() > 0.95  # the rest: at a pixel corner
    wet = np.zeros(relaxed.n, dtype=bool)
    wet[owner[~on]] = True
    assert wet.all()


def test_a_share_out_of_reach_warns_once_with_what_was_done(coast_pair):
    base, relaxed, _, caught = coast_pair
    x = relaxed.stats["relaxed"]
    s = shares(relaxed)
    below = int(np.sum(s < 0.6))
    assert not x["reached"] and x["below"] == below > 0 and x["rounds"] <= 24
    assert len(caught) == 1
    assert caught[0].startswith("min_area_share = 0.6 not reached")
    assert f"{below} free cells below it" in caught[0]
    assert f"the smallest {s.min():.2f} x the median area" in caught[0]
    assert f"(was {shares(base).min():.2f};" in caught[0]
    # the cells left below the share lie at the mesh's edge, where seeds do not move
    assert x["at_edge"] == below
    assert np.all(outside_seams(relaxed)[relaxed.kind == ICE][s < 0.6])


def test_off_by_default_bit_identical_and_deterministic(graded_pair):
    kw = {**BOX, "spacing": 30e3}
    off = build_mesh(**kw)
    idle = build_mesh(**kw, min_area_share=0.05)  # every cell already above: nothing moves
    assert idle.stats["relaxed"]["moved"] == 0 and idle.stats["relaxed"]["rounds"] == 0
    for name in ("lonlat", "offsets", "vertex_id", "seeds", "kind"):
        assert np.array_equal(getattr(off, name), getattr(idle, name)), name
    assert off.stats["relaxed"] is None
    p = MeshParams(**kw)
    assert "min_area_share" not in p.canonical()  # meshes built before keep their hash
    assert MeshParams(**kw, min_area_share=0.6).digest() != p.digest()
    again = build_mesh(**BOX, spacing=30e3, spacing_fn=graded, spacing_bounds=(20e3, 30e3),
                       min_area_share=0.6)
    assert np.array_equal(again.lonlat, graded_pair[1].lonlat)
    assert np.array_equal(again.offsets, graded_pair[1].offsets)


def test_the_cache_follows_min_area_share(tmp_path):
    path = tmp_path / "m.npz"
    p = MeshParams(**BOX, spacing=40e3)
    m0, built0 = load_or_build(p, path)
    p.min_area_share = 0.8
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # reached or not, the cache must be rebuilt
        m1, built1 = load_or_build(p, path)
    m2, built2 = load_or_build(p, path)
    assert built0 and built1 and not built2
    assert m1.digest != m0.digest and m2.digest == m1.digest
    assert m2.stats["relaxed"] == m1.stats["relaxed"]


@pytest.mark.parametrize("value", ["0.95", "-0.1"])
def test_min_area_share_out_of_range_is_refused(value):
    base = ('[time]\nduration = "1h"\ndt = 60\n[elements.mesh]\nlon = [0, 1]\nlat = [70, 71]\n'
            f'spacing = 10000.0\nland = "none"\nmin_area_share = {value}\n')
    with pytest.raises(SceneError, match="min_area_share"):
        scene_from_text(base)
    with pytest.raises(ValueError, match="min_area_share"):
        MeshParams(lon=[0, 1], lat=[70, 71], spacing=10e3, min_area_share=float(value)).check()
