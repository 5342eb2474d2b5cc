"""Cells of a mesh: the spherical Voronoi diagram of its seeds as CSR polygons (stage 2)."""
from __future__ import annotations

import numpy as np
from scipy.spatial import SphericalVoronoi

from .merge import merge_vertices
from .sphere import unit_rows


# ---------------------------------------------------------------------------- voronoi
def voronoi_cells(points: np.ndarray, merge_chord: float = 0.0):
    """Spherical Voronoi cells of unit vectors ``points (n, 3)``.

    Returns ``(vertices (V, 3), offsets (n + 1,), index (M,))``: cell ``i`` is
    ``vertices[index[offsets[i]:offsets[i+1]]]``, counter-clockwise seen from outside the sphere.
    Vertices closer than ``merge_chord`` are merged (and repeated vertices dropped from cells).
    """
    sv = SphericalVoronoi(points, radius=1.0, center=np.zeros(3))
    sv.sort_vertices_of_regions()
    verts = unit_rows(np.asarray(sv.vertices, dtype=float))
    regions = sv.regions
    lens = np.fromiter((len(r) for r in regions), dtype=np.int64, count=len(regions))
    offsets = np.zeros(len(regions) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum(lens)
    index = np.fromiter((v for r in regions for v in r), dtype=np.int64, count=int(offsets[-1]))
    if merge_chord > 0:
        verts, offsets, index = merge_vertices(verts, offsets, index, merge_chord)
    # orientation: counter-clockwise seen from outside, i.e. (v_k x v_k+1) . seed > 0
    nxt = next_index(offsets)
    a, b = verts[index], verts[index[nxt]]
    seed_of = np.repeat(np.arange(len(regions)), np.diff(offsets))
    s = np.einsum("ij,ij->i", np.cross(a, b), points[seed_of])
    sign = np.add.reduceat(np.sign(s), offsets[:-1]) if len(index) else np.zeros(0)
    for i in np.flatnonzero(sign < 0):
        index[offsets[i]:offsets[i + 1]] = index[offsets[i]:offsets[i + 1]][::-1]
    return verts, offsets, index


def next_index(offsets: np.ndarray) -> np.ndarray:
    """For CSR cells, the position of the next vertex around each cell."""
    m = int(offsets[-1])
    nxt = np.arange(1, m + 1, dtype=np.int64)
    ends = offsets[1:] - 1
    nonempty = np.diff(offsets) > 0
    nxt[ends[nonempty]] = offsets[:-1][nonempty]
    return nxt


def cell_pairs(offsets: np.ndarray, vertex_id: np.ndarray, edges: bool = False):
    """Pairs ``(i, j)``, ``i < j``, of CSR cells sharing an edge (both its vertex ids); with
    ``edges``, also the two vertex ids of each pair's edge (cells that share one edge only,
    as Voronoi cells do)."""
    nxt = next_index(offsets)
    a, b = vertex_id, vertex_id[nxt]
    cell = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))
    key = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    k = key[order]
    same = np.all(k[1:] == k[:-1], axis=1)
    i = cell[order][:-1][same]
    j = cell[order][1:][same]
    if edges:
        return np.stack([np.minimum(i, j), np.maximum(i, j)], axis=1), k[:-1][same]
    return np.unique(np.sort(np.stack([i, j], axis=1), axis=1), axis=0)


def csr_take(offsets: np.ndarray, index: np.ndarray, rows: np.ndarray):
    """Rows ``rows`` of a CSR array: ``(offsets, values)``."""
    rows = np.asarray(rows, dtype=np.int64)
    lens = np.diff(offsets)[rows]
    off = np.zeros(len(rows) + 1, dtype=np.int64)
    off[1:] = np.cumsum(lens)
    pos = np.repeat(offsets[rows] - off[:-1], lens) + np.arange(off[-1])
    return off, index[pos]
