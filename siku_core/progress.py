"""What a run says while it works: the one-time kernel compilation and the progress bar.

The first step of a process compiles the numba kernels the scene uses (about 30 s on a 2-core
machine the first time after installing; later runs load them from the caches in a fraction of
a second: numba's cache beside the installed modules or in ``NUMBA_CACHE_DIR``, generated
kernels in ``SIKU_KERNEL_CACHE``). :class:`CompileNotice` says so on screen when that first step
takes long, and the progress bar starts only after it, so its rate and ETA are the run's.
"""
from __future__ import annotations

import sys
import threading
import time

#: the first step is announced when it has taken this long [s]
NOTICE_AFTER = 1.0


class CompileNotice:
    """Context manager around a process's first step: after ``NOTICE_AFTER`` seconds prints
    ``compiling kernels ...``; at exit, when it was printed, how long the step took."""

    def __init__(self, enabled: bool = True, stream=None):
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stderr
        self.printed = False
        self.seconds = 0.0
        self._timer: threading.Timer | None = None

    def _say(self) -> None:
        self.printed = True
        print("compiling kernels (first run after installing or changing a plugin; cached for "
              "later runs: 'siku warm' does it ahead) ...", file=self.stream, flush=True)

    def __enter__(self) -> CompileNotice:
        self._t0 = time.perf_counter()
        if self.enabled:
            self._timer = threading.Timer(NOTICE_AFTER, self._say)
            self._timer.daemon = True
            self._timer.start()
        return self

    def __exit__(self, *exc) -> None:
        self.seconds = time.perf_counter() - self._t0
        if self._timer is not None:
            self._timer.cancel()
            self._timer.join()
        if self.printed and exc[0] is None:
            print(f"kernels compiled in {self.seconds:.1f} s", file=self.stream, flush=True)
