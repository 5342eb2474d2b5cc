"""Relaxing the seeds of a mesh's smallest free cells (``[elements.mesh] min_area_share``).

A free (ice) cell's stable step scales with its linear size (:mod:`siku_core.scene.cells`), so the
smallest cells of a mesh set the step of the whole pack. With ``min_area_share = s > 0`` the
builder moves seeds until every free cell has at least ``s`` times the median free-cell area,
or a bounded number of rounds (:data:`ROUNDS`) is spent, or a round moves nothing:

* **Rounds.** The seed of each free cell below the share moves to its cell's centroid on the
  sphere (a Lloyd step), and the seeds of its free neighbours move straight away from it far
  enough to move their shared edges out by the missing area over the length of those edges
  (grown to :data:`MARGIN` above the share; a move at most a fifth of the two seeds'
  distance); then the Voronoi diagram is rebuilt.
* **Merges.** After :data:`LLOYD_ROUNDS` rounds (or a round that moved nothing), a cell still
  below the share is merged with its nearest free neighbour (both seeds replaced by one at
  their midpoint) before each further step.

Only free seeds move, never the seeds of static cells (coast, landfast), and only free seeds
whose cell borders no cell outside the mesh (a cell cut by the region's edge, a removed land
cell, a guard): the union of the mesh's cells stays exactly what it was. After each step the
cells around the moved seeds are classified again by the builder's own rules (inside the
region, land, coast, landfast, :func:`siku_io.mesh.build.build_mesh`); a move that would change
any cell's kind (a free cell touching land, a coast cell losing its land, a seed entering a
landfast contour) or make a moved seed border a cell outside the mesh is undone, and that seed
stays where it was for the round. So a small cell between static cells and the region's edge
may stay below the share (the builder warns). The relaxation is deterministic: no random
numbers, a fixed order of work.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from .sphere import unit_rows, spherical_polygon_areas
from .voronoi import csr_take, next_index, cell_pairs, voronoi_cells

#: rounds of moves alone before merges start, and the whole budget of rounds
LLOYD_ROUNDS = 8
ROUNDS = 24
#: the largest share a scene may ask for (a Voronoi mesh of random seeds cannot have all
#: its cells near the median)
MAX_SHARE = 0.9
#: the area a small cell is grown to, above the share asked for: ``share * (1 + MARGIN)``
MARGIN = 0.05
#: the status of a seed whose cell is not in the mesh (cut by the region's edge, or a guard);
#: a removed land cell is :data:`REMOVED`; cells of the mesh have their kind (0 ice = free)
OUTSIDE, REMOVED, FREE_KIND = -1, 3, 0


class _Diagram:
    """The Voronoi diagram of the seeds and guards: the free cells' areas (unit sphere),
    neighbour pairs, and which seeds border a cell outside the mesh."""

    def __init__(self, pts, guards, status, merge_chord):
        self.allp = np.vstack([pts, guards])
        self.verts, self.offsets, self.index = voronoi_cells(self.allp, merge_chord=merge_chord)
        n = len(pts)
        self.free = status == FREE_KIND
        rows = np.flatnonzero(self.free)
        off, idx = csr_take(self.offsets, self.index, rows)
        self.area = np.full(n, np.nan)
        self.area[rows] = spherical_polygon_areas(off, self.verts[idx])
        pairs, edge = cell_pairs(self.offsets, self.index, edges=True)
        out = np.concatenate([(status == OUTSIDE) | (status == REMOVED),
                              np.ones(len(guards), dtype=bool)])
        touch = np.zeros(len(self.allp), dtype=bool)
        for a, b in (pairs[:, 0], pairs[:, 1]), (pairs[:, 1], pairs[:, 0]):
            touch[a[out[b]]] = True
        self.touches_out = touch[:n]
        inner = (pairs[:, 0] < n) & (pairs[:, 1] < n)
        self.pairs = pairs[inner]
        self.edge_length = np.linalg.norm(self.verts[edge[inner, 0]] - self.verts[edge[inner, 1]],
                                          axis=1)

    def median(self) -> float:
        return float(np.median(self.area[self.free]))

    def smallest(self) -> float:
        """The smallest free cell's share of the median free-cell area [1]."""
        return float(np.nanmin(self.area) / self.median()) if self.free.any() else float("nan")

    def neighbours_of(self, mask: np.ndarray) -> np.ndarray:
        """Seeds sharing an edge with a seed of ``mask``."""
        out = np.zeros(len(mask), dtype=bool)
        p = self.pairs
        for a, b in (p[:, 0], p[:, 1]), (p[:, 1], p[:, 0]):
            out[b[mask[a]]] = True
        return out

    def centroids(self, rows: np.ndarray) -> np.ndarray:
        """Centroids of the cells ``rows`` on the sphere (triangles seed-vertex-vertex)."""
        off, idx = csr_take(self.offsets, self.index, rows)
        cell = np.repeat(np.arange(len(rows)), np.diff(off))
        s = self.allp[rows][cell]
        a, b = self.verts[idx], self.verts[idx[next_index(off)]]
        w = np.linalg.norm(np.cross(a - s, b - s), axis=1)
        c = np.zeros((len(rows), 3))
        np.add.at(c, cell, w[:, None] * (s + a + b))
        return unit_rows(c)

    def pushes(self, small: np.ndarray, movable: np.ndarray, target: float) -> np.ndarray:
        """Displacements (unit sphere, ``(n, 3)``) of the movable seeds next to the small cells
        that move their shared edges out far enough to give each small cell the area
        ``target``: the missing area over the length of the edges that can move is the shift
        of those edges, a seed moving twice as far straight away from the small cell's seed
        (at most a fifth of their distance)."""
        n = len(small)
        out = np.zeros((n, 3))
        p, L = self.pairs, self.edge_length
        for a, b in (p[:, 0], p[:, 1]), (p[:, 1], p[:, 0]):
            sel = small[a] & movable[b] & ~small[b]
            room = np.bincount(a[sel], weights=L[sel], minlength=n)
            i, j = a[sel], b[sel]
            h = (target - self.area[i]) / room[i]
            u = self.allp[j] - self.allp[i]
            dist = np.linalg.norm(u, axis=1)
            step = np.minimum(2.0 * h, 0.2 * dist) / dist
            np.add.at(out, j, step[:, None] * u)
        return out

    def status_of(self, rows: np.ndarray, status_fn: Callable) -> np.ndarray:
        return status_fn(rows, self.allp, self.verts, self.offsets, self.index)


