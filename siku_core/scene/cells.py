"""The smallest free cells of a pack and what they cost in time step.

The stable step of an element's elastic contact modes scales with its linear size (the
frequency ``omega ~ sqrt(E / rho) / L``), so a free cell whose area is a share ``a`` of the
median free cell's has about ``sqrt(a)`` of the median cell's stable step. The mesh builder
prints this when it builds or reads a mesh, and the run summary
(:mod:`siku_core.run.summary`) shows it for the run's elements. Plain numpy; imports nothing of
the engine but the element flags.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..state import FREE


@dataclass(frozen=True)
class SmallCellReport:
    """The free cells' areas against their median: ``smallest`` and ``p5`` (the 5th
    percentile) are shares of the median free-cell area [1]; ``step_factor`` = ``sqrt(smallest)``
    is the smallest free cell's stable step as a share of the median cell's [1]; ``n_free``
    free cells of median area ``median`` [m², or the areas' unit]."""

    n_free: int
    median: float
    smallest: float
    p5: float

    @property
    def step_factor(self) -> float:
        return math.sqrt(self.smallest) if self.smallest >= 0 else float("nan")

    def line(self, p5: bool = True) -> str:
        """One line: the smallest share, its step factor and (``p5``) the 5th percentile."""
        tail = f"; 5th percentile {self.p5:.2f} x median" if p5 else ""
        return (f"smallest free cell {self.smallest:.2f} x median area (step "
                f"x{self.step_factor:.2f} of the median cell's{tail})")


def small_cell_report(areas, flags) -> SmallCellReport | None:
    """The smallest free cells of elements of area ``areas`` (any unit) and flags ``flags``
    (:data:`~siku_core.state.FREE`, ``STATIC``, ``STEADY``): their shares of the median free
    area. ``None`` without free cells of positive median area."""
    a = np.asarray(areas, dtype=float)[np.asarray(flags) == FREE]
    if not len(a):
        return None
    med = float(np.median(a))
    if not med > 0:
        return None
    return SmallCellReport(n_free=int(len(a)), median=med, smallest=float(a.min()) / med,
                           p5=float(np.percentile(a, 5.0)) / med)
