"""Broad-phase contact candidate kernels on unit vectors (numba, ``cache=True``).

docs/explanation/physics.md section 4.1. Every element has a bounding circle on the unit sphere; a
pair of elements is a candidate for the narrow phase when their bounding circles, grown by a skin,
meet.

Inputs (common to all kernels)
------------------------------
centers : float64 ``(N, 3)``
    Element centres as unit vectors in the global Earth-fixed frame (``quat.centers``).
radii : float64 ``(N,)``
    Bounding-circle radii as angles, radians (bounding radius in m / planet radius in m).
skin : float
    Skin distance, radians, ``>= 0`` (candidate lists reused between steps).
skip : bool ``(N,)``
    ``True`` for static elements: a pair of two such elements is never reported.

Candidate rule
--------------
A pair ``(i, j)``, ``i < j``, is a candidate when the great-circle angle between the centres is
at most ``radii[i] + radii[j] + skin`` (``<=``; the sum is clamped at ``pi``, beyond which every
pair qualifies). The test uses chord lengths, ``|c_i - c_j| <= 2 sin(theta / 2)``, with
``sin(theta / 2)`` built from per-element sines and cosines of ``rho = radius + skin / 2``
(angle-sum formula), so no trigonometric function is evaluated per pair. A relative slack of
``1e-12`` on the squared chord makes a pair lying exactly on the threshold (up to round-off)
count; a broad phase may report a few more pairs, never fewer.

Output: int64 ``(K, 2)`` with ``i < j`` in each row, rows sorted lexicographically, so the three
methods (``brute_force_pairs``, the reference; ``sweep_and_prune_pairs``; ``cell_grid_pairs``)
return identical arrays: all of them apply the same pair test after a conservative prefilter.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Relative slack on the squared chord of the pair test.
CHORD2_SLACK = 1e-12
# Prefilter padding (relative and absolute, unit-sphere lengths): keeps the prefilters of the
# sweep and the grid conservative against round-off and the slack above.
_PAD_REL = 1e-9
_PAD_ABS = 1e-12


@njit(cache=True)
def _prepare(radii, skin):
    """Per element: ``rho = r + skin/2`` (rad), ``sin(rho/2)``, ``cos(rho/2)`` and a padded chord
    radius ``w >= 2 sin(min(rho, pi)/2)`` (unit-sphere length)."""
    n = radii.shape[0]
    rho = np.empty(n)
    s = np.empty(n)
    c = np.empty(n)
    w = np.empty(n)
    half_skin = 0.5 * skin
    for i in range(n):
        r = radii[i] + half_skin
        rho[i] = r
        h = 0.5 * min(max(r, 0.0), math.pi)
        s[i] = math.sin(h)
        c[i] = math.cos(h)
        w[i] = 2.0 * s[i] * (1.0 + _PAD_REL) + _PAD_ABS
    return rho, s, c, w


@njit(cache=True, inline="always")
def _is_candidate(centers, rho, s, c, i, j):
    """The pair test: great-circle angle ``<= rho_i + rho_j`` (clamped at ``pi``), via chords."""
    if rho[i] + rho[j] >= math.pi:
        return True
    # 2 sin((rho_i + rho_j)/2), both halves in [0, pi/2)
    t = 2.0 * (s[i] * c[j] + c[i] * s[j])
    dx = centers[i, 0] - centers[j, 0]
    dy = centers[i, 1] - centers[j, 1]
    dz = centers[i, 2] - centers[j, 2]
    return dx * dx + dy * dy + dz * dz <= t * t * (1.0 + CHORD2_SLACK)


@njit(cache=True)
def _push(buf, k, i, j):
    """Append pair ``(min, max)`` to the growable buffer; returns the (possibly new) buffer."""
    if k >= buf.shape[0]:
        nb = np.empty((2 * buf.shape[0] + 16, 2), dtype=np.int64)
        for a in range(k):
            nb[a, 0] = buf[a, 0]
            nb[a, 1] = buf[a, 1]
        buf = nb
    if i < j:
        buf[k, 0] = i
        buf[k, 1] = j
    else:
        buf[k, 0] = j
        buf[k, 1] = i
    return buf


@njit(cache=True)
def _sorted_pairs(buf, k, n):
    """The first ``k`` pairs ``(i < j < n)`` of ``buf`` as a fresh array, sorted
    lexicographically (counting sort on ``i``, insertion sort of each row's ``j``)."""
    count = np.zeros(n + 1, dtype=np.int64)
    for a in range(k):
        count[buf[a, 0] + 1] += 1
    for i in range(n):
        count[i + 1] += count[i]
    fill = count[:n].copy()
    out = np.empty((k, 2), dtype=np.int64)
    for a in range(k):
        i = buf[a, 0]
        pos = fill[i]
        fill[i] += 1
        out[pos, 0] = i
        out[pos, 1] = buf[a, 1]
    for i in range(n):
        for a in range(count[i] + 1, count[i + 1]):
            v = out[a, 1]
            b = a - 1
            while b >= count[i] and out[b, 1] > v:
                out[b + 1, 1] = out[b, 1]
                b -= 1
            out[b + 1, 1] = v
    return out


@njit(cache=True, inline="always")
def _before(a, i, j):
    """Heap order: ``a[i]`` before ``a[j]``, ties broken by index."""
    return a[i] < a[j] or (a[i] == a[j] and i < j)


@njit(cache=True)
def _sift(a, idx, root, end):
    """Sift ``idx[root]`` down the max-heap ``idx[:end]`` ordered by ``_before``."""
    while True:
        ch = 2 * root + 1
        if ch >= end:
            return
        if ch + 1 < end and _before(a, idx[ch], idx[ch + 1]):
            ch += 1
        if _before(a, idx[root], idx[ch]):
            t = idx[root]
            idx[root] = idx[ch]
            idx[ch] = t
            root = ch
        else:
            return


@njit(cache=True)
def _argsort(a):
    """Indices sorting ``a`` ascending, ties by index (heapsort: deterministic, cheap to
    compile)."""
    n = a.shape[0]
    idx = np.arange(n)
    for start in range(n // 2 - 1, -1, -1):
        _sift(a, idx, start, n)
    for end in range(n - 1, 0, -1):
        t = idx[0]
        idx[0] = idx[end]
        idx[end] = t
        _sift(a, idx, 0, end)
    return idx


@njit(cache=True)
def _find(sorted_keys, key):
    """Index of ``key`` in the ascending array ``sorted_keys``, or -1 (binary search)."""
    lo = 0
    hi = sorted_keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if sorted_keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    if lo < sorted_keys.shape[0] and sorted_keys[lo] == key:
        return lo
    return -1


@njit(cache=True)
def brute_force_pairs(centers, radii, skin, skip):
    """All candidate pairs by testing every pair, O(N²): the reference (see module docstring).

    Returns int64 ``(K, 2)``, ``i < j``, sorted lexicographically.
    """
    n = centers.shape[0]
    rho, s, c, _ = _prepare(radii, skin)
    buf = np.empty((max(16, 4 * n), 2), dtype=np.int64)
    k = 0
    for i in range(n):
        for j in range(i + 1, n):
            if skip[i] and skip[j]:
                continue
            if _is_candidate(centers, rho, s, c, i, j):
                buf = _push(buf, k, i, j)
                k += 1
    out = np.empty((k, 2), dtype=np.int64)
    for a in range(k):
        out[a, 0] = buf[a, 0]
        out[a, 1] = buf[a, 1]
    return out


@njit(cache=True)
def sweep_and_prune_pairs(centers, radii, skin, skip, axis=0):
    """Candidate pairs by sweep and prune on one global axis (the Siku report's method).

    Each bounding circle projects onto the global ``axis`` (0 = x as in the report, 1 = y,
    2 = z; -1 picks the axis along which the centres spread most) as the interval
    ``centre ± w`` with ``w = 2 sin(rho/2)`` its chord radius (a point within angle ``rho`` of the
    centre is within that chord, hence within ``w`` along any axis). Intervals are sorted by
    their start and swept; overlapping intervals are then checked with the true pair test.
    O(N log N + number of overlapping intervals); returns int64 ``(K, 2)``, ``i < j``, sorted.
    """
    n = centers.shape[0]
    rho, s, c, w = _prepare(radii, skin)
    ax = axis
    if ax < 0:
        best = -1.0
        ax = 0
        for d in range(3):
            if n == 0:
                break
            mean = 0.0
            for i in range(n):
                mean += centers[i, d]
            mean /= n
            var = 0.0
            for i in range(n):
                var += (centers[i, d] - mean) ** 2
            if var > best:
                best = var
                ax = d
    if ax > 2:
        raise ValueError("sweep_and_prune_pairs: axis must be 0, 1, 2 or -1")
    lo = np.empty(n)
    hi = np.empty(n)
    for i in range(n):
        lo[i] = centers[i, ax] - w[i]
        hi[i] = centers[i, ax] + w[i]
    order = _argsort(lo)
    buf = np.empty((max(16, 4 * n), 2), dtype=np.int64)
    k = 0
    for a in range(n):
        i = order[a]
        hi_i = hi[i]
        for b in range(a + 1, n):
            j = order[b]
            if lo[j] > hi_i:
                break
            if skip[i] and skip[j]:
                continue
            if _is_candidate(centers, rho, s, c, i, j):
                buf = _push(buf, k, i, j)
                k += 1
    return _sorted_pairs(buf, k, max(n, 1))


@njit(cache=True)
def cell_grid_pairs(centers, radii, skin, skip):
    """Candidate pairs from a uniform 3-D cell grid (spatial hash) over the unit vectors.

    The cube ``[-1, 1]³`` holding the unit sphere is cut into cubic cells of edge
    ``h >= max_i 2 w_i`` (the largest possible pair chord; ``w`` the padded chord radius), at
    most ``2**20`` cells per axis. Two elements within a pair's threshold chord lie in the same
    or in adjacent cells, so only the 27 neighbouring cells are checked. The grid is a sorted
    list of cell keys (no dense array): memory O(N), time O(N log N + candidates). Working in
    3-D Cartesian coordinates, it has no trouble at the poles or the antimeridian.
    Returns int64 ``(K, 2)``, ``i < j``, sorted lexicographically.

    It stays one function: one compiled pass over the cells, and splitting it would cost numba's
    inlining of the inner loops.
    """
    n = centers.shape[0]
    rho, s, c, w = _prepare(radii, skin)
    if n < 2:
        return np.empty((0, 2), dtype=np.int64)
    wmax = 0.0
    for i in range(n):
        wmax = max(wmax, w[i])
    h = max(2.0 * wmax * (1.0 + _PAD_REL), 2.0 / 2.0**20)
    ncell = math.floor(2.0 / h) + 1
    inv_h = 1.0 / h
    cell = np.empty((n, 3), dtype=np.int64)
    keys = np.empty(n, dtype=np.int64)
    for i in range(n):
        for d in range(3):
            v = math.floor((centers[i, d] + 1.0) * inv_h)
            cell[i, d] = min(max(v, 0), ncell - 1)
        keys[i] = (cell[i, 0] * ncell + cell[i, 1]) * ncell + cell[i, 2]
    order = _argsort(keys)
    skeys = keys[order]
    # runs of equal keys: ukeys[r], elements order[start[r]:start[r + 1]]
    nrun = 1
    for a in range(1, n):
        if skeys[a] != skeys[a - 1]:
            nrun += 1
    ukeys = np.empty(nrun, dtype=np.int64)
    start = np.empty(nrun + 1, dtype=np.int64)
    r = 0
    ukeys[0] = skeys[0]
    start[0] = 0
    for a in range(1, n):
        if skeys[a] != skeys[a - 1]:
            r += 1
            ukeys[r] = skeys[a]
            start[r] = a
    start[nrun] = n

    buf = np.empty((max(16, 4 * n), 2), dtype=np.int64)
    k = 0
    for r in range(nrun):
        first = order[start[r]]
        cx = cell[first, 0]
        cy = cell[first, 1]
        cz = cell[first, 2]
        for ox in range(-1, 2):
            gx = cx + ox
            if gx < 0 or gx >= ncell:
                continue
            for oy in range(-1, 2):
                gy = cy + oy
                if gy < 0 or gy >= ncell:
                    continue
                for oz in range(-1, 2):
                    gz = cz + oz
                    if gz < 0 or gz >= ncell:
                        continue
                    key = (gx * ncell + gy) * ncell + gz
                    r2 = _find(ukeys, key)
                    if r2 < 0:
                        continue
                    for a in range(start[r], start[r + 1]):
                        i = order[a]
                        for b in range(start[r2], start[r2 + 1]):
                            j = order[b]
                            if j <= i:
                                continue
                            if skip[i] and skip[j]:
                                continue
                            if _is_candidate(centers, rho, s, c, i, j):
                                buf = _push(buf, k, i, j)
                                k += 1
    return _sorted_pairs(buf, k, n)
