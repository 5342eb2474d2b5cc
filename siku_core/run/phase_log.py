"""The phases of the step by window of model time: ``siku run --profile``'s hour-by-hour table.

:class:`PhaseLog` reads a run's phase timers (``Simulation.timings``, seconds that leave the
compilation out: :func:`siku_core.run.progress.clock`) at the end of every window of model time
(an hour by default) and keeps, for each window, the seconds of every phase, its steps, its
wall time and the process's CPU time without compilation, the machine's load average at its
end and the state of the contacts at its end (candidate pairs, overlapping pairs, joints broken
so far, candidate-list rebuilds). A cost per element-step that grows through a run shows there,
next to what grew with it; on a machine shared with other work the wall time of an hour swings
with the other work, and the CPU time per step (one thread: the time a core of its own would
take, less what sharing its caches adds) and the load beside it tell the two apart.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

from .progress import COMPILING, clock

#: the contact model's counters a window records at its end, and their column titles
CONTACT_COLUMNS = (("pairs", "candidate pairs"), ("n_overlap", "overlapping"),
                   ("n_broken_total", "broken"), ("rebuilds", "rebuilds"))


@dataclass
class Window:
    """One window of model time: ``start``, ``end`` [s of model time], ``steps`` taken in it,
    ``wall`` [s] (compilation left out), ``phases`` {phase: seconds}, ``contacts``
    {counter: value at its end} (empty without contacts), ``cpu`` [s] the process's CPU time
    over the window (all its threads; compilation left out) and ``load`` the machine's
    one-minute load average at its end (NaN where the system does not tell)."""

    start: float
    end: float
    steps: int
    wall: float
    phases: dict[str, float]
    contacts: dict[str, int] = field(default_factory=dict)
    cpu: float = math.nan
    load: float = math.nan


def cpu_clock() -> float:
    """The process's CPU time [s] (``time.process_time()``) less its CPU time of numba's
    compilations: the difference of two readings is the CPU time of the work between them."""
    return time.process_time() - COMPILING.cpu_now()


def load_average() -> float:
    """The machine's one-minute load average (NaN where ``os.getloadavg`` is missing)."""
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return math.nan


class PhaseLog:
    """Phase times of ``sim`` (a :class:`~siku_core.run.simulation.Simulation`) by window of
    ``every`` seconds of model time [s]; ``Simulation.step`` calls :meth:`before_step` when a
    log is set on ``sim.phase_log``, and :meth:`before_step` closes a window whose end the steps
    reached (at the next step, so that it holds its last step's output); :meth:`finish` closes
    the last one."""

    def __init__(self, sim, every: float = 3600.0):
        if not every > 0.0:
            raise ValueError(f"every = {every!r}: a window needs a positive length [s]")
        self.every = float(every)
        self.windows: list[Window] = []
        self._mark(sim)

    def _mark(self, sim) -> None:
        self._t0 = sim.time
        self._timings = dict(sim.timings)
        self._clock = clock()
        self._cpu = cpu_clock()
        self._steps = sim.timed_steps
        # the first window boundary after t0 (a step within round-off of it counts as on it)
        self._next = (math.floor(self._t0 / self.every + 1e-9) + 1) * self.every

    def before_step(self, sim) -> None:
        """Close the window when the steps so far reached its end."""
        if sim.time >= self._next - 1e-6 * sim.dt and sim.timed_steps > self._steps:
            self._close(sim)

    def finish(self, sim) -> None:
        """Close the window under way (after the run) if it holds steps."""
        if sim.timed_steps > self._steps:
            self._close(sim)

    def _close(self, sim) -> None:
        now, cpu = clock(), cpu_clock()
        phases = {k: v - self._timings.get(k, 0.0) for k, v in sim.timings.items()}
        contacts = {}
        cm = sim.contacts
        if cm is not None:
            contacts = {k: (len(cm.pairs) if k == "pairs" else int(getattr(cm, k, 0)))
                        for k, _ in CONTACT_COLUMNS}
        self.windows.append(Window(self._t0, sim.time, sim.timed_steps - self._steps,
                                   now - self._clock, phases, contacts,
                                   max(cpu - self._cpu, 0.0), load_average()))
        self._mark(sim)

    def table(self, n: int, phases: tuple[str, ...]) -> str:
        """The windows as a table: per window its model time [h], steps, steps and
        element-steps per second of wall time, the process's CPU milliseconds per step, the
        nanoseconds per element-step of each phase in ``phases`` with time spent (and
        ``other``: the window's wall time less its phases), the contact counters and the
        machine's load average at its end; ``n`` the number of elements."""
        n = max(n, 1)
        used = [p for p in phases if any(w.phases.get(p, 0.0) > 0.0 for w in self.windows)]
        cols = [c for c in CONTACT_COLUMNS if any(c[0] in w.contacts for w in self.windows)]
        head = (f"  {'hours':>11} {'steps':>6} {'steps/s':>8} {'el-steps/s':>10} "
                f"{'CPU ms/step':>11} "
                + " ".join(f"{p[:11]:>11}" for p in used + ["other"])
                + "".join(f" {t:>15}" for _, t in cols) + f" {'load':>5}")
        lines = ["profile by hour of model time (wall time and CPU time without the "
                 "compilation; ns per element-step of each phase, wall time; the contacts and "
                 "the machine's 1-min load average at the end of the hour):", head]
        for w in self.windows:
            steps = max(w.steps, 1)
            rate = w.steps / w.wall if w.wall > 0 else 0.0
            ns = [w.phases.get(p, 0.0) / steps / n * 1e9 for p in used]
            other = max(w.wall - sum(w.phases.get(p, 0.0) for p in phases), 0.0)
            ns.append(other / steps / n * 1e9)
            hours = f"{w.start / 3600:g}-{w.end / 3600:.3g}"
            lines.append(f"  {hours:>11} {w.steps:>6} {rate:8.4g} {n * rate:10.3g} "
                         f"{1e3 * w.cpu / steps:11.3f} "
                         + " ".join(f"{x:11.1f}" for x in ns)
                         + "".join(f" {w.contacts.get(k, 0):>15}" for k, _ in cols)
                         + f" {w.load:5.2f}")
        return "\n".join(lines)
