"""The MPI wrapper of the ranks driver: the few collective operations it uses, on numpy
records, and the end of a run on every rank when one fails.

Only this module imports ``mpi4py``; the driver names MPI nowhere else. Records are dicts of
numpy arrays sent as Python objects (``mpi4py``'s pickling): the driver's messages are few
per step and their arrays contiguous.
"""
from __future__ import annotations

import sys
from typing import Any

import numpy as np

from ..errors import SikuError


def mpi_available() -> bool:
    """Whether ``mpi4py`` can be imported (the ``siku[mpi]`` extra)."""
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        return False
    return True


class Comm:
    """The ranks of one run (``MPI.COMM_WORLD`` by default)."""

    def __init__(self, comm: Any = None):
        try:
            from mpi4py import MPI
        except ImportError:
            raise SikuError("running on ranks needs mpi4py: pip install 'siku[mpi]'") from None
        self.MPI = MPI
        self.comm = comm if comm is not None else MPI.COMM_WORLD
        self.rank = self.comm.Get_rank()
        self.size = self.comm.Get_size()
        #: bytes this rank sent in exchanges (ghost updates), for ``bench.ranks``
        self.sent_bytes = 0
        from .launch import note_pid

        note_pid(self.rank)

    def allgather(self, obj: Any) -> list[Any]:
        return self.comm.allgather(obj)

    def gather(self, obj: Any) -> list[Any] | None:
        """Every rank's ``obj`` on rank 0 (``None`` elsewhere)."""
        return self.comm.gather(obj, root=0)

    def bcast(self, obj: Any) -> Any:
        return self.comm.bcast(obj, root=0)

    def alltoall(self, objs: list[Any]) -> list[Any]:
        """``objs[r]`` to rank ``r``; returns what each rank sent here, by rank."""
        self.sent_bytes += sum(_nbytes(o) for k, o in enumerate(objs) if k != self.rank)
        return self.comm.alltoall(objs)

    def max(self, values: np.ndarray) -> np.ndarray:
        """Element-wise maximum of ``values`` (float64) over the ranks."""
        out = np.empty_like(values)
        self.comm.Allreduce(np.ascontiguousarray(values), out, op=self.MPI.MAX)
        return out

    def barrier(self) -> None:
        self.comm.Barrier()

    def abort(self, line: str, code: int = 2) -> None:
        """Print ``line`` on stderr and end every rank of the run (``MPI_Abort``)."""
        from .launch import note_abort

        print(line, file=sys.__stderr__, flush=True)  # (not a rank's muted stderr)
        note_abort()
        self.comm.Abort(code)


def _nbytes(obj: Any) -> int:
    if isinstance(obj, np.ndarray):
        return obj.nbytes
    if isinstance(obj, dict):
        return sum(_nbytes(v) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return sum(_nbytes(v) for v in obj)
    return 8
