"""Linear kinematic features (LKFs) of a deformation field on Lagrangian cells: detection,
segmentation at junctions, intersection angles and lifetimes (``siku deformation --sirex``).

The cells are triangles of tracked points (:func:`siku_io.analysis.sirex.cells`), each with a
total deformation rate ``eps`` [1/s]. The method, in the spirit of the RGPS feature analyses
(Hutter, Zampieri and Losch 2019, The Cryosphere 13, 627-645: features split at junctions,
tracked through time by overlap), on cells instead of a grid:

1. **Active cells**: ``eps > rate``; joined through shared sides into connected groups.
2. **Local orientation**: each active cell's is the principal axis of the centroids of the
   active cells of its group within ``reach`` [m] of it (default three median cell sizes);
   its anisotropy ``sqrt(l_min / l_max)`` of that neighbourhood's second moments. A cell whose
   neighbourhood is nearly isotropic (anisotropy above ``junction``, default 0.5) is a
   junction or a blob, not part of a line.
3. **Segments**: within a group, neighbouring line cells (sharing a side) are joined when
   their local orientations differ by less than ``bend`` [deg, default 20]; each joined set of
   at least ``min_cells`` cells is one feature. Two crossing leads, one group, are four
   segments (the arms); a straight lead is one.
4. **Geometry**: a feature's length is the extent of its centroids along their principal axis
   [m], its orientation that axis's angle from east [deg, 0-180], its ends the extreme
   projections on the axis.
5. **Intersections**: two features of one interval intersect when the distance between their
   axis segments is at most ``reach``; the angle between them is the acute angle between the
   axes [deg, 0-90], counted when at least ``bend`` (smaller angles are one lead's pieces).
6. **Lifetimes**: the cells' points are the same material points at every interval, so a
   feature of interval ``k + 1`` continues one of interval ``k`` when they share at least half
   of the smaller one's points. Features linked so (merges and splits included) are one
   track; its lifetime is the number of intervals from its first to its last, times the
   interval [s].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Feature:
    """One linear kinematic feature: its cells (rows of the triangles given), its points
    (sorted indices of the tracked points), centroid ``(x, y)`` [m], unit ``axis``, ``length``
    [m], ``angle`` [deg from east, 0-180] and the ``ends`` of its axis segment [m]."""

    cells: np.ndarray
    points: np.ndarray
    centre: tuple[float, float]
    axis: tuple[float, float]
    length: float
    angle: float
    ends: tuple[tuple[float, float], tuple[float, float]]


def side_pairs(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(a, b)`` of rows of ``tri`` ``(M, 3)`` that share a side."""
    t = np.sort(tri, axis=1)
    sides = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [0, 2]]])
    owner = np.tile(np.arange(len(tri)), 3)
    order = np.lexsort((sides[:, 1], sides[:, 0]))
    s, o = sides[order], owner[order]
    same = np.all(s[1:] == s[:-1], axis=1)
    return o[:-1][same], o[1:][same]


def _components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    g = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    return connected_components(g, directed=False)[1]