class _Seeds:
    """The seeds during relaxation: positions, the input seed each was (``-1``: merged), the
    status of its cell, whether it may no longer move, and a serial number per merged seed
    (``tag``) so that a merge can be undone."""

    def __init__(self, pts, status):
        self.pts = np.array(pts, dtype=float)
        self.origin = np.arange(len(pts))
        self.status = np.asarray(status, dtype=np.int8).copy()
        self.frozen = np.zeros(len(pts), dtype=bool)
        self.tag = np.full(len(pts), -1)
        self.serial = 0

    def _take(self, keep, pts, origin, status, frozen, tag) -> None:
        self.pts = np.vstack([self.pts[keep], pts])
        self.origin = np.concatenate([self.origin[keep], origin])
        self.status = np.concatenate([self.status[keep], status]).astype(np.int8)
        self.frozen = np.concatenate([self.frozen[keep], frozen])
        self.tag = np.concatenate([self.tag[keep], tag])

    def merge(self, gone: list, born: np.ndarray) -> list:
        """The seeds ``gone`` (pairs, in order) become the seeds ``born`` (one a pair); returns,
        per merge, ``(tag, the two seeds' positions, origins, statuses, tags)``."""
        n = len(born)
        undo = []
        for k in range(n):
            ij = [gone[2 * k], gone[2 * k + 1]]
            undo.append((self.serial + k, self.pts[ij].copy(), self.origin[ij].copy(),
                         self.status[ij].copy(), self.tag[ij].copy()))
        keep = np.ones(len(self.pts), dtype=bool)
        keep[gone] = False
        self._take(keep, born, np.full(n, -1), np.full(n, FREE_KIND), np.zeros(n, dtype=bool),
                   self.serial + np.arange(n))
        self.serial += n
        return undo

    def index_of(self, tag: int) -> int:
        return int(np.flatnonzero(self.tag == tag)[0])

    def unmerge(self, u) -> None:
        """Undo one merge: the merged seed goes, the two seeds come back, frozen."""
        keep = np.arange(len(self.pts)) != self.index_of(u[0])
        self._take(keep, u[1], u[2], u[3], np.ones(2, dtype=bool), u[4])


