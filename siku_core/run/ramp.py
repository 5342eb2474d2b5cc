"""Forcing ramps: a forcing source switched on gradually from the start of the run.

``[[forcing]] ramp = "6h"`` multiplies the force and torque that source adds by ``r(t)``, with
``t`` the model time of the force evaluation (from the scene's start) and ``T`` the ramp time:

* ``ramp_shape = "cosine"`` (default): ``r = (1 - cos(pi t / T)) / 2 = sin²(pi t / 2T)`` for
  ``0 <= t < T``: zero force and zero rate of change at the start, full force with zero rate of
  change at ``T``, so neither end jerks the ice;
* ``ramp_shape = "linear"``: ``r = t / T``;

and ``r = 1`` from ``t >= T`` on. The engine has the source add into scratch arrays and adds
``r`` times them (one product per entry: the ramped force is ``r`` times the unramped force to
round-off); from ``T`` on, and without a ramp, the source adds directly, bit for bit as before.
``r`` depends on the model time alone, so a run restarted inside the ramp continues it bit for
bit. What a source does besides adding forces (wave-induced breaking) is not ramped.
"""
from __future__ import annotations

import math

import numpy as np

#: the shapes ``ramp_shape`` may name
RAMP_SHAPES = ("cosine", "linear")


def ramp_factor(t: float, ramp: float, shape: str = "cosine") -> float:
    """The ramp ``r(t)`` [1] for ramp time ``ramp`` [s] (module docstring)."""
    if t >= ramp:
        return 1.0
    if t <= 0.0:
        return 0.0
    x = t / ramp
    if shape == "linear":
        return x
    return 0.5 * (1.0 - math.cos(math.pi * x))


class ForcingRamps:
    """The ramps of a run's forcing sources, built from the scene's ``[[forcing]]`` tables;
    :meth:`add` has every source add its force, ramped where its table says."""

    def __init__(self, tables):
        #: per source: ``(ramp [s], shape)`` or ``None``
        self.ramps = [None if f.ramp is None else (float(f.ramp), f.ramp_shape) for f in tables]
        self._scratch: tuple[np.ndarray, np.ndarray] | None = None

    def factor(self, k: int, t: float) -> float:
        """``r(t)`` of source ``k`` (1 without a ramp)."""
        ramp = self.ramps[k]
        return 1.0 if ramp is None else ramp_factor(t, *ramp)

    def add(self, sources, t, q, V, w, F, T) -> None:
        """Every source adds its force ``F`` [N] and torque ``T`` [N m] for the state at
        ``t`` [s]; a ramped one (``r < 1``) adds into zeroed scratch arrays, of which ``r``
        times is added."""
        for k, src in enumerate(sources):
            r = self.factor(k, t)
            if r == 1.0:
                src.add(t, q, V, w, F, T)
                continue
            if self._scratch is None or self._scratch[0].shape != F.shape:
                self._scratch = (np.zeros_like(F), np.zeros_like(T))
            Fs, Ts = self._scratch
            Fs.fill(0.0)
            Ts.fill(0.0)
            src.add(t, q, V, w, Fs, Ts)
            F += r * Fs
            T += r * Ts
