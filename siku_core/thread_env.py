"""How idle numba threads wait: asleep, unless the user says otherwise.

numba's OpenMP threading layer (GNU libgomp here; Intel's with TBB-less conda builds) lets a
thread that has finished its share of a parallel loop spin for a while before it sleeps, so
that the next loop starts without waking it. The engine runs many short loops per step, so
on a machine busy with other work the spinning threads hold cores the step's own thread
needs: the default scene ran 5 to 10 times slower on two threads than on one at a load of 4
to 16 on two cores (``bench/RESULTS.md``, "Threads on a busy machine"). With
``OMP_WAIT_POLICY=PASSIVE`` (and ``KMP_BLOCKTIME=0`` for Intel's library) an idle thread
sleeps at once; waking it costs a few microseconds per loop, within the noise of an idle
machine's step.

:func:`set_quiet_defaults` puts these variables in the environment, where the OpenMP library
reads them once, when numba loads its threading layer (the first parallel loop, or the first
``numba.get_num_threads()``): ``import siku_core`` calls it, before anything of the engine
starts a thread. A variable the user set is kept as it is, and so is the whole choice when the
user sets any of :data:`USER_CHOICES` (``GOMP_SPINCOUNT=300000`` gives libgomp's own
default back). In a process whose threads were started before ``import siku_core`` the
variables come too late and change nothing; child processes inherit them.
"""
from __future__ import annotations

import os

#: what siku sets when the user has not: idle OpenMP threads sleep at once
QUIET = {"OMP_WAIT_POLICY": "PASSIVE", "KMP_BLOCKTIME": "0"}
#: variables by which a user chooses how OpenMP threads wait; any of them set: siku sets none
USER_CHOICES = ("OMP_WAIT_POLICY", "KMP_BLOCKTIME", "GOMP_SPINCOUNT")


def set_quiet_defaults(environ: dict | None = None) -> dict[str, str]:
    """Set :data:`QUIET` in ``environ`` (default ``os.environ``) unless the user has chosen
    how OpenMP threads wait (any of :data:`USER_CHOICES` set, even to an empty string);
    returns the variables it set."""
    env = os.environ if environ is None else environ
    if any(k in env for k in USER_CHOICES):
        return {}
    env.update(QUIET)
    return dict(QUIET)
