"""How the engine's compiled loops share work between numba threads.

Loops over elements or contacts run over ``nch`` equal chunks (:func:`chunk_bounds`); each
chunk writes only its own items, so the result never depends on ``nch``, on the number of
threads, or on which thread runs which chunk. :func:`chunks` picks ``nch``: 1 (no threads
started) for small loops or one thread, else several chunks per thread.
``numba.set_num_threads`` (or ``siku run --threads``) sets the threads.

Chunks are handed out as threads ask for them (:func:`claim`), not split up front: numba's
``prange`` gives each thread a fixed half of the iterations (its OpenMP and workqueue layers
schedule statically), so on a machine where one core runs slower than the other (a virtual
CPU sharing its physical core, a busy neighbour) every parallel loop waits for the slow half
and two threads gain 1.3× instead of 2×. The contact loops run ``prange`` over
:func:`tasks` (one task per thread) and each task claims chunks from a shared counter with an
atomic add until none are left: a fast thread simply takes more chunks.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from typing import Any

import numba
from numba import njit, types
from numba.np.ufunc import parallel as _numba_parallel
from numba.core import cgutils
from numba.extending import intrinsic

#: items below which a loop runs on the calling thread: starting threads costs more (items of
#: :data:`ITEM_NS`; a loop whose items cost less needs proportionally more of them)
PARALLEL_MIN = 2048
#: smallest chunk worth a task [items of ITEM_NS]
CHUNK_MIN = 512
#: the cost of the reference item [ns on one thread]: about a contact's
ITEM_NS = 100.0
#: cost per item [ns, one thread] of the engine's light loops, measured on the 40 000-element
#: pack (``python -m bench.threads``): waking the other threads for a region costs tens of
#: microseconds, more than a loop of a few thousand such items
GUARD_NS, ROTATION_NS, DRAG_NS, INTEGRATOR_NS, GATHER_NS = 4.0, 10.0, 15.0, 40.0, 40.0
#: the drag of a gridded field in one pass (centre, interpolation, stress) [ns per element]
GRIDDED_DRAG_NS = 60.0


def threads() -> int:
    """The numba threads loops may use now."""
    return _numba_threads()


def _numba_threads() -> int:
    """``numba.get_num_threads()``, read without its lock once numba has started its threads
    (a step asks a dozen times; the lock costs about 3 us a call, a tenth of a millisecond a
    step of the default scene): numba's own reading of the calling thread's count, where the
    numba version has it."""
    if _numba_parallel._is_initialized:
        read = getattr(_numba_parallel, "_get_num_threads", None)
        n = read() if callable(read) else 0
        if n > 0:
            return n
    return numba.get_num_threads()


@contextmanager
def threads_for(n: int) -> Iterator[int]:
    """Run the enclosed phases on one thread when ``n`` (the scene's elements) is below
    :data:`PARALLEL_MIN`, else on the threads set; yields the threads used.

    Every loop of such a scene runs in one chunk anyway (:func:`chunks`), but a parallel
    region of one chunk still wakes the other threads; with one thread set none is woken, so
    a small run on all cores costs what it costs on one (``bench/threads.py``).
    """
    before = _numba_threads()
    if before > 1 and n < PARALLEL_MIN:
        numba.set_num_threads(1)
        try:
            yield 1
        finally:
            numba.set_num_threads(before)
    else:
        yield before


@contextmanager
def alone(nch: int) -> Iterator[None]:
    """Run the enclosed call of a loop cut into ``nch`` chunks on the calling thread alone when
    ``nch`` is 1: a parallel region of one chunk would still wake the other threads and wait
    for them (tens of microseconds each time, more than a light loop of a few thousand items)."""
    before = _numba_threads() if nch <= 1 else 1
    if before <= 1:
        yield
        return
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def chunks(n: int, item_ns: float = ITEM_NS) -> int:
    """Number of chunks for a parallel loop over ``n`` items of ``item_ns`` [ns on one thread]
    each with the current numba threads: one (no thread woken) below ``PARALLEL_MIN`` reference
    items of work, else several per thread, none smaller than ``CHUNK_MIN`` reference items."""
    threads = globals()["threads"]()
    work = n * (item_ns / ITEM_NS)
    if threads <= 1 or work < PARALLEL_MIN:
        return 1
    return max(1, min(8 * threads, int(work // max(CHUNK_MIN, 1e-300))))


def tasks(nch: int) -> int:
    """Tasks of a loop over ``nch`` claimed chunks: one per thread, at most one per chunk."""
    return max(1, min(globals()["threads"](), nch))


@intrinsic
def _fetch_add(typingctx, counter, value):
    """Atomically add ``value`` to ``counter[0]`` (int64) and return the previous value."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64):
        return None
    sig = types.int64(counter, types.int64)

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary,
                                       [context.get_constant(types.intp, 0)])
        return builder.atomic_rmw("add", ptr, args[1], "monotonic")

    return sig, codegen


