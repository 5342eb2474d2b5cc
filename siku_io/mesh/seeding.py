"""Seeds of a mesh: maximal blue noise with a spacing that may vary with position (stage 1)."""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from siku_core.geometry.sphere import xyz_to_lonlat

from .region import Region
from .sphere import DEFAULT_RADIUS, arc_of, chord_of


# ---------------------------------------------------------------------------- spacing
@dataclass
class SpacingField:
    """Minimum seed spacing [m] as a function of position: ``fine`` at the coast rising linearly
    to ``coarse`` at ``distance`` from it (``coarse`` everywhere without coast points), or any
    callable ``fn(lon, lat) -> metres`` with its bounds."""

    coarse: float
    fine: float | None = None
    distance: float | None = None
    coast_xyz: np.ndarray | None = None
    R: float = DEFAULT_RADIUS
    fn: Callable | None = None
    bounds: tuple[float, float] | None = None
    _tree: Any = field(default=None, repr=False)

    def __post_init__(self):
        if self.fn is None and self.graded:
            self._tree = cKDTree(self.coast_xyz)

    @property
    def graded(self) -> bool:
        return (self.fn is None and self.fine is not None and self.fine != self.coarse
                and self.distance is not None and self.distance > 0
                and self.coast_xyz is not None and len(self.coast_xyz) > 0)

    @property
    def r_min(self) -> float:
        if self.fn is not None:
            return self.bounds[0]  # type: ignore[index]
        return min(self.coarse, self.fine) if self.graded else self.coarse  # type: ignore

    @property
    def r_max(self) -> float:
        if self.fn is not None:
            return self.bounds[1]  # type: ignore[index]
        return max(self.coarse, self.fine) if self.graded else self.coarse  # type: ignore

    @property
    def lipschitz(self) -> float | None:
        """Bound on ``|dr/ds|`` (None: unknown)."""
        if self.fn is not None:
            return None
        if not self.graded:
            return 0.0
        return abs(self.coarse - self.fine) / self.distance  # type: ignore[operator]

    def coast_distance(self, xyz: np.ndarray) -> np.ndarray:
        """Distance to the nearest coast point [m] (``inf`` beyond ``distance``)."""
        ub = float(chord_of(self.distance, self.R)) * 1.000001  # type: ignore[arg-type]
        d, _ = self._tree.query(xyz, distance_upper_bound=ub)
        return np.where(np.isfinite(d), arc_of(np.minimum(d, 2.0), self.R), np.inf)

    def __call__(self, xyz: np.ndarray) -> np.ndarray:
        xyz = np.atleast_2d(xyz)
        if self.fn is not None:
            r = np.asarray(self.fn(*xyz_to_lonlat(xyz)), dtype=float)
            return np.broadcast_to(r, (len(xyz),)).astype(float)
        if not self.graded:
            return np.full(len(xyz), float(self.coarse))
        d = self.coast_distance(xyz)
        s = np.minimum(d / self.distance, 1.0)
        return self.fine + (self.coarse - self.fine) * s  # type: ignore[operator]


