"""Voronoi meshes (docs/explanation/physics.md §6; ``siku_io.mesh``, ``[elements.mesh]``).

Tolerances and why:

* whole-sphere tessellation: the spherical cell areas sum to ``4 pi R^2`` within ``1e-9``
  relative (the Voronoi cells partition the sphere; only round-off remains, measured ~1e-15);
* polar cap (a lat/lon box with the full circle of longitude): cells cut by the cap edge are
  dropped, so the kept area ``A`` is at most the cap area and at least the area of the cap
  shrunk by ``2 rho`` (``rho`` the largest seed-to-vertex distance: a point left uncovered
  belongs to a dropped cell, which reaches outside the cap). Measured: the dropped strip is
  about ``0.7 × perimeter × spacing``; asserted below ``1.2``;
* spacing: by construction no seed is nearer another than the larger of their two spacings
  (asserted to 1e-9). The set is maximal (holes are filled at Voronoi vertices until none is
  as wide as the local spacing), so every Voronoi vertex lies within ``r`` of its seeds and every
  nearest-neighbour distance is below ``2 r``. For saturated random sequential packing the mean
  nearest-neighbour distance is about ``1.06 r`` (measured 1.06 for 4k and 16k points); the
  test takes ``[1.0, 1.3]``, and ``[1.0, 1.6]`` of the local spacing for a graded mesh;
* overlap: neighbouring cells share an edge exactly, so the clipped overlap of any two cells is
  round-off: below ``1e-9`` of the smaller cell's area.
"""
from __future__ import annotations

import importlib.util
import json
import math
import time

import numpy as np
import pytest
from scipy.spatial import cKDTree

from siku_core.contact.contact_frames import find_shared_edges
from siku_core.run.elements import build_elements
from siku_core.errors import SceneError
from siku_core.geometry.clip import overlap, project_partner
from siku_core.geometry.polygon import element_from_lonlat
from siku_core.geometry.quat import centers
from siku_core.geometry.sphere import lonlat_to_xyz, xyz_to_lonlat
from siku_core.scene.scene_file import load_scene, scene_from_text
from siku_core.state import FREE, STATIC
from siku_io.mesh.build import build_mesh
from siku_io.mesh.cache import load_or_build, mesh_for_scene
from siku_io.mesh.contours import points_in_polygon, read_contour
from siku_io.mesh.land import LandGrid, glm_land
from siku_io.mesh.mesh_file import COAST, ICE, LANDFAST, Mesh
from siku_io.mesh.params import MeshParams
from siku_io.mesh.region import Region
from siku_io.mesh.seeding import SpacingField
from siku_io.mesh.sphere import unit_rows, arc_of
from siku_io.mesh.voronoi import next_index

R = 6_371_000.0


# ---------------------------------------------------------------------------- helpers
def seed_xyz(mesh):
    return lonlat_to_xyz(mesh.seeds[:, 0], mesh.seeds[:, 1])


def nn_over_spacing(mesh, spacing_of):
    p = seed_xyz(mesh)
    d, _ = cKDTree(p).query(p, 2)
    return arc_of(d[:, 1], R) / spacing_of(p)


def circumradius(mesh):
    """Largest distance from each seed to its cell's vertices [m]."""
    cell = np.repeat(np.arange(mesh.n), np.diff(mesh.offsets))
    d = arc_of(np.linalg.norm(mesh.xyz() - seed_xyz(mesh)[cell], axis=1), R)
    out = np.zeros(mesh.n)
    np.maximum.at(out, cell, d)
    return out


def cell_samples(mesh, cells, step_m):
    """Vertices, points every ``step_m`` along the edges, and interior points of cells:
    ``(lon, lat, cell)``."""
    lon, lat, owner = [], [], []
    for i in cells:
        v = lonlat_to_xyz(*mesh.cell(i).T)
        s = seed_xyz(mesh)[i]
        b = np.roll(v, -1, axis=0)
        pts = [v]
        for a, c in zip(v, b):
            m = max(2, math.ceil(arc_of(np.linalg.norm(c - a), R) / step_m) + 1)
            t = np.linspace(0, 1, m)[:, None]
            pts.append(a * (1 - t) + c * t)
            for f in (0.25, 0.5, 0.75):  # interior: points between the seed and the edge
                pts.append(s * (1 - f) + (a * (1 - t) + c * t) * f)
        p = unit_rows(np.vstack(pts))
        lo, la = xyz_to_lonlat(p)
        lon.append(lo)
        lat.append(la)
        owner.append(np.full(len(lo), i))
    return np.concatenate(lon), np.concatenate(lat), np.concatenate(owner)


