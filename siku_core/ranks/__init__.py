"""One scene on many MPI ranks: domain decomposition with ghost elements, the same bits as one
rank (``docs/explanation/scaling_out.md``).

Nothing here imports ``mpi4py`` until a run asks for ranks (:func:`launched_ranks` reads the
launcher's environment only): without it, or on one rank, a run is the plain
:class:`~siku_core.simulation.Simulation`. :mod:`.decompose` splits the elements by recursive
coordinate bisection, :mod:`.ghosts` finds the elements each rank must see, :mod:`.local`
builds a rank's engine over them, :mod:`.driver` steps it and exchanges, :mod:`.comm` wraps
MPI.
"""
from __future__ import annotations

import os

#: environment variables by which MPI launchers tell a process how many ranks it runs with
SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS", "PMIX_SIZE")


def launched_ranks(environ=None) -> int:
    """How many ranks the launcher started this process among (1: not under ``mpiexec``),
    from its environment alone (no import of ``mpi4py``)."""
    env = os.environ if environ is None else environ
    for name in SIZE_VARIABLES:
        value = env.get(name, "")
        if value.isdigit() and int(value) > 1:
            return int(value)
    return 1


__all__ = ["SIZE_VARIABLES", "launched_ranks"]
