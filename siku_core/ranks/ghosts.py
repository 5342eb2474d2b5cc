"""The elements each rank must see: its own and their ghosts.

A ghost of rank ``r`` is an element owned elsewhere that one of ``r``'s elements could touch
before the next redistribution: a partner of it in the broad phase's candidate pairs for the
current centres (contact reach plus the skin, the same reach and the same broad phase as the
engine's candidate list) or in a joint. The driver redistributes as soon as any element has
moved half the skin since (the engine's own rebuild rule), so every pair the engine would find
overlapping while the ghosts are current has both elements on the rank that owns either.

A process that reads the contacts may change an element from its pairs in an order that runs
through its partners' other pairs (``ridging``: a giver's open water, taken pair after pair);
with such a process the ranks hold a second layer (``depth = 2``), the partners of the ghosts,
so that every ghost next to an owned element has all of its contacts too.
"""
from __future__ import annotations

import numpy as np


def reach_pairs(model, c: np.ndarray) -> np.ndarray:
    """Candidate pairs ``(m, 2)`` of the contact ``model`` (a ``ContactModel`` over every
    element) for centres ``c``, with its reach and skin; melted elements touch nothing."""
    pairs = np.asarray(model.broad.pairs(c, model.radii, model.skip), dtype=np.int64)
    pairs = pairs.reshape(-1, 2)
    if model.gone is not None and len(pairs):
        pairs = pairs[~(model.gone[pairs[:, 0]] | model.gone[pairs[:, 1]])]
    return pairs


def local_sets(owner: np.ndarray, size: int, links: list[np.ndarray],
               depth: int = 1) -> list[np.ndarray]:
    """Per rank, the sorted element indices it holds: those it owns and every partner of
    them in ``links`` (arrays of pairs ``(m, 2)``: candidate pairs, joints), and with
    ``depth`` 2 or more, the partners of those again (``depth`` layers of ghosts)."""
    n = len(owner)
    out = []
    for r in range(size):
        need = owner == r
        for _ in range(depth):
            have = need.copy()
            for p in links:
                if len(p):
                    a, b = p[:, 0], p[:, 1]
                    need[b[have[a]]] = True
                    need[a[have[b]]] = True
        out.append(np.flatnonzero(need) if n else np.zeros(0, np.int64))
    return out


def exchange_plan(owner: np.ndarray, held: list[np.ndarray], rank: int
                  ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """What ``rank`` sends and receives each step: ``send[s]``, the elements it owns that rank
    ``s`` holds as ghosts, and ``recv[s]``, its ghosts that ``s`` owns (global indices,
    ascending: both sides agree on the order without a message)."""
    size = len(held)
    send = [np.zeros(0, np.int64)] * size
    recv = [np.zeros(0, np.int64)] * size
    mine = held[rank]
    for s in range(size):
        if s == rank:
            continue
        theirs = held[s]
        send[s] = theirs[owner[theirs] == rank]
        recv[s] = mine[owner[mine] == s]
    return send, recv


__all__ = ["exchange_plan", "local_sets", "reach_pairs"]
