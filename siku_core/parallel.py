"""How the engine's compiled loops share work between numba threads.

Loops over elements or contacts run as ``prange`` over ``nch`` equal chunks
(:func:`chunk_bounds`); each chunk allocates its scratch space once and writes only its own
items, so the result never depends on ``nch`` or on the number of threads. :func:`chunks`
picks ``nch``: 1 (no threads started) for small loops or one thread, else a few chunks per
thread. ``numba.set_num_threads`` (or ``siku run --threads``) sets the threads.
"""
from __future__ import annotations

import numba
from numba import njit

#: items below which a loop runs on the calling thread: starting threads costs more
PARALLEL_MIN = 2048
#: smallest chunk worth a task [items]
CHUNK_MIN = 512


def threads() -> int:
    """The numba threads loops may use now."""
    return numba.get_num_threads()


def chunks(n: int) -> int:
    """Number of chunks for a parallel loop over ``n`` items with the current numba threads."""
    threads = globals()["threads"]()
    if threads <= 1 or n < PARALLEL_MIN:
        return 1
    return max(1, min(4 * threads, n // CHUNK_MIN))


def sum_chunks(n: int) -> int:
    """Number of chunks for a parallel *reduction* over ``n`` items (partial sums per chunk,
    added in chunk order): a function of ``n`` alone, so that sums come out the same, bit for
    bit, on any number of threads."""
    if n < PARALLEL_MIN:
        return 1
    return max(1, min(64, n // CHUNK_MIN))


@njit(cache=True, inline="always")
def chunk_bounds(c, nch, n):
    """Range ``[lo, hi)`` of chunk ``c`` of ``nch`` equal chunks of ``range(n)``."""
    return (c * n) // nch, ((c + 1) * n) // nch