# ---------------------------------------------------------------------------- blue noise
def _fibonacci(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def guard_points(patch: Region, R: float, gap_m: float) -> np.ndarray:
    """Far points closing the Voronoi diagram of a patch (none for the whole sphere)."""
    if patch.full_lon and patch.lat0 <= -90 and patch.lat1 >= 90:
        return np.zeros((0, 3))
    g = _fibonacci(600)
    far = patch.expanded(gap_m, R)
    return g[~far.contains_xyz(g)]


def blue_noise(region: Region, spacing: SpacingField, R: float, rng: np.random.Generator,
               *, pool: float = 8.0, guards: np.ndarray | None = None,
               max_points: int = 2_000_000) -> np.ndarray:
    """Maximal Poisson-disc points in ``region`` (unit vectors ``(n, 3)``).

    For every pair ``|p - q| >= max(r(p), r(q))`` (great-circle distance, ``r = spacing``).
    Candidates are drawn uniformly by area and thinned with probability ``(r_min / r)^2`` (equal
    candidates per final point everywhere), about ``pool`` per expected point, and accepted in
    random order when no accepted point is too close (a k-d tree on the candidates). Holes are
    then filled at Voronoi vertices (centres of the largest empty circles) until none is
    ``r`` wide. Deterministic for a given ``rng`` state.
    """
    probe = region.sample(rng, 4096)
    rp = spacing(probe)
    if np.any(~np.isfinite(rp)) or np.any(rp <= 0):
        raise ValueError("spacing must be positive and finite")
    r_min = float(min(spacing.r_min, rp.min()))
    r_max = float(max(spacing.r_max, rp.max()))
    n_est = 0.75 * region.area(R) * float(np.mean(1.0 / rp**2))
    if n_est > max_points:
        raise ValueError(
            f"about {n_est:.3g} cells at this spacing; more than {max_points}: widen the spacing "
            "or narrow the region")
    if n_est > 200_000:  # the gap filling completes a thinner pool; keeps memory down
        pool = min(pool, 3.0)
    keep_p = float(np.mean((r_min / rp) ** 2))
    n_draw = int(pool * n_est / keep_p) + 64
    parts = []
    while n_draw > 0:
        b = min(n_draw, 1_000_000)
        c = region.sample(rng, b)
        u = rng.random(b)
        parts.append(c[u < (r_min / spacing(c)) ** 2])
        n_draw -= b
    cand = np.concatenate(parts)
    rm = spacing(cand)
    rc = chord_of(rm, R)
    L = spacing.lipschitz
    ch_max = float(chord_of(r_max, R))
    if L is not None and L < 0.9:
        qr = np.minimum(chord_of(rm / (1.0 - L), R) * 1.001, ch_max * 1.001)
    else:
        qr = np.full(len(cand), ch_max * 1.001)
    tree = cKDTree(cand)
    alive = np.ones(len(cand), dtype=bool)
    chosen = []
    for i in range(len(cand)):
        if not alive[i]:
            continue
        chosen.append(i)
        nb = np.asarray(tree.query_ball_point(cand[i], qr[i]), dtype=np.int64)
        d = np.linalg.norm(cand[nb] - cand[i], axis=1)
        alive[nb[d < np.maximum(rc[nb], rc[i])]] = False
    pts = cand[np.asarray(chosen, dtype=np.int64)]
    rad = rc[np.asarray(chosen, dtype=np.int64)]
    if guards is None:
        guards = np.zeros((0, 3))
    return _fill_gaps(pts, rad, region, spacing, R, rng, guards, ch_max)


def _conflict_free(tree: cKDTree, rad: np.ndarray, v: np.ndarray, rv: np.ndarray,
                   qmax: float, k: int = 24) -> np.ndarray:
    """Which points ``v`` (chord radii ``rv``) keep ``|v - p| >= max(r(v), r(p))`` to every
    point ``p`` of ``tree`` (chord radii ``rad``)."""
    n = tree.n
    if n == 0 or len(v) == 0:
        return np.ones(len(v), dtype=bool)
    k = min(k, n)
    d, idx = tree.query(v, k=k, distance_upper_bound=qmax)
    d, idx = d.reshape(len(v), k), idx.reshape(len(v), k)
    valid = idx < n
    rr = np.where(valid, rad[np.minimum(idx, n - 1)], 0.0)
    good = ~np.any(valid & (d < np.maximum(rr, rv[:, None])), axis=1)
    for i in np.flatnonzero(good & valid[:, -1]):  # k neighbours all within reach: check all
        nb = np.asarray(tree.query_ball_point(v[i], qmax), dtype=np.int64)
        dd = np.linalg.norm(tree.data[nb] - v[i], axis=1)
        good[i] = not np.any(dd < np.maximum(rad[nb], rv[i]))
    return good


def _greedy(v: np.ndarray, rv: np.ndarray) -> np.ndarray:
    """Indices of a maximal conflict-free subset of ``v``, taken in the given order."""
    if len(v) <= 1:
        return np.arange(len(v))
    pairs = cKDTree(v).query_pairs(float(rv.max()), output_type="ndarray")
    if len(pairs):
        d = np.linalg.norm(v[pairs[:, 0]] - v[pairs[:, 1]], axis=1)
        pairs = pairs[d < np.maximum(rv[pairs[:, 0]], rv[pairs[:, 1]])]
    both = np.concatenate([pairs, pairs[:, ::-1]])
    order = np.argsort(both[:, 0], kind="stable")
    nbr = both[order, 1]
    start = np.searchsorted(both[order, 0], np.arange(len(v) + 1))
    blocked = np.zeros(len(v), dtype=bool)
    out = []
    for i in range(len(v)):
        if blocked[i]:
            continue
        out.append(i)
        blocked[nbr[start[i]:start[i + 1]]] = True
    return np.asarray(out, dtype=np.int64)


def _fill_gaps(pts, rad, region, spacing, R, rng, guards, ch_max, max_rounds=100):
    """Add points at Voronoi vertices (centres of empty circles) while any can be added."""
    for _ in range(max_rounds):
        allp = np.vstack([pts, guards])
        hull = ConvexHull(allp)
        v = hull.equations[:, :3]  # outward unit normals: the circumcentres on the sphere
        empty = np.linalg.norm(v - allp[hull.simplices[:, 0]], axis=1)
        ok = region.contains_xyz(v)
        v, empty = v[ok], empty[ok]
        rv = chord_of(spacing(v), R) if len(v) else np.zeros(0)
        ok = empty >= rv
        v, rv = v[ok], rv[ok]
        if not len(v):
            break
        good = _conflict_free(cKDTree(pts), rad, v, rv, ch_max * 1.001)
        v, rv = v[good], rv[good]
        if not len(v):
            break
        perm = rng.permutation(len(v))
        v, rv = v[perm], rv[perm]
        take = _greedy(v, rv)
        pts = np.vstack([pts, v[take]])
        rad = np.concatenate([rad, rv[take]])
    return pts
