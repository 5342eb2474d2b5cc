"""Errors raised for bad input and failed runs.

Every error a user can cause is a :class:`SikuError`; the command line prints its message on one
line and exits with status 2. Messages name the file, key or element concerned.
"""
from __future__ import annotations


class SikuError(Exception):
    """Base class of all user-facing errors (CLI exit status 2, no traceback)."""


class SceneError(SikuError):
    """A scene file is malformed: unknown key, wrong type, out-of-range value, missing file."""


class PluginError(SikuError):
    """A component name is unknown, registered twice, or a plugin does not meet its interface."""


class GeometryError(SikuError):
    """A polygon is degenerate, non-convex or otherwise unusable as an ice element."""


class StabilityError(SikuError):
    """The time step is above the safe share of the estimated critical time step."""


class NonFiniteError(SikuError):
    """A non-finite value appeared in the state; names the step, element and quantity."""


class DataError(SikuError):
    """A data file (forcing, mesh, restart) is missing, corrupt or does not cover the run."""


class InputError(SikuError, ValueError):
    """A value handed to siku through its Python interfaces (the BMI, the scene API) that the
    model cannot mean: a wrong shape or type, a non-finite or unphysical number, an index off
    the grid. Also a :class:`ValueError`, as callers of those interfaces expect."""


def shown(path) -> str:
    """How messages name a file: relative to the working directory when it lies inside it
    (``run.h5``, ``scenes/a.toml``), else absolute; the same file is always named the same
    way, whether it was given relative or absolute."""
    import os
    from pathlib import Path

    p = Path(os.path.abspath(path))
    try:
        return str(p.relative_to(Path.cwd()))
    except ValueError:
        return str(p)