def _principal(px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit principal axis of points and the anisotropy ``sqrt(l_min / l_max)``."""
    P = np.column_stack([px - px.mean(), py - py.mean()])
    w, vec = np.linalg.eigh(P.T @ P)
    lmax = max(float(w[-1]), 1e-300)
    return vec[:, -1], float(np.sqrt(max(float(w[0]), 0.0) / lmax))


def _axial_difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Acute difference [deg, 0-90] of axial angles [deg]."""
    d = np.abs(a - b) % 180.0
    return np.minimum(d, 180.0 - d)


def detect(tri: np.ndarray, eps: np.ndarray, cx: np.ndarray, cy: np.ndarray, rate: float,
           min_cells: int = 3, reach: float | None = None, junction: float = 0.5,
           bend: float = 20.0) -> list[Feature]:
    """The features of cells ``tri`` (point indices) with rates ``eps`` [1/s] and centroids
    ``(cx, cy)`` [m] (steps 1-4 of the module docstring)."""
    from scipy.spatial import cKDTree

    act = np.flatnonzero(eps > rate)
    if len(act) < min_cells:
        return []
    a, b = side_pairs(tri[act])
    group = _components(len(act), a, b)
    x, y = cx[act], cy[act]
    if reach is None:
        d = np.hypot(x[a] - x[b], y[a] - y[b])
        reach = 3.0 * float(np.median(d)) if len(d) else 0.0
    near = cKDTree(np.column_stack([x, y])).query_ball_point(np.column_stack([x, y]), reach)
    theta = np.full(len(act), np.nan)
    for c, nb in enumerate(near):
        nb = np.asarray(nb)
        nb = nb[group[nb] == group[c]]
        if len(nb) < 3:
            continue
        axis, aniso = _principal(x[nb], y[nb])
        if aniso <= junction:
            theta[c] = np.degrees(np.arctan2(axis[1], axis[0])) % 180.0
    line = np.isfinite(theta)
    keep = line[a] & line[b] & (group[a] == group[b])
    keep[keep] = _axial_difference(theta[a[keep]], theta[b[keep]]) < bend
    seg = _components(len(act), a[keep], b[keep])
    out = []
    for s in np.unique(seg[line]):
        m = np.flatnonzero((seg == s) & line)
        if len(m) < min_cells:
            continue
        axis, _ = _principal(x[m], y[m])
        mx, my = float(x[m].mean()), float(y[m].mean())
        proj = (x[m] - mx) * axis[0] + (y[m] - my) * axis[1]
        lo, hi = float(proj.min()), float(proj.max())
        out.append(Feature(
            cells=act[m], points=np.unique(tri[act[m]]), centre=(mx, my),
            axis=(float(axis[0]), float(axis[1])), length=hi - lo,
            angle=float(np.degrees(np.arctan2(axis[1], axis[0])) % 180.0),
            ends=((mx + lo * axis[0], my + lo * axis[1]), (mx + hi * axis[0], my + hi * axis[1]))))
    return out


def segment_distance(p, q, r, s) -> float:
    """Least distance [m] between the segments ``p-q`` and ``r-s`` (points ``(x, y)``)."""
    p, q, r, s = (np.asarray(v, float) for v in (p, q, r, s))

    def point_seg(c, a, b):
        ab = b - a
        t = 0.0 if not ab.any() else float(np.clip((c - a) @ ab / (ab @ ab), 0.0, 1.0))
        return float(np.hypot(*(a + t * ab - c)))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    d1, d2 = cross(r, s, p), cross(r, s, q)
    d3, d4 = cross(p, q, r), cross(p, q, s)
    if d1 * d2 < 0 and d3 * d4 < 0:
        return 0.0
    return min(point_seg(p, r, s), point_seg(q, r, s), point_seg(r, p, q), point_seg(s, p, q))


def intersection_angles(features: list[Feature], reach: float, bend: float = 20.0) -> np.ndarray:
    """Acute angles [deg] between the features whose axis segments come within ``reach`` [m]
    of each other, at least ``bend`` [deg] apart (step 5)."""
    out = []
    for i, f in enumerate(features):
        for g in features[i + 1:]:
            ang = float(_axial_difference(np.array(f.angle), np.array(g.angle)))
            if ang >= bend and segment_distance(*f.ends, *g.ends) <= reach:
                out.append(ang)
    return np.asarray(out)


def lifetimes(per_interval: list[list[Feature]], interval: float,
              overlap: float = 0.5) -> np.ndarray:
    """Lifetimes [s] of the tracks through consecutive intervals ``per_interval`` (each a
    list of features), ``interval`` [s] apart (step 6): one per track."""
    flat = [(k, f) for k, fs in enumerate(per_interval) for f in fs]
    if not flat:
        return np.zeros(0)
    index = {}
    start = 0
    for k, fs in enumerate(per_interval):
        index[k] = range(start, start + len(fs))
        start += len(fs)
    a, b = [], []
    for k in range(len(per_interval) - 1):
        for i, f in zip(index[k], per_interval[k]):
            for j, g in zip(index[k + 1], per_interval[k + 1]):
                shared = len(np.intersect1d(f.points, g.points, assume_unique=True))
                if shared >= overlap * min(len(f.points), len(g.points)):
                    a.append(i)
                    b.append(j)
    track = _components(len(flat), np.asarray(a, np.int64), np.asarray(b, np.int64))
    k_of = np.array([k for k, _ in flat])
    out = []
    for t in np.unique(track):
        ks = k_of[track == t]
        out.append((ks.max() - ks.min() + 1) * interval)
    return np.asarray(out, float)