@njit(cache=True, inline="always")
def claim(counter):
    """The next unclaimed chunk of a loop (``counter``: int64 array of one zero, shared by
    the loop's tasks); a value ``>= nch`` means every chunk is taken."""
    return _fetch_add(counter, 1)


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


#: steps at one thread count before it is first compared with the other
FIRST_TRIAL = 3
#: steps of a trial of the other thread count, at most
TRIAL_STEPS = 5
#: a trial wins when its median step takes at most this fraction of the current median [1]
WIN = 0.95
#: after a losing trial, the stepping time before the next is at least this many times the time
#: the trial lost, and at least twice the previous wait [1]
PATIENCE = 50.0
#: the first and the longest wait between trials [s]
FIRST_WAIT, LONGEST_WAIT = 1.0, 60.0
#: the current count is tried against the other at once when its recent median step has grown
#: past this multiple of the median it had when it was last compared [1]
SLOWER = 2.0
#: steps taken at each thread count by the last :class:`ThreadTuner` of this process
LAST_TUNED: dict[int, int] = {}


class ThreadTuner:
    """Chooses, while a run steps, between one thread and ``most`` by timing both.

    Idle OpenMP threads spin for a while before they sleep (the library's default, which
    the engine's many short parallel loops need on an idle machine: with
    ``OMP_WAIT_POLICY=PASSIVE`` two threads lose 40 % of their speed there); on a machine
    busy with other work the spinning threads hold cores the run's own thread needs, and two
    threads can run 5 to 15 times slower than one (``bench/RESULTS.md``, "Threads on a
    busy machine"). Which is faster depends on what else runs now, so the run measures it:
    it starts on one thread, after ``FIRST_TRIAL`` steps takes up to ``TRIAL_STEPS`` steps on
    the other count and keeps the faster (``WIN``), then tries again after waits that double
    from ``FIRST_WAIT`` to ``LONGEST_WAIT`` seconds of stepping, and at least ``PATIENCE``
    times what the last trial lost; at once when its steps have become ``SLOWER`` times
    slower. A trial that has already cost ``TRIAL_STEPS`` current steps stops. Results do not
    depend on the thread count (the loops' chunks, module docstring), so switching changes
    speed only. Use as ``with tuner:`` around each step (its time on :func:`clock`).
    """

    def __init__(self, most: int, clock: Callable[[], float],
                 set_threads: Callable[[int], None] = numba.set_num_threads):
        from collections import deque

        self.most, self.clock, self._set = most, clock, set_threads
        self.current = 1
        self.recent: deque = deque(maxlen=8)  # seconds of the last steps at `current`
        self.trial: list[float] | None = None  # seconds of the trial's steps so far
        self.compared: float | None = None  # median step at `current` when last compared [s]
        self.wait = FIRST_WAIT
        self.elapsed = 0.0  # stepping time so far [s]
        self.due = 0.0  # stepping time of the next trial [s]
        self.switches = 0
        LAST_TUNED.clear()
        self.threads = 1  # the threads of the next step
        set_threads(1)

    @property
    def other(self) -> int:
        return self.most if self.current == 1 else 1

    def __enter__(self) -> ThreadTuner:
        self._t0 = self.clock()
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.record(self.clock() - self._t0)

    def record(self, seconds: float) -> None:
        """Account for a step of ``seconds`` [s] and set the threads of the next."""
        from statistics import median

        LAST_TUNED[self.threads] = LAST_TUNED.get(self.threads, 0) + 1
        self.elapsed += seconds
        if self.trial is not None:
            self.trial.append(seconds)
            now = median(self.recent)
            if len(self.trial) < TRIAL_STEPS and sum(self.trial) <= TRIAL_STEPS * now:
                return
            tried = median(self.trial)
            if tried <= WIN * now:  # the other count is faster: keep it
                self.current, self.compared, self.wait = self.other, tried, FIRST_WAIT
                self.recent.clear()
                self.recent.extend(self.trial)
                self.switches += 1
            else:
                lost = max(sum(self.trial) - len(self.trial) * now, 0.0)
                self.compared = now
                self.wait = min(LONGEST_WAIT, max(2.0 * self.wait, PATIENCE * lost))
            self.trial = None
            self.due = self.elapsed + self.wait
            self._use(self.current)
            return
        self.recent.append(seconds)
        if len(self.recent) < FIRST_TRIAL:
            return
        now = median(self.recent)
        if self.elapsed >= self.due or (self.compared is not None
                                        and now > SLOWER * self.compared):
            self.trial = []
            self._use(self.other)

    def _use(self, n: int) -> None:
        self.threads = n
        self._set(n)


@contextmanager
def tuned(enabled: bool, clock: Callable[[], float]) -> Iterator[Any]:
    """A :class:`ThreadTuner` between one thread and the threads set now when ``enabled`` and
    more than one is set, else a context that does nothing (``with tuner:`` around each step
    either way); the threads set are restored at exit."""
    before = _numba_threads()
    if not enabled or before <= 1:
        yield nullcontext()
        return
    try:
        yield ThreadTuner(before, clock)
    finally:
        numba.set_num_threads(before)
