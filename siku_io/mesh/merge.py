"""Merging of Voronoi vertices closer than a tolerance, so that no edge is numerically zero."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .sphere import unit_rows

MERGE_SHARE = 1e-4  # Voronoi vertices closer than this share of the smallest spacing are merged


def merge_vertices(verts, offsets, index, tol):
    pairs = cKDTree(verts).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return verts, offsets, index
    parent = np.arange(len(verts))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    root = np.arange(len(verts))
    for x in np.unique(pairs):
        root[x] = find(x)
    sums = np.zeros_like(verts)
    np.add.at(sums, root, verts)
    verts = verts.copy()
    merged = np.unique(root[root != np.arange(len(verts))])
    verts[merged] = unit_rows(sums[merged])
    new_index = root[index]
    out, new_off = [], [0]
    for i in range(len(offsets) - 1):
        c = new_index[offsets[i]:offsets[i + 1]]
        if len(c):
            keep = c != np.roll(c, 1)
            if not keep.any():
                keep[0] = True
            c = c[keep]
        out.append(c)
        new_off.append(new_off[-1] + len(c))
    return verts, np.asarray(new_off, dtype=np.int64), np.concatenate(out).astype(np.int64)
