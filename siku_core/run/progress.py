"""What a run says while it works: the kernel compilation and the progress bar; the run's clock.

The first run of a scene compiles the numba kernels it uses (about four minutes for the default
scene on a 2-core machine the first time after installing, more when the machine is busy:
``bench/RESULTS.md``, "The first compile"; later runs load them
from the caches in a second or two: siku's numba functions keyed by siku's sources
(:mod:`siku_core.numba_cache`, or ``NUMBA_CACHE_DIR``), generated kernels in
``SIKU_KERNEL_CACHE``).

:data:`COMPILING` (a :class:`CompileClock`, listening to numba's ``numba:compile`` event from
the import of this module on) counts the seconds numba spends compiling. :func:`clock` is
``time.perf_counter()`` less those seconds: the run's phases (``Simulation.timings``), its
summary's steps per second and ``siku run --profile`` are timed with it, so that they leave
the compilation out wherever it happens (the first step, a process's first application).

:class:`CompileProgress` shows the compilation on screen while it lasts: a line saying that
kernels are compiling, how many are done, for how long, and which one is compiling now;
at the end, how long it took.
"""
from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

from numba.core import event

#: a compilation is shown when it has lasted this long [s]
NOTICE_AFTER = 1.0
#: seconds between redraws of the compile line [s]
REFRESH = 0.5


def kernel_name(ev: event.Event) -> str:
    """``module.function`` of the kernel a ``numba:compile`` event compiles."""
    disp = (ev.data or {}).get("dispatcher")
    fn = getattr(disp, "py_func", None)
    if fn is None:
        return str(disp)
    return f"{fn.__module__}.{fn.__qualname__}"


class CompileClock(event.Listener):
    """Counts and times numba compilations while listening (``with CompileClock() as c:``
    or :func:`numba.core.event.register`).

    ``seconds``: wall seconds of compilation [s], a compilation that another one starts (the
    functions a kernel calls) counted once; ``count``: kernels compiled (numba's own
    implementations of the library functions a kernel calls counted in the kernel);
    ``kernels``: seconds per kernel, its own (without the kernels it compiled on the way)
    [s]; ``signatures``: compilations per kernel (one per argument types); ``current``: the
    kernel compiling now (``None`` between compilations); ``cpu_seconds``: the process's CPU
    seconds over the same compilations (``time.process_time()``) [s].
    """

    def __init__(self) -> None:
        self.seconds = 0.0
        self.cpu_seconds = 0.0
        self.count = 0
        self.kernels: dict[str, float] = {}
        self.signatures: dict[str, int] = {}
        # [name, start, seconds of the compilations inside, CPU clock at the start]
        self._stack: list[list] = []
        self._lock = threading.Lock()

    @property
    def current(self) -> str | None:
        names = [e[0] for e in self._stack if not e[0].startswith("numba.")]
        return names[-1] if names else None

    def now(self) -> float:
        """Seconds of compilation so far, the one under way included [s]."""
        with self._lock:
            if self._stack:
                return self.seconds + time.perf_counter() - self._stack[0][1]
            return self.seconds

    def cpu_now(self) -> float:
        """The process's CPU seconds of compilation so far, the one under way included [s]."""
        with self._lock:
            if self._stack:
                return self.cpu_seconds + time.process_time() - self._stack[0][3]
            return self.cpu_seconds

    def on_start(self, ev: event.Event) -> None:
        with self._lock:
            self._stack.append([kernel_name(ev), time.perf_counter(), 0.0,
                                time.process_time()])

    def on_end(self, ev: event.Event) -> None:
        with self._lock:
            if not self._stack:
                return
            name, t0, inner, c0 = self._stack.pop()
            took = time.perf_counter() - t0
            if not self._stack:
                self.seconds += took
                self.cpu_seconds += time.process_time() - c0
            if name.startswith("numba.") and self._stack:
                return  # numba's own implementation of a library call: the caller's time
            self.count += 1
            self.kernels[name] = self.kernels.get(name, 0.0) + took - inner
            self.signatures[name] = self.signatures.get(name, 0) + 1
            if self._stack:
                self._stack[-1][2] += took

    def __enter__(self) -> CompileClock:
        event.register("numba:compile", self)
        return self

    def __exit__(self, *exc) -> None:
        event.unregister("numba:compile", self)


#: the process's compile clock, listening from the import of this module on
COMPILING = CompileClock()
event.register("numba:compile", COMPILING)


def clock() -> float:
    """``time.perf_counter()`` less the seconds numba has spent compiling in this process [s]:
    the difference of two readings is the time between them that was not compilation."""
    return time.perf_counter() - COMPILING.now()


@contextmanager
def compile_time(sim) -> Iterator[None]:
    """Add the seconds numba spends compiling inside the block to ``sim.compile_seconds``."""
    c0 = COMPILING.now()
    try:
        yield
    finally:
        sim.compile_seconds += COMPILING.now() - c0


#: the :class:`CompileProgress` objects active now, outermost first: only the outermost one
#: that is enabled shows a line
_ACTIVE: list = []


class CompileProgress(CompileClock):
    """Context manager that shows the kernels compiling while it is active: after a
    compilation has lasted ``NOTICE_AFTER`` seconds, a line ``compiling kernels ...: N done
    [elapsed], now: module.function`` redrawn every ``REFRESH`` seconds (a tqdm status line);
    at exit, when it was shown, ``kernels compiled in S s (N kernels)``. Nothing is shown
    when ``enabled`` is false, nothing when no kernel compiles (all loaded from the caches),
    and one line only when another ``CompileProgress`` is showing already."""

    def __init__(self, enabled: bool = True, stream=None):
        super().__init__()
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stderr
        self.printed = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def on_start(self, ev: event.Event) -> None:
        super().on_start(ev)
        if self.enabled and self._thread is None:
            self._thread = threading.Thread(target=self._show, daemon=True)
            self._thread.start()

    def _show(self) -> None:
        if self._stop.wait(NOTICE_AFTER):
            return
        from tqdm.auto import tqdm

        self.printed = True
        bar = tqdm(total=None, file=self.stream, desc="compiling kernels (first run after "
                   "installing or changing a plugin; cached for later runs)", unit=" kernels",
                   bar_format="{desc}: {n} done [{elapsed}]{postfix}", mininterval=0)
        while True:
            bar.n = self.count
            now = self.current
            bar.set_postfix_str(f"now: {now}" if now else "", refresh=False)
            bar.refresh()
            if self._stop.wait(REFRESH):
                break
        bar.n = self.count
        bar.set_postfix_str("", refresh=False)
        bar.close()

    def __enter__(self) -> CompileProgress:
        self.enabled = self.enabled and not any(p.enabled for p in _ACTIVE)
        _ACTIVE.append(self)
        return super().__enter__()  # type: ignore[return-value]

    def __exit__(self, *exc) -> None:
        super().__exit__(*exc)
        _ACTIVE.remove(self)
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self.printed:
            if exc[0] is None:
                n = self.count
                print(f"kernels compiled in {self.seconds:.1f} s ({n} kernel{'s' * (n != 1)})",
                      file=self.stream, flush=True)
