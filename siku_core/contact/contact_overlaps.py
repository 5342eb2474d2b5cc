"""The overlaps of the colliding pairs of the current state, for components that act on them
outside the force evaluation (the ridging process): overlap area [m²] and contact width [m] by
the same clip as the contact loop, and the force each pair carried in the last evaluation."""
from __future__ import annotations

import numpy as np
from numba import njit

from .contact_frames import overlap_width, j_to_i, relative_matrix
from ..geometry.clip import make_overlap_scratch, overlap_inline


@njit(cache=True, inline="always")
def _clip_pair(rm, offsets, verts, pair, R, inv_r, proj, xy, tag):
    """Element ``i``'s outline, ``j``'s projected into ``i``'s frame (in ``proj``), ``j``'s
    centre there and the contact loop's clip of the two, for ``pair = (i, j)`` [m, m²]."""
    i = pair[0]
    j = pair[1]
    M = relative_matrix(rm, i, j)
    oj = offsets[j]
    nj = offsets[j + 1] - oj
    for v in range(nj):
        proj[v, 0], proj[v, 1] = j_to_i(M, verts[oj + v, 0], verts[oj + v, 1], R, inv_r)
    pi = verts[offsets[i]:offsets[i + 1]]
    pj = proj[:nj]
    c2x, c2y = j_to_i(M, 0.0, 0.0, R, inv_r)
    area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = overlap_inline(pi, pj, xy, tag, c2x, c2y,
                                                                       False)
    return pi, pj, c2x, c2y, area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny


@njit(cache=True)
def pair_overlaps(rm, offsets, verts, pairs, ks, R, nmax):
    """Per candidate pair ``pairs[ks[a]]``: overlap area [m²] and contact width [m] for the
    rotation matrices ``rm`` of the state (``(len(ks), 2)``; 0 where they do not overlap)."""
    xy, tag = make_overlap_scratch(nmax, nmax)
    proj = np.empty((nmax, 2))
    out = np.zeros((ks.shape[0], 2))
    inv_r = 1.0 / R
    for a in range(ks.shape[0]):
        pi, pj, c2x, c2y, area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = _clip_pair(
            rm, offsets, verts, pairs[ks[a]], R, inv_r, proj, xy, tag)
        if area > 0.0:
            out[a, 0] = area
            out[a, 1] = overlap_width(pi, pj, area, ncross, p1x, p1y, p2x, p2y, nx, ny)
    return out


@njit(cache=True)
def pair_contact_lines(rm, offsets, verts, pairs, ks, R, nmax):
    """Per candidate pair ``pairs[ks[a]]``: the line along which its two elements touch, in
    ``i``'s frame [m] ``(len(ks), 2, 2)``, running counter-clockwise round ``i`` (its normal
    ``(dy, -dx)`` points towards ``j``'s centre); zero where they do not overlap. It is the
    chord between the two crossings of the boundaries where there are two, else the contact
    width (``overlap_width``) across the overlap's normal through its centroid: the line a joint
    made of the contact is frozen along."""
    xy, tag = make_overlap_scratch(nmax, nmax)
    proj = np.empty((nmax, 2))
    out = np.zeros((ks.shape[0], 2, 2))
    inv_r = 1.0 / R
    for a in range(ks.shape[0]):
        pi, pj, c2x, c2y, area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = _clip_pair(
            rm, offsets, verts, pairs[ks[a]], R, inv_r, proj, xy, tag)
        if not area > 0.0:
            continue
        if ncross != 2:
            h = 0.5 * overlap_width(pi, pj, area, ncross, p1x, p1y, p2x, p2y, nx, ny)
            p1x, p1y = cx + h * ny, cy - h * nx
            p2x, p2y = cx - h * ny, cy + h * nx
        if (p2y - p1y) * c2x - (p2x - p1x) * c2y < 0.0:
            p1x, p1y, p2x, p2y = p2x, p2y, p1x, p1y
        out[a, 0, 0], out[a, 0, 1] = p1x, p1y
        out[a, 1, 0], out[a, 1, 1] = p2x, p2y
    return out


def contact_lines(cm, ks: np.ndarray) -> np.ndarray:
    """:func:`pair_contact_lines` of candidate pairs ``ks`` of contact model ``cm`` in the
    current state."""
    from .contact_frames import rotation_matrices
    from ..parallel import chunks

    st = cm.state
    rm = np.empty((st.n, 3, 3))
    rotation_matrices(st.q, rm, chunks(st.n))
    nmax = int(np.max(np.diff(st.vert_offsets)))
    return pair_contact_lines(rm, st.vert_offsets, st.verts, cm.pairs,
                              np.ascontiguousarray(ks, dtype=np.int64), float(cm.radius), nmax)


def overlaps(cm) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The colliding pairs of contact model ``cm`` (those that carried force in the last
    evaluation): ``(pairs (K, 2), area [m²], width [m], force [N])``, geometry of the current
    state, force magnitude of the last evaluation (the generalised force on ``i``: equal to the
    contact force to order (size / R)²)."""
    from .contact_frames import ROW_FIX, ROW_FIY, rotation_matrices
    from ..parallel import chunks

    ks = np.flatnonzero(cm.pair_active == 1) if len(cm.pair_active) == len(cm.pairs) else \
        np.zeros(0, np.int64)
    if not len(ks):
        z = np.zeros(0)
        return np.zeros((0, 2), np.int64), z, z, z
    st = cm.state
    rm = np.empty((st.n, 3, 3))
    rotation_matrices(st.q, rm, chunks(st.n))
    nmax = int(np.max(np.diff(st.vert_offsets)))
    got = pair_overlaps(rm, st.vert_offsets, st.verts, cm.pairs, ks, float(cm.radius), nmax)
    force = np.hypot(cm.pair_rows[ks, ROW_FIX], cm.pair_rows[ks, ROW_FIY])
    return cm.pairs[ks], got[:, 0], got[:, 1], force


__all__ = ["contact_lines", "overlaps", "pair_contact_lines", "pair_overlaps"]