def relax_small_cells(pts: np.ndarray, guards: np.ndarray, status: np.ndarray, share: float,
                      merge_chord: float, status_fn: Callable, reach: float,
                      rounds: int = ROUNDS):
    """Move the seeds ``pts (n, 3)`` (unit vectors) until every free cell has at least
    ``share`` [1] of the median free-cell area, in at most ``rounds`` rounds (see the module
    docstring).

    ``status``: per seed, the kind of its cell (0 ice, that is free; 1 coast; 2 landfast),
    :data:`REMOVED` or :data:`OUTSIDE`; ``status_fn(rows, allp, verts, offsets, index)`` the
    same for the cells ``rows`` of a Voronoi diagram (seeds and guards ``allp``, CSR cells);
    ``merge_chord``: the vertex merging chord of :func:`~siku_io.mesh.voronoi.voronoi_cells`;
    ``reach``: a chord (unit sphere) beyond which a merge changes no cell.

    Returns ``(pts, origin, status, info)``: the new seeds, for each the index of the input
    seed it was (``-1`` for a merged seed, which is free), their statuses, and ``info`` with
    ``moved`` (input seeds that moved and stayed), ``merged`` (pairs merged into one seed),
    ``rounds``, ``before`` and ``after`` (the smallest free cell's share of the median [1]),
    ``reached``, ``below`` (free cells still below the share) and ``at_edge`` (those of them
    bordering a cell outside the mesh, whose seeds never move).
    """
    start = np.array(pts, dtype=float)
    s = _Seeds(start, status)
    merged = 0

    def diagram():
        return _Diagram(s.pts, guards, s.status, merge_chord)

    d = diagram()
    before = d.smallest()
    done = 0
    merging = False
    while done < rounds:
        small = d.free & (d.area < share * d.median())
        if not small.any():
            break
        done += 1
        n_merged = 0
        merging = merging or done > LLOYD_ROUNDS
        if merging:
            n_merged, d = _merge(d, s, small, diagram, status_fn, reach)
            merged += n_merged
            small = d.free & (d.area < share * d.median())
        movable = d.free & ~s.frozen & ~d.touches_out
        push = d.pushes(small, movable, share * d.median() * (1.0 + MARGIN))
        grow = np.flatnonzero(movable & small)
        active = np.flatnonzero((movable & small) | np.any(push != 0.0, axis=1))
        old = s.pts[active].copy()
        d_old = d
        s.pts[grow] = d.centroids(grow)
        s.pts[active] = unit_rows(s.pts[active] + push[active])
        d = diagram()
        while len(active):  # moves that change a cell's kind or reach outside: undone
            moved = np.zeros(len(s.pts), dtype=bool)
            moved[active] = True
            near = moved | d.neighbours_of(moved) | d_old.neighbours_of(moved)
            rows = np.flatnonzero(near & (s.status >= 0) & (s.status != REMOVED))
            changed = np.zeros(len(s.pts), dtype=bool)
            changed[rows] = d.status_of(rows, status_fn) != s.status[rows]
            blame = changed | d.neighbours_of(changed) | d_old.neighbours_of(changed)
            bad = blame[active] | d.touches_out[active]
            if not bad.any():
                break
            s.pts[active[bad]] = old[bad]
            s.frozen[active[bad]] = True
            active, old = active[~bad], old[~bad]
            d = diagram()
        s.frozen[:] = False  # a seed whose move was undone may move again next round
        if not len(active) and not n_merged:  # nothing moved: merge, or stop (the next
            if merging:                        # round would be this one again)
                break
            merging = True
    after = d.smallest()
    below = d.free & (d.area < share * d.median())
    kept = s.origin >= 0
    moved_n = int(np.sum(np.any(s.pts[kept] != start[s.origin[kept]], axis=1)))
    return s.pts, s.origin, s.status, {
        "moved": moved_n, "merged": merged, "rounds": done, "before": before,
        "after": after, "reached": not below.any(), "below": int(below.sum()),
        "at_edge": int(np.sum(below & d.touches_out))}


def _merge(d: _Diagram, s: _Seeds, small: np.ndarray, diagram: Callable,
           status_fn: Callable, reach: float):
    """Merge each small movable cell (smallest first) with its nearest movable free neighbour
    (neither merged yet this round): both seeds become one at their midpoint. Merges that
    change a cell's kind or reach outside the mesh are undone. Returns the number of merges
    kept and the diagram after them."""
    movable = d.free & ~s.frozen & ~d.touches_out
    used = np.zeros(len(s.pts), dtype=bool)
    pairs = d.pairs[movable[d.pairs[:, 0]] & movable[d.pairs[:, 1]]]
    both = np.concatenate([pairs, pairs[:, ::-1]])
    gone, born = [], []
    for i in np.flatnonzero(small & movable)[np.argsort(d.area[small & movable],
                                                        kind="stable")]:
        if used[i]:
            continue
        nb = both[both[:, 0] == i, 1]
        nb = nb[~used[nb]]
        if not len(nb):
            continue
        j = int(nb[np.argmin(np.linalg.norm(s.pts[nb] - s.pts[i], axis=1))])
        used[[i, j]] = True
        gone += [int(i), j]
        born.append(unit_rows(s.pts[i] + s.pts[j]))
    if not born:
        return 0, d
    undo = s.merge(gone, np.array(born))
    d = diagram()
    while undo:
        tags = np.array([u[0] for u in undo])
        at = np.array([s.index_of(t) for t in tags])
        tree = cKDTree(s.pts[at])
        near = np.isfinite(tree.query(s.pts, distance_upper_bound=reach)[0])
        rows = np.flatnonzero(near & (s.status >= 0) & (s.status != REMOVED))
        changed_rows = rows[d.status_of(rows, status_fn) != s.status[rows]]
        bad = set(np.flatnonzero(d.touches_out[at]).tolist())
        if len(changed_rows):
            for hit in tree.query_ball_point(s.pts[changed_rows], reach):
                bad.update(hit)
        if not bad:
            break
        for k in sorted(bad, reverse=True):
            s.unmerge(undo[k])
            del undo[k]
        d = diagram()
    return len(undo), d
