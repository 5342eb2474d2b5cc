"""Recursive coordinate bisection of element centres on the sphere.

The centres are unit vectors (x, y, z); a set of elements shared by ``k`` ranks is cut by a
plane normal to the axis along which the set spreads most, at the weighted median that gives
each side its share of the ranks (``k // 2`` and ``k - k // 2``), and each side is cut again.
The cuts form a tree (:class:`Cuts`) that assigns any centre to a rank: an element that drifts
across a cut changes owner at the next redistribution. Deterministic: ties in a coordinate are
broken by element index, and the weights are only summed in index order.

Where the elements are owned changes the work per rank, never the results
(``siku_core.ranks.driver``): a decomposition may follow measured costs freely.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Cuts:
    """A bisection tree: a leaf is a rank; a node cuts along ``axis`` at ``value``, centres
    below it go to ``lo``, the others to ``hi``."""

    rank: int = -1
    axis: int = 0
    value: float = 0.0
    lo: "Cuts | None" = None
    hi: "Cuts | None" = None
    #: (for bench.ranks and tests) how many leaves
    leaves: int = field(default=1)

    def assign(self, c: np.ndarray) -> np.ndarray:
        """The rank of each centre ``c`` (``(n, 3)`` unit vectors)."""
        out = np.empty(len(c), dtype=np.int64)
        self._assign(c, np.arange(len(c)), out)
        return out

    def _assign(self, c: np.ndarray, idx: np.ndarray, out: np.ndarray) -> None:
        if self.lo is None or self.hi is None:
            out[idx] = self.rank
            return
        below = c[idx, self.axis] < self.value
        self.lo._assign(c, idx[below], out)
        self.hi._assign(c, idx[~below], out)


def bisect(c: np.ndarray, weights: np.ndarray, ranks: int) -> Cuts:
    """The cuts that split centres ``c`` (``(n, 3)``) into ``ranks`` parts of about equal
    total ``weights`` (per element, > 0: its cost)."""
    return _bisect(np.asarray(c, float), np.asarray(weights, float), np.arange(len(c)), 0, ranks)


def _bisect(c: np.ndarray, w: np.ndarray, idx: np.ndarray, first: int, k: int) -> Cuts:
    if k == 1 or len(idx) == 0:
        if k == 1:
            return Cuts(rank=first)
        # no elements left for these ranks: every centre goes to the first of them
        return Cuts(rank=first, leaves=k)
    sub = c[idx]
    spread = sub.max(axis=0) - sub.min(axis=0)
    axis = int(np.argmax(spread))
    order = np.lexsort((idx, sub[:, axis]))  # by coordinate, ties by element index
    cum = np.cumsum(w[idx[order]])
    klo = k // 2
    share = cum[-1] * klo / k
    m = int(np.searchsorted(cum, share, side="left")) + 1  # elements on the low side
    m = min(max(m, 1), len(idx) - 1) if len(idx) > 1 else len(idx)
    coords = sub[order, axis]
    if m >= len(idx):
        value = np.inf
    else:
        value = 0.5 * (coords[m - 1] + coords[m])
        if value <= coords[m - 1]:  # equal coordinates across the cut: move it above them
            value = np.nextafter(coords[m - 1], np.inf)
    below = c[idx, axis] < value
    return Cuts(axis=axis, value=float(value),
                lo=_bisect(c, w, idx[below], first, klo),
                hi=_bisect(c, w, idx[~below], first + klo, k - klo), leaves=k)


def imbalance(work: np.ndarray) -> float:
    """The slowest rank's work over the mean, minus one (0: balanced)."""
    work = np.asarray(work, float)
    mean = float(work.mean()) if len(work) else 0.0
    return float(work.max() / mean - 1.0) if mean > 0 else 0.0


__all__ = ["Cuts", "bisect", "imbalance"]
