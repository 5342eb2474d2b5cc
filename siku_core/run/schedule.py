"""Schedules: when writers and checks run, and the time step that makes them exact."""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

#: a fitted step may be this much shorter than the scene's before the fit is given up
MIN_FIT_SHARE = 0.5


def _fraction(seconds: float) -> Fraction:
    return Fraction(seconds).limit_denominator(1_000_000)


def fit_time_step(dt: float, total: float, intervals) -> tuple[float, bool]:
    """The longest step ``<= dt`` [s] on which the run's end ``total`` and every output
    interval in ``intervals`` (seconds; ``None`` entries ignored) fall exactly.

    With ``g`` the greatest common divisor of ``total`` and the intervals (as exact fractions of
    a microsecond), the step is ``g / ceil(g / dt)``: ``dt`` itself when it divides ``g``,
    otherwise a step at most one part in ``g / dt`` shorter (``dt = 7 s`` with hourly outputs
    gives 3600/515 = 6.990 s). Returns ``(step, exact)``; when that step would be shorter than
    ``MIN_FIT_SHARE · dt`` (output times with no common divisor near ``dt``) the step stays
    ``dt``, ``exact`` is False and the outputs fall on the nearest steps.
    """
    g = _fraction(total)
    for s in intervals:
        if s is not None and s > 0:
            g = Fraction(math.gcd(g.numerator * _fraction(s).denominator,
                                  _fraction(s).numerator * g.denominator),
                         g.denominator * _fraction(s).denominator)
    if g <= 0:
        return dt, False
    ratio = float(g) / dt
    n = max(1, math.ceil(ratio - 1e-9))
    if abs(ratio - round(ratio)) <= 1e-9 * max(1.0, ratio):
        return dt, True  # dt divides every time already: keep it bit for bit
    step = float(g) / n
    if step < MIN_FIT_SHARE * dt:
        return dt, False
    return step, True


#: default output schedules (``[output] every`` / ``diagnostics_every`` unset): about this many
#: snapshots and diagnostics rows per run, at least this many steps apart (a snapshot of a
#: 10 000-element scene costs about two steps, a diagnostics row a sixth of one)
DEFAULT_SNAPSHOTS, DEFAULT_SNAPSHOT_STEPS = 20, 100
DEFAULT_DIAGNOSTICS, DEFAULT_DIAGNOSTICS_STEPS = 200, 10


@dataclass(frozen=True)
class StepInterval:
    """Due at step ``offset`` (0), every ``every`` steps from it, and at the last step of a
    run. A restart with another step sets ``offset`` so that the steps due are those whose
    model time is a multiple of ``every`` of the new step (:meth:`from_origin`)."""

    every: int
    offset: int = 0

    def from_origin(self, k0: int, t0: float, dt: float) -> "StepInterval":
        """The same interval on the model time of a run whose step ``k0`` is at ``t0`` [s]
        with steps of ``dt`` [s]: due where ``t0 + (k - k0) dt`` is a multiple of
        ``every dt``."""
        return StepInterval(self.every, k0 - round(t0 / dt))

    @classmethod
    def from_seconds(cls, seconds: float | None, dt: float, n_steps: int, default_count: int,
                     min_steps: int = 1):
        """Interval from seconds; ``None`` gives about ``default_count`` events per run, at
        least ``min_steps`` steps apart (so that writing stays a small share of a short run:
        ``docs/explanation/outputs.md``)."""
        if seconds is None:
            return cls(max(1, min_steps, math.ceil(n_steps / default_count)))
        return cls(max(1, round(seconds / dt)))

    @classmethod
    def snapshots(cls, seconds: float | None, dt: float, n_steps: int) -> "StepInterval":
        """The state snapshots' schedule: every ``seconds``, else the default."""
        return cls.from_seconds(seconds, dt, n_steps, DEFAULT_SNAPSHOTS, DEFAULT_SNAPSHOT_STEPS)

    @classmethod
    def diagnostics(cls, seconds: float | None, dt: float, n_steps: int) -> "StepInterval":
        """The diagnostics rows' schedule: every ``seconds``, else the default."""
        return cls.from_seconds(seconds, dt, n_steps, DEFAULT_DIAGNOSTICS,
                                DEFAULT_DIAGNOSTICS_STEPS)

    def due(self, step: int, last: int) -> bool:
        return (step - self.offset) % self.every == 0 or step == last