def elements_of(mesh):
    out = [element_from_lonlat(mesh.cell(i), R, f"cell {i}") for i in range(mesh.n)]
    q = np.array([o[0] for o in out])
    verts = [o[1] for o in out]
    area = np.array([o[2] for o in out])
    off = np.zeros(mesh.n + 1, dtype=np.int64)
    off[1:] = np.cumsum([len(v) for v in verts])
    return q, off, np.concatenate(verts), area


def max_overlap_share(q, off, verts, area):
    """Largest overlap area of any two elements whose bounding circles meet, over the smaller
    element's area (every pair, not only neighbours)."""
    c = centers(q)
    rad = np.array([np.hypot(*verts[off[i]:off[i + 1]].T).max() for i in range(len(q))]) / R
    pairs = cKDTree(c).query_pairs(2 * rad.max(), output_type="ndarray")
    worst = 0.0
    n_checked = 0
    for i, j in pairs:
        if np.linalg.norm(c[i] - c[j]) > rad[i] + rad[j]:
            continue
        vj = verts[off[j]:off[j + 1]]
        pj = project_partner(q[i], q[j], vj, R, np.empty_like(vj))
        a = overlap(verts[off[i]:off[i + 1]], pj)[0]
        worst = max(worst, a / min(area[i], area[j]))
        n_checked += 1
    return worst, n_checked


# ---------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def sphere():
    return build_mesh(lon=[-180, 180], lat=[-90, 90], spacing=300e3, land="none", seed=2)


# synthetic land: a wavy southern coast and a round island, rasterised once
WINDOW = Region.box([-4.0, 16.0], [57.0, 67.0])


def wavy_land(lon, lat):
    coast = lat < 60.9 + 0.5 * np.sin(np.radians(lon) * 40.0)
    d = np.hypot((lon - 6.0) * math.cos(math.radians(62.6)), lat - 62.6)
    return coast | (d < 0.25)


@pytest.fixture(scope="module")
def synthetic():
    land = LandGrid.from_function(wavy_land, WINDOW, 1000.0, R, name="wavy")
    params = MeshParams(
        lon=[0.0, 12.0], lat=[60.0, 64.0], spacing=30e3, coast_spacing=12e3,
        coast_distance=80e3, seed=5, land="none",
        landfast=[[[2.0, 61.3], [5.0, 61.3], [5.0, 62.0], [2.0, 62.0]]],
    )
    mesh = build_mesh(params, land_grid=land)
    field = SpacingField(
        coarse=30e3, fine=12e3, distance=80e3, R=R,
        coast_xyz=lonlat_to_xyz(*land.pixel_centres(land.coast_pixels()[0])))
    return mesh, land, field


BEAUFORT = """
title = "Beaufort coast mesh"
[time]
duration = "1h"
dt = 1

[elements]
thickness = 1.5

[elements.mesh]
lon = [-160.0, -140.0]
lat = [69.5, 73.5]
spacing = 20000.0
coast_spacing = 10000.0
coast_distance = 100000.0
seed = 3
landfast = [[-157.0, 71.0], [-152.0, 70.6], [-152.0, 71.3], [-156.0, 71.6]]
mesh_file = "beaufort.mesh.npz"

[contact]
law = "distributed_spring"
joints = "auto"
"""


@pytest.fixture(scope="module")
def beaufort(tmp_path_factory):
    if importlib.util.find_spec("global_land_mask") is None:  # not imported: 0.9 GB on import
        pytest.skip("needs the package global-land-mask")
    path = tmp_path_factory.mktemp("beaufort") / "beaufort.toml"
    path.write_text(BEAUFORT, encoding="utf-8")
    from siku_core.run.simulation import Simulation

    t0 = time.perf_counter()
    sim = Simulation(load_scene(path), out=False, progress=False)
    return sim, path, time.perf_counter() - t0


