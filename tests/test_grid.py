"""Gridded fields (siku_forcing.gridded.regular_grid, siku_io.analysis.gridded_fields): exact area,
exact strain rates, stress.

* Concentration times cell area, summed over the grid, is the ice area of the elements to
  round-off: the overlap pieces of a polygon partition it (1e-9 relative), on both grid kinds and
  across the antimeridian; a cell deep inside a tiled pack is full (1 to the map distortion
  across one element, (size / R) ~ 1e-3).
* Strain rates from the line integral around the hull of the centres are exact for any
  velocity linear in position (trapezoidal rule on straight edges), so prescribed divergence,
  pure shear and rigid rotation come back to 1e-9 and a rigid translation gives 0.
* The grid's geometry against PROJ and the geodesic area of pyproj.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.run.simulation import Simulation
from siku_core.testing.scenes import make_scene
from siku_io.analysis.gridded_fields import Snapshot, grid_snapshot, snapshot_of, strain_rates
from siku_forcing.gridded.regular_grid import Grid, GridCfg

R = 6371e3


def pack_snapshot(lon, lat, nx, ny):
    """The snapshot of a pack of ``nx`` x ``ny`` square floes spanning ``lon``, ``lat``."""
    scene = make_scene([], packs=[{"lon": list(lon), "lat": list(lat), "nx": nx, "ny": ny}],
                       duration=60.0, dt=60.0)
    sim = Simulation(scene, out=False, progress=False)
    return snapshot_of(sim)


PS = dict(kind="polar_stereographic", x=(-2.5e6, 2.5e6), y=(-2.5e6, 2.5e6), resolution=50e3)


@pytest.mark.parametrize("cfg,pack", [
    (dict(kind="lonlat", lon=(-10, 10), lat=(60, 80), resolution=0.5),
     ((-4.3, 3.9), (66.1, 71.7))),
    (dict(kind="lonlat", lon=(170, 190), lat=(60, 80), resolution=0.25),
     ((176.2, 183.9), (70.05, 74.3))),  # across the antimeridian
    (dict(kind="lonlat", lon=(-180, 180), lat=(-80, 80), resolution=2.0),
     ((175.0, 185.0), (-5.0, 5.0))),  # a whole circle: the pack wraps from its east edge
    (PS, ((-160.0, -120.0), (76.0, 81.0))),
    (dict(PS, central_longitude=180.0), ((172.0, 190.0), (78.0, 82.0))),
    (dict(PS, hemisphere="south", central_longitude=0.0), ((-40.0, 10.0), (-78.0, -73.0))),
])
def test_concentration_times_cell_area_sums_to_the_ice_area(cfg, pack):
    snap = pack_snapshot(*pack, 12, 7)
    grid = Grid(GridCfg(**cfg), R)
    f = grid_snapshot(grid, snap)
    total = np.sum(f["concentration"] * grid.cell_area)
    assert total == pytest.approx(snap.area.sum(), rel=1e-9)
    volume = np.sum(f["thickness"] * grid.cell_area)
    assert volume == pytest.approx(np.sum(snap.area * snap.thickness), rel=1e-9)
    # a cell with every neighbour inside the pack is covered, to the change of the map's
    # scale across one element: relative (d / R)(1 + tan lat) for elements of diameter d
    (w, e), (s, n) = pack
    mx, my = (e - w) / 12, (n - s) / 7  # one floe in from the pack's edges
    X, Y = np.meshgrid(grid.x_edges, grid.y_edges)
    lon, lat = grid.to_lonlat(X, Y)
    lon = w + np.mod(lon - w, 360.0)
    ok = (lon > w + mx) & (lon < e - mx) & (lat > s + my) & (lat < n - my)
    inner = ok[:-1, :-1] & ok[1:, :-1] & ok[:-1, 1:] & ok[1:, 1:]
    full = f["concentration"][inner]
    d = 2 * np.sqrt(snap.area.max())
    bound = d / R * (1 + math.tan(math.radians(np.abs(snap.lat).max())))
    assert full.size and np.all(np.abs(full - 1.0) < bound)


def test_the_lonlat_cell_areas_tile_the_sphere_and_stereographic_ones_match_pyproj():
    pyproj = pytest.importorskip("pyproj")
    whole = Grid(GridCfg(kind="lonlat", lon=(-180, 180), lat=(-90, 90), resolution=3.0), R)
    assert whole.cell_area.sum() == pytest.approx(4 * math.pi * R * R, rel=1e-12)
    for hemi in ("north", "south"):
        g = Grid(GridCfg(**dict(PS, hemisphere=hemi)), R)
        lon = np.array([-150.0, 10.0, 100.0])
        lat = np.array([75.0, 80.0, 65.0]) * (1 if hemi == "north" else -1)
        X, Y = g.to_plane(lon, lat)
        t = pyproj.Transformer.from_crs(pyproj.CRS.from_proj4(f"+proj=longlat +R={R}"),
                                        pyproj.CRS.from_proj4(g.proj4), always_xy=True)
        px, py = t.transform(lon, lat)
        assert np.allclose(X, px, atol=1e-6) and np.allclose(Y, py, atol=1e-6)
        back = g.to_lonlat(X, Y)
        assert np.allclose(back, [lon, lat], atol=1e-12)
        # the grid x axis against a finite difference of the projection along east
        Xe, Ye = g.to_plane(lon + 1e-6, lat)
        east = np.arctan2(Ye - Y, Xe - X)
        assert np.allclose(np.angle(np.exp(1j * (east + g.axes(lon, lat)))), 0, atol=1e-7)
        # one cell against the geodesic area of its outline (edges densified in the plane)
        i, j = 3, 5
        x0, x1 = g.x_edges[j], g.x_edges[j + 1]
        y0, y1 = g.y_edges[i], g.y_edges[i + 1]
        s = np.linspace(0, 1, 2001)
        px = np.r_[x0 + (x1 - x0) * s, np.full_like(s, x1), x1 - (x1 - x0) * s,
                   np.full_like(s, x0)]
        py = np.r_[np.full_like(s, y0), y0 + (y1 - y0) * s, np.full_like(s, y1),
                   y1 - (y1 - y0) * s]
        lo, la = g.to_lonlat(px, py)
        area, _ = pyproj.Geod(a=R, b=R).polygon_area_perimeter(lo, la)
        assert g.cell_area[i, j] == pytest.approx(abs(area), rel=1e-9)


def test_the_line_integral_is_exact_for_linear_velocity():
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-2e4, 2e4, 9), rng.uniform(-1e4, 3e4, 9)
    L = np.array([[2e-6, -3e-6], [5e-7, -1e-6]])
    u = L[0, 0] * x + L[0, 1] * y + 0.3
    v = L[1, 0] * x + L[1, 1] * y - 0.1
    ux, uy, vx, vy, area = strain_rates(x, y, u, v)
    assert np.allclose([ux, uy, vx, vy], L.ravel(), rtol=0, atol=1e-9 * 3e-6)
    assert np.isnan(strain_rates(x[:2], y[:2], u[:2], v[:2])[0])


def _assign(snap, grid, gradient, offset):
    """Velocities of a field linear in the grid plane: ``(u, v)_grid = G (x, y) + offset``,
    given to the snapshot as east/north components."""
    X, Y = grid.to_plane(snap.lon, snap.lat)
    gu = gradient[0][0] * X + gradient[0][1] * Y + offset[0]
    gv = gradient[1][0] * X + gradient[1][1] * Y + offset[1]
    a = grid.axes(snap.lon, snap.lat)  # grid components -> east/north: rotate back by a
    snap.u = gu * np.cos(a) - gv * np.sin(a)
    snap.v = gu * np.sin(a) + gv * np.cos(a)


FIELDS = {  # name: (gradient [[ux, uy], [vx, vy]] [1/s], divergence, shear, vorticity)
    "divergence": ([[1e-6, 0.0], [0.0, 1e-6]], 2e-6, 0.0, 0.0),
    "pure shear": ([[1e-6, 0.0], [0.0, -1e-6]], 0.0, 2e-6, 0.0),
    "simple shear": ([[0.0, 2e-6], [0.0, 0.0]], 0.0, 2e-6, -2e-6),
    "rotation": ([[0.0, -1e-6], [1e-6, 0.0]], 0.0, 0.0, 2e-6),
    "translation": ([[0.0, 0.0], [0.0, 0.0]], 0.0, 0.0, 0.0),
}


@pytest.mark.parametrize("name", FIELDS)
def test_strain_rates_are_exact_for_prescribed_motion_on_a_stereographic_grid(name):
    grad, div, shear, vort = FIELDS[name]
    snap = pack_snapshot((-160.0, -110.0), (74.0, 80.0), 30, 24)
    grid = Grid(GridCfg(**PS), R)
    _assign(snap, grid, grad, (0.2, -0.1))
    f = grid_snapshot(grid, snap)
    ok = np.isfinite(f["divergence"])
    assert ok.sum() >= 20
    tol = 1e-9 * 2e-6
    assert np.allclose(f["divergence"][ok], div, rtol=0, atol=tol)
    assert np.allclose(f["shear"][ok], shear, rtol=0, atol=tol)
    assert np.allclose(f["vorticity"][ok], vort, rtol=0, atol=tol)
    assert np.allclose(f["total_deformation"][ok], math.hypot(div, shear), rtol=0, atol=tol)
    # the mean velocity of a cell is the field at its mass centre: a translation is exact
    if name == "translation":
        got = f["u"][np.isfinite(f["u"])]
        assert np.allclose(got, 0.2, rtol=0, atol=1e-12)


def test_strain_rates_on_a_lonlat_grid_use_the_plane_of_each_cell():
    """A velocity linear in longitude and latitude, ``u = a lon + b lat`` [deg], is linear in
    each cell's plane ``x = R cos(lat_c) (lon - lon_c)``, ``y = R (lat - lat_c)``, with
    ``ux = a / (R cos(lat_c) rad)``, ``uy = b / (R rad)``; likewise ``v``."""
    snap = pack_snapshot((-30.0, 10.0), (66.0, 74.0), 36, 30)
    grid = Grid(GridCfg(kind="lonlat", lon=(-30, 10), lat=(66, 74), resolution=2.0), R)
    a, b, c, d = 2e-3, -1e-3, 5e-4, 1.5e-3  # m/s per degree
    snap.u = a * snap.lon + b * snap.lat
    snap.v = c * snap.lon + d * snap.lat
    f = grid_snapshot(grid, snap)
    rad = math.pi / 180
    coslat = np.cos(np.radians(grid.y))[:, None]
    ux, uy = a / (R * coslat * rad), b / (R * rad) + 0 * coslat
    vx, vy = c / (R * coslat * rad), d / (R * rad) + 0 * coslat
    ok = np.isfinite(f["divergence"])
    assert ok.sum() >= 20
    tol = 1e-9 * 1e-6
    expect = {"divergence": ux + vy, "vorticity": vx - uy, "shear": np.hypot(ux - vy, uy + vx)}
    for name, value in expect.items():
        assert np.allclose(f[name][ok], np.broadcast_to(value, ok.shape)[ok], rtol=0, atol=tol)


def test_cells_without_enough_elements_have_no_strain_rate():
    snap = Snapshot([0.0, 0.1], [0.0, 0.1], [0, 0], [0, 0], [1, 1], [1, 1], [1, 1],
                    [-0.01, 0.01, 0.01, -0.01, 0.09, 0.11, 0.11, 0.09],
                    [-0.01, -0.01, 0.01, 0.01, 0.09, 0.09, 0.11, 0.11], [0, 4, 8])
    grid = Grid(GridCfg(kind="lonlat", lon=(-1, 1), lat=(-1, 1), resolution=1.0), R)
    f = grid_snapshot(grid, snap)
    assert np.isnan(f["divergence"]).all()
    assert f["n_elements"].sum() == 2


@pytest.mark.parametrize("cover,overlap_cells,giver_cells", [
    (0.8, 1.0, 1.0),     # the giver ceded exactly the overlap: no ice counted twice
    (0.6, 1.0, 0.75),    # more open water than overlap: the rest spread over the giver's cells
    (0.9, 1.5, 1.0),     # half the overlap ceded: half of it still covered twice
])
def test_a_givers_open_water_lies_under_its_overlap_on_cells_narrower_than_an_element(
        cover, overlap_cells, giver_cells):
    """Two 0.1° squares at the equator overlapping on a 0.02° strip (a fifth of each), the
    carrier all ice, the giver's ice covering ``cover`` of it, on 0.02° cells: the giver's
    open water lies in the strip first, so a strip cell holds the carrier's ice plus the
    giver's left there, ``1 + (0.2 - (1 - cover)) / 0.2`` when positive."""
    lon_a = [0.0, 0.1, 0.1, 0.0]
    lon_b = [0.08, 0.18, 0.18, 0.08]
    lat = [0.0, 0.0, 0.1, 0.1]
    area = R**2 * math.radians(0.1) * math.sin(math.radians(0.1))
    snap = Snapshot([0.05, 0.13], [0.05, 0.05], [0, 0], [0, 0], [area, area], [1, 1],
                    [1, 1], lon_a + lon_b, lat + lat, [0, 4, 8],
                    categories=([[1.0], [cover]], [[1.0], [1.0]]))
    grid = Grid(GridCfg(kind="lonlat", lon=(-0.04, 0.22), lat=(0.0, 0.1), resolution=0.02),
                R)
    c = grid_snapshot(grid, snap)["concentration"]
    assert c.shape == (5, 13)
    x = grid.x
    assert c[:, (x > 0) & (x < 0.08)] == pytest.approx(1.0, rel=1e-5)           # carrier alone
    assert c[:, (x > 0.08) & (x < 0.1)] == pytest.approx(overlap_cells, rel=1e-5)
    assert c[:, (x > 0.1) & (x < 0.18)] == pytest.approx(giver_cells, rel=1e-5)  # giver alone
    assert c[:, (x < 0) | (x > 0.18)] == pytest.approx(0.0, abs=1e-12)
    # the ice area is the elements' ice: A + cover A
    assert np.sum(c * grid.cell_area) == pytest.approx(area * (1 + cover), rel=1e-5)
