"""Schedules: when writers and checks run."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class StepInterval:
    """Due at step 0, every ``every`` steps, and at the last step of a run."""

    every: int

    @classmethod
    def from_seconds(cls, seconds: float | None, dt: float, n_steps: int, default_count: int):
        """Interval from seconds; ``None`` gives about ``default_count`` events per run."""
        if seconds is None:
            return cls(max(1, math.ceil(n_steps / default_count)))
        return cls(max(1, round(seconds / dt)))

    def due(self, step: int, last: int) -> bool:
        return step % self.every == 0 or step == last