# ---------------------------------------------------------------------------- region
def test_region_box_across_the_antimeridian_and_full_circle():
    r = Region.box([170.0, -170.0], [60.0, 70.0])
    assert r.width == pytest.approx(20.0)
    assert r.contains([175.0, -175.0, 180.0, -180.0], [65.0] * 4).all()
    assert not r.contains([0.0, 169.0, -169.0, 175.0], [65.0, 65.0, 65.0, 71.0]).any()
    assert Region.box([-180, 180], [60, 90]).full_lon
    with pytest.raises(ValueError, match="south < north"):
        Region.box([0, 1], [70, 60])


@pytest.mark.parametrize("lon", [[-1500.0, -149.5], [-180.0, 180.5], [0.0, math.inf],
                                 [math.nan, 10.0]])
def test_a_box_wider_than_the_full_circle_is_refused(lon):
    # [-1500, -149.5] spans 1350.5 degrees: taken before as the full circle without a word
    with pytest.raises(ValueError, match=r"east - west <= 360"):
        Region.box(lon, [72.0, 72.2])
    assert Region.box([-180.0, 180.0], [72.0, 72.2]).full_lon  # the full circle itself holds


def test_mesh_across_the_antimeridian_builds_elements():
    mesh = build_mesh(lon=[175.0, -175.0], lat=[70.0, 72.0], spacing=15e3, land="none", seed=1)
    assert mesh.n > 50
    lon = mesh.seeds[:, 0]
    assert (lon > 170).any() and (lon < -170).any()
    assert Region.box([175.0, -175.0], [70.0, 72.0]).contains(*mesh.lonlat.T).all()
    area = elements_of(mesh)[3]
    assert np.all(area > 0)
    box = Region.box([175.0, -175.0], [70.0, 72.0]).area(R)
    assert 0.8 * box < mesh.spherical_areas().sum() <= box


