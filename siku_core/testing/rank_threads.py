"""The ranks of one run as threads of one process, for the checks that need the ranks'
collective calls without MPI (:func:`siku_core.testing.conformance.check_forcing_on_ranks`).

Each rank runs a function on a thread of its own, given a :class:`ThreadComm` in place of the
MPI wrapper (``siku_core.ranks.comm.Comm``: ``rank``, ``size``, ``allgather``, ``alltoall``,
what a :class:`~siku_core.ranks.local.RankLink` calls). One rank runs at a time: a rank hands
the turn on only inside a collective call, to the next rank in order, so numba's kernels are
never entered by two threads at once and every run takes the same course. A rank that raises
ends the other ranks' waits, as does a rank that ends without a collective call the others
make, or a wait longer than ``timeout``: :func:`run_ranks` then raises the first error.
"""
from __future__ import annotations

import threading
from typing import Any, Callable

#: an empty place of a collective call (a rank's ``None`` is a value)
_EMPTY = object()


class _Abandoned(Exception):
    """A rank's wait ended by another rank's error."""


class _Turns:
    """The ranks' turns and the values of their collective calls, call by call."""

    def __init__(self, size: int, timeout: float):
        self.size = size
        self.timeout = timeout
        self.cv = threading.Condition()
        self.turn = 0
        self.calls = [0] * size
        self.slots: dict[int, list[Any]] = {}
        self.done = [False] * size
        self.failed: BaseException | None = None

    def _wait(self, ready: Callable[[], bool], what: str) -> None:
        if not self.cv.wait_for(lambda: self.failed is not None or ready(),
                                timeout=self.timeout):
            self.failed = TimeoutError(f"a rank waited more than {self.timeout:g} s {what}")
            self.cv.notify_all()
        if self.failed is not None:
            raise _Abandoned

    def _hand_on(self, r: int) -> None:
        for k in range(1, self.size + 1):
            nxt = (r + k) % self.size
            if not self.done[nxt]:
                self.turn = nxt
                break
        self.cv.notify_all()

    def start(self, r: int) -> None:
        with self.cv:
            self._wait(lambda: self.turn == r, "for its turn")

    def exchange(self, r: int, obj: Any) -> list[Any]:
        """Every rank's ``obj`` of this collective call (rank ``r``'s ``k``-th), by rank."""
        with self.cv:
            k = self.calls[r]
            self.calls[r] += 1
            slot = self.slots.setdefault(k, [_EMPTY] * self.size)
            slot[r] = obj
            self._hand_on(r)

            def ready() -> bool:
                gone = [s for s in range(self.size) if self.done[s] and slot[s] is _EMPTY]
                if gone:
                    self.failed = RuntimeError(
                        f"rank {gone[0]} ended without collective call {k} of rank {r}: the "
                        "ranks must make the same collective calls, in the same order")
                    self.cv.notify_all()
                return self.turn == r and all(o is not _EMPTY for o in slot)
            self._wait(ready, f"in collective call {k}")
            return list(slot)

    def finish(self, r: int, exc: BaseException | None = None) -> None:
        with self.cv:
            self.done[r] = True
            if exc is not None and self.failed is None:
                self.failed = exc
            self._hand_on(r)


class ThreadComm:
    """Rank ``rank`` of ranks that are threads (the collective calls of the MPI wrapper)."""

    def __init__(self, turns: _Turns, rank: int):
        self._turns = turns
        self.rank = rank
        self.size = turns.size
        self.sent_bytes = 0

    def allgather(self, obj: Any) -> list[Any]:
        return self._turns.exchange(self.rank, obj)

    def alltoall(self, objs: list[Any]) -> list[Any]:
        """``objs[r]`` to rank ``r``; returns what each rank sent here, by rank."""
        got = self._turns.exchange(self.rank, list(objs))
        return [got[s][self.rank] for s in range(self.size)]


def run_ranks(fns: list[Callable[[ThreadComm], Any]], timeout: float = 600.0) -> list[Any]:
    """Run ``fns[r](comm)`` as rank ``r`` of ``len(fns)`` ranks (module docstring); their
    results, by rank. Raises the first error a rank raised (or a deadlock's, after
    ``timeout`` [s] in one wait)."""
    turns = _Turns(len(fns), timeout)
    results: list[Any] = [None] * len(fns)

    def main(r: int) -> None:
        try:
            turns.start(r)
            results[r] = fns[r](ThreadComm(turns, r))
        except _Abandoned:
            turns.finish(r)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller below
            turns.finish(r, exc)
        else:
            turns.finish(r)

    threads = [threading.Thread(target=main, args=(r,), name=f"rank {r}", daemon=True)
               for r in range(len(fns))]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    if turns.failed is not None:
        raise turns.failed
    return results


__all__ = ["ThreadComm", "run_ranks"]
