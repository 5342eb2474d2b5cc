"""One scene on many MPI ranks: domain decomposition with ghost elements, the same bits as one
rank (``docs/explanation/scaling_out.md``).

Nothing here imports ``mpi4py`` until a run asks for ranks (:func:`launched_ranks` reads the
launcher's environment only): without it, or on one rank, a run is the plain
:class:`~siku_core.run.simulation.Simulation`. :mod:`.decompose` splits the elements by recursive
coordinate bisection, :mod:`.ghosts` finds the elements each rank must see, :mod:`.local`
builds a rank's engine over them, :mod:`.driver` steps it and exchanges, :mod:`.comm` wraps
MPI.
"""
from __future__ import annotations

import os

#: environment variables by which MPI launchers tell a process how many ranks it runs with
SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS", "PMIX_SIZE")
#: ... and which of them it is
RANK_VARIABLES = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "MPI_LOCALRANKID", "PMIX_RANK")


def launched_ranks(environ=None) -> int:
    """How many ranks the launcher started this process among (1: not under ``mpiexec``),
    from its environment alone (no import of ``mpi4py``)."""
    env = os.environ if environ is None else environ
    for name in SIZE_VARIABLES:
        value = env.get(name, "")
        if value.isdigit() and int(value) > 1:
            return int(value)
    return 1


def launched_rank(environ=None) -> int:
    """This process's rank as its launcher set it (0 when not under ``mpiexec``)."""
    env = os.environ if environ is None else environ
    if launched_ranks(env) == 1:
        return 0
    for name in RANK_VARIABLES:
        value = env.get(name, "")
        if value.isdigit():
            return int(value)
    return 0


def mpiexec() -> str | None:
    """The ``mpiexec`` beside this Python (the ``mpich`` wheel's), else the one on ``PATH``."""
    import shutil
    import sys
    from pathlib import Path

    here = Path(sys.executable).parent / "mpiexec"
    return str(here) if here.exists() else shutil.which("mpiexec")


__all__ = ["RANK_VARIABLES", "SIZE_VARIABLES", "launched_rank", "launched_ranks", "mpiexec"]