# ---------------------------------------------------------------------------- tessellation
def test_whole_sphere_cells_cover_the_sphere(sphere):
    assert sphere.n == sphere.stats["points"] and sphere.stats["guards"] == 0
    total = sphere.spherical_areas().sum()
    assert abs(total / (4 * math.pi * R**2) - 1.0) < 1e-9
    # a closed tessellation: every edge belongs to exactly two cells
    nxt = next_index(sphere.offsets)
    e = np.sort(np.stack([sphere.vertex_id, sphere.vertex_id[nxt]], axis=1), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert np.all(counts == 2)
    assert np.all(sphere.spherical_areas() > 0)


def test_spacing_is_a_maximal_poisson_disc(sphere):
    nn = nn_over_spacing(sphere, lambda p: 300e3)
    assert nn.min() >= 1.0 - 1e-9
    assert nn.max() < 2.0
    assert 1.0 <= nn.mean() <= 1.3, nn.mean()
    # maximal: no empty circle as wide as the spacing (every Voronoi vertex within r of a seed)
    assert circumradius(sphere).max() <= 300e3 * (1 + 1e-9)
    # mean cell area ~1.43 r^2 for a saturated packing
    assert 1.2 < sphere.spherical_areas().mean() / 300e3**2 < 1.7


def test_spacing_from_a_function_is_respected():
    """A finer spot around a site of interest (``spacing_fn``), no land."""

    def fn(lon, lat):
        d = np.hypot((np.asarray(lon) - 0.0) * math.cos(math.radians(72)), np.asarray(lat) - 72)
        return 10e3 + 20e3 * np.clip(d / 1.5, 0.0, 1.0)

    mesh = build_mesh(lon=[-8.0, 8.0], lat=[70.0, 74.0], spacing=30e3, land="none", seed=3,
                        spacing_fn=fn, spacing_bounds=(10e3, 30e3))
    assert mesh.digest.startswith("custom-")
    nn = nn_over_spacing(mesh, lambda p: fn(*xyz_to_lonlat(p)))
    assert nn.min() >= 1.0 - 1e-9 and 1.0 <= nn.mean() <= 1.6
    a = mesh.spherical_areas()
    near = np.hypot(mesh.seeds[:, 0] * math.cos(math.radians(72)), mesh.seeds[:, 1] - 72) < 0.3
    assert a[near].mean() < 0.3 * a.max()


def test_polar_cap_cells_cover_the_cap_up_to_the_dropped_edge_cells():
    sp = 150e3
    mesh = build_mesh(lon=[-180, 180], lat=[60, 90], spacing=sp, land="none", seed=4)
    a = mesh.spherical_areas().sum()
    lat0 = math.radians(60.0)
    cap = 2 * math.pi * R**2 * (1 - math.sin(lat0))
    rho = circumradius(mesh).max()
    shrunk = 2 * math.pi * R**2 * (1 - math.sin(lat0 + 2 * rho / R))
    assert shrunk <= a <= cap * (1 + 1e-12)
    strip = (cap - a) / (2 * math.pi * R * math.cos(lat0) * sp)
    assert 0.2 < strip < 1.2, strip
    assert (mesh.lonlat[:, 1] >= 60.0).all()


def test_neighbours_share_edges_exactly_and_never_overlap(synthetic):
    mesh, _, _ = synthetic
    q, off, verts, area = elements_of(mesh)
    worst, n = max_overlap_share(q, off, verts, area)
    assert n > 2 * mesh.n
    assert worst < 1e-9, worst
    nb = mesh.neighbours()
    found, ends_i, ends_j = find_shared_edges(q, off, verts, nb, 1e-6, R)
    assert found.all()
    # the shared edge has the same length seen from both cells, up to the difference of the two
    # tangent planes (gnomonic scale differs by ~(distance / R)^2 ~ 1e-5 at 20 km)
    wi = np.hypot(*(ends_i[:, 1] - ends_i[:, 0]).T)
    wj = np.hypot(*(ends_j[:, 1] - ends_j[:, 0]).T)
    assert np.allclose(wi, wj, rtol=1e-4)


def test_graded_spacing_follows_the_coast(synthetic):
    mesh, _, field = synthetic
    nn = nn_over_spacing(mesh, field)
    assert nn.min() >= 1.0 - 1e-9
    assert 1.0 <= nn.mean() <= 1.6, nn.mean()
    d = field.coast_distance(seed_xyz(mesh))
    near, far = d < 20e3, d > 80e3
    assert near.sum() > 20 and far.sum() > 20
    a = mesh.spherical_areas()
    assert a[near].mean() < 0.5 * a[far].mean()  # spacing 12-15 km vs 30 km


# ---------------------------------------------------------------------------- land
def test_no_ice_cell_on_or_touching_land(synthetic):
    mesh, land, _ = synthetic
    c = mesh.counts()
    assert c["ice"] > 50 and c["coast"] > 20 and c["landfast"] > 3 and mesh.stats["removed_land"]
    ice = np.flatnonzero(mesh.kind == ICE)
    assert not land.is_land(*mesh.seeds[ice].T).any()
    lon, lat, owner = cell_samples(mesh, ice, 250.0)
    hit = land.is_land(lon, lat)
    assert not hit.any(), f"ice cells touching land: {np.unique(owner[hit])}"


def test_cells_touching_land_are_static_coast_and_coast_is_sealed(synthetic):
    mesh, land, _ = synthetic
    lon, lat, owner = cell_samples(mesh, range(mesh.n), 250.0)
    touching = np.zeros(mesh.n, dtype=bool)
    touching[owner[land.is_land(lon, lat)]] = True
    assert np.all(mesh.kind[touching] == COAST)
    coast = mesh.kind == COAST
    assert touching[coast].mean() > 0.95  # the rest touch land only at a pixel corner
    # land_removal = "covered": every kept cell has water
    has_water = np.zeros(mesh.n, dtype=bool)
    has_water[owner[~land.is_land(lon, lat)]] = True
    assert has_water.all()
    # sealed: away from the region edge, every edge of an ice cell is shared with a kept cell
    nb = mesh.neighbours()
    degree = np.bincount(nb.ravel(), minlength=mesh.n)
    sides = np.diff(mesh.offsets)
    # a neighbour's vertices lie within twice its circumradius (<= 30 km, the set is maximal) of
    # the shared edge: cells with every vertex 60 km inside the region have all neighbours kept
    lo, la = mesh.lonlat.T
    edge_km = np.minimum.reduce([(la - 60.0) * 111.2, (64.0 - la) * 111.2,
                                 lo * 111.2 * np.cos(np.radians(la)),
                                 (12.0 - lo) * 111.2 * np.cos(np.radians(la))])
    interior = np.minimum.reduceat(edge_km, mesh.offsets[:-1]) > 61.0
    ice = (mesh.kind == ICE) & interior
    assert ice.sum() > 20
    assert np.all(degree[ice] == sides[ice])


def test_landfast_cells_are_static(synthetic):
    mesh, _, _ = synthetic
    poly = mesh.params["params"]["landfast"][0]
    inside = points_in_polygon(*mesh.seeds.T, poly)
    assert np.all(mesh.kind[inside] != ICE)
    assert np.all(inside[mesh.kind == LANDFAST])


def test_seed_rule_removes_every_cell_with_a_seed_on_land(synthetic):
    _, land, _ = synthetic
    mesh = build_mesh(MeshParams(lon=[0.0, 12.0], lat=[60.0, 64.0], spacing=30e3, seed=5,
                                     land="none", land_removal="seed"), land_grid=land)
    assert not land.is_land(*mesh.seeds.T).any()
    assert mesh.counts()["coast"] > 5


def test_points_in_polygon_and_contour_files(tmp_path):
    poly = [[-1.0, 60.0], [1.0, 60.0], [1.0, 61.0], [-1.0, 61.0]]
    got = points_in_polygon([0.0, 0.0, 2.0, 179.0], [60.5, 59.9, 60.5, 60.5], poly)
    assert got.tolist() == [True, False, False, False]
    txt = tmp_path / "fast.txt"
    txt.write_text("# landfast\n-1 60\n1 60\n1 61\n-1 61\n-1 60\n\n5 5\n6 5\n6 6\n")
    polys = read_contour(txt)
    assert [len(p) for p in polys] == [4, 3]
    shapefile = pytest.importorskip("shapefile")
    w = shapefile.Writer(str(tmp_path / "fast"), shapeType=shapefile.POLYGON)
    w.field("name", "C")
    w.poly([poly + [poly[0]]])
    w.record("a")
    w.close()
    (shp,) = read_contour(tmp_path / "fast.shp")
    assert np.allclose(np.sort(shp, axis=0), np.sort(np.array(poly), axis=0))


# ---------------------------------------------------------------------------- files
def test_save_load_round_trip_is_identical(tmp_path, synthetic):
    mesh, _, _ = synthetic
    back = Mesh.load(mesh.save(tmp_path / "m.npz"))
    for name in ("offsets", "lonlat", "vertex_id", "seeds", "kind"):
        a, b = getattr(mesh, name), getattr(back, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert back.params == mesh.params and back.digest == mesh.digest
    assert back.stats == json_round(mesh.stats)


def json_round(d):
    return json.loads(json.dumps(d))


def test_build_is_reproducible_and_seeded():
    kw = {"lon": [-10.0, 10.0], "lat": [70.0, 74.0], "spacing": 40e3, "land": "none"}
    a, b = build_mesh(seed=1, **kw), build_mesh(seed=1, **kw)
    assert np.array_equal(a.lonlat, b.lonlat) and np.array_equal(a.offsets, b.offsets)
    c = build_mesh(seed=2, **kw)
    assert c.digest != a.digest and not np.array_equal(c.seeds[:10], a.seeds[:10])


def test_cache_is_reused_until_the_parameters_change(tmp_path):
    path = tmp_path / "cache.npz"
    p = MeshParams(lon=[-10.0, 10.0], lat=[70.0, 74.0], spacing=40e3, land="none", seed=1)
    m1, built1 = load_or_build(p, path)
    stamp = path.stat().st_mtime_ns
    m2, built2 = load_or_build(p, path)
    assert built1 and not built2 and path.stat().st_mtime_ns == stamp
    assert np.array_equal(m1.lonlat, m2.lonlat)
    p.spacing = 45e3
    m3, built3 = load_or_build(p, path)
    assert built3 and m3.digest != m1.digest and m3.n < m1.n
    assert Mesh.load(path).digest == m3.digest
    # a file siku did not write (or cannot tell as its cache) is never replaced
    path.write_bytes(b"not a mesh")
    with pytest.raises(ValueError, match="exists and is not a mesh cache siku wrote"):
        load_or_build(p, path)
    assert path.read_bytes() == b"not a mesh"
    path.unlink()
    m4, built4 = load_or_build(p, path)
    assert built4 and np.array_equal(m4.lonlat, m3.lonlat)


def test_scene_mesh_is_cached_beside_the_scene(tmp_path, monkeypatch, capsys):
    text = """
[time]
duration = "1h"
dt = 60
[elements.mesh]
lon = [-10.0, 10.0]
lat = [70.0, 74.0]
spacing = 40000.0
land = "none"
thickness = 2.0
velocity = [0.1, 0.0]
"""
    path = tmp_path / "sea.toml"
    path.write_text(text, encoding="utf-8")
    st = build_elements(load_scene(path))
    cache = tmp_path / "sea.mesh.npz"
    assert cache.is_file()
    assert "mesh built" in capsys.readouterr().err  # the first build says so
    mesh, built = mesh_for_scene(load_scene(path))
    assert not built and st.n == mesh.n
    err = capsys.readouterr().err  # read from the cache: said, with its smallest cells
    assert "built" not in err and f"mesh of {mesh.n} cells read from {cache}" in err
    assert "smallest free cell" in err
    assert np.all(st.flags == FREE) and np.all(st.thickness == 2.0)
    assert np.allclose(np.hypot(*st.V.T), 0.1)
    path.write_text(text.replace("40000.0", "50000.0"), encoding="utf-8")
    mesh2, built2 = mesh_for_scene(load_scene(path))
    assert built2 and mesh2.n < mesh.n
    err = capsys.readouterr().err  # a rebuild names the cache and says why
    assert "[elements.mesh]" in err and "rebuilt (the cache held a mesh of other parameters)" \
        in err and f"{mesh2.n} cells" in err and str(cache) in err
    # a scene from text and no mesh_file is not cached
    monkeypatch.chdir(tmp_path)
    _, built3 = mesh_for_scene(scene_from_text(text))
    _, built4 = mesh_for_scene(scene_from_text(text))
    assert built3 and built4


def test_scene_mesh_errors_name_the_table():
    base = '[time]\nduration = "1h"\ndt = 60\n[elements.mesh]\nlon = [0, 1]\n'
    with pytest.raises(SceneError, match="south < north"):
        scene_from_text(base + "lat = [71, 70]\nspacing = 1000.0\n")
    with pytest.raises(SceneError, match="land"):
        scene_from_text(base + 'lat = [70, 71]\nspacing = 1000.0\nland = "gshhs"\n')
    with pytest.raises(SceneError, match="spacing"):
        scene_from_text(base + "lat = [70, 71]\n")
    sc = scene_from_text(base + 'lat = [70, 70.01]\nspacing = 50000.0\nland = "none"\n'
                         "cache = false\n")
    with pytest.raises(SceneError, match=r"\[elements.mesh\]: spacing = 50000 m: the region is "
                       r"only about 6.5e\+03 m across"):
        build_elements(sc)


# ---------------------------------------------------------------------------- Beaufort (GLM)
def test_beaufort_scene_builds_with_static_coast_and_auto_joints(beaufort):
    sim, path, seconds = beaufort
    mesh, built = mesh_for_scene(sim.scene)
    assert not built and (path.parent / "beaufort.mesh.npz").is_file()
    st = sim.state
    c = mesh.counts()
    assert st.n == mesh.n and c["ice"] > 300 and c["coast"] > 50 and c["landfast"] > 10
    assert np.all(st.flags[mesh.kind != ICE] == STATIC)
    assert np.all(st.flags[mesh.kind == ICE] == FREE)
    # joints: exactly the edge-sharing pairs that are not both static
    cm = sim.contacts
    joints = set(zip(cm.ji.tolist(), cm.jj.tolist()))
    free = mesh.kind == ICE
    want = {(int(i), int(j)) for i, j in mesh.neighbours() if free[i] or free[j]}
    assert joints == want
    assert sum(free[i] and free[j] for i, j in joints) > 500
    assert seconds < 30


def test_beaufort_ice_cells_are_off_the_land_mask(beaufort):
    sim, _, _ = beaufort
    mesh, _ = mesh_for_scene(sim.scene)
    land = glm_land(Region.box([-162.0, -138.0], [69.0, 74.0]))
    ice = np.flatnonzero(mesh.kind == ICE)
    assert not land.is_land(*mesh.seeds[ice].T).any()
    lon, lat, owner = cell_samples(mesh, ice, 150.0)
    hit = land.is_land(lon, lat)
    assert not hit.any(), np.unique(owner[hit])
    assert land.is_land(*mesh.seeds[mesh.kind == COAST].T).any()  # some coast seeds on land


@pytest.mark.slow
def test_land_window_matches_global_land_mask(request):
    """Our streamed window looks up the same pixels as ``globe.is_land``. Importing ``globe``
    decompresses its whole 0.9 GB grid (4 s): runs only with ``-m slow``."""
    if "slow" not in (request.config.getoption("markexpr") or ""):
        pytest.skip("imports the whole 0.9 GB land mask; run with -m slow")
    globe = pytest.importorskip("global_land_mask.globe")

    win = Region.box([-162.0, -138.0], [69.0, 74.0])
    land = glm_land(win)
    rng = np.random.default_rng(0)
    lon = rng.uniform(-162, -138, 200_000)
    lat = rng.uniform(69, 74, 200_000)
    assert np.array_equal(land.is_land(lon, lat), globe.is_land(lat, lon))


# ---------------------------------------------------------------------------- GSHHG: no lakes
def test_the_default_mesh_has_no_cell_on_inland_water():
    """The shipped default scene's mesh (GSHHG shorelines) puts no cell on the lakes of the
    North Slope: every cell, static or free, reaches the sea (outside the GSHHG level-1
    polygons, which hold the lakes), and no free element's centre lies inside a level-1 polygon
    nor does a free cell meet one. Checked with shapely against the polygons the mesh was built
    from; a cell counts as reaching the sea when it comes within half a land pixel's diagonal of
    it (the builder looks a point up in the pixel holding it, whose centre may lie that far
    off; a pixel is ``r_min / 8`` high and ``1 / cos`` of the window's far latitude as wide), plus
    the bulge of a great-circle edge off its straight lon/lat chord (below ``L² tan(lat) /
    8R``: 2 m for a 6 km edge at 75° N; 1e-4 degrees taken). With the lakes meshed as sea, 188
    static cells lay wholly on land and lakes, 179 of them farther than that from the sea."""
    shapely = pytest.importorskip("shapely")
    from siku_core.run.cli import default_scene_path
    from siku_io.mesh import gshhg

    mesh, _ = mesh_for_scene(load_scene(default_scene_path()))
    p = MeshParams(**mesh.params["params"])
    assert p.land == "gshhg"
    window = Region.box(p.lon, p.lat).expanded(p.coast_distance + 4.0 * p.spacing, p.radius)
    lon = (window.lon0, window.lon0 + window.width)
    shores = gshhg.shorelines(lon, (window.lat0, window.lat1), gshhg.choose_resolution(p.r_min))
    land = shapely.union_all([shapely.Polygon(s.lonlat) for s in shores if s.level == 1])
    lakes = [s for s in shores if s.level == 2]
    assert len(lakes) > 100  # the North Slope's lakes are in the window
    sea = shapely.box(lon[0], window.lat0, lon[1], window.lat1).difference(land)
    dlat = math.degrees(p.r_min / 8.0 / p.radius)
    dlon = dlat / math.cos(math.radians(window.lat1))
    tol = 0.5 * math.hypot(dlat, dlon) + 1e-4
    x = lon[0] + (mesh.lonlat[:, 0] - lon[0]) % 360.0
    cells = np.array([shapely.Polygon(np.column_stack([x, mesh.lonlat[:, 1]])[a:b])
                      for a, b in zip(mesh.offsets[:-1], mesh.offsets[1:])])
    far = shapely.distance(cells, sea) > tol
    assert not far.any(), (f"{far.sum()} cells ({mesh.counts()}) lie on land or lakes, e.g. "
                           f"seeds {mesh.seeds[far][:5].tolist()}")
    ice = mesh.kind == ICE
    assert ice.sum() > 4000
    sx = lon[0] + (mesh.seeds[:, 0] - lon[0]) % 360.0
    assert not shapely.contains_xy(land, sx[ice], mesh.seeds[ice, 1]).any()
    centroids = shapely.centroid(cells[ice])
    assert not shapely.contains(land, centroids).any()
    assert not shapely.intersects(cells[ice], shapely.buffer(land, -tol)).any()
