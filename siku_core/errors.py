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


def check_argument(call: str, name: str, value, ok: bool, want: str) -> None:
    """The one rule for an argument of siku's Python API (``Simulation``, ``run``,
    ``scene_from_text``, ``load_scene``...): when ``ok`` is false, an :class:`InputError` on one
    line naming the call, the argument and its value, and saying what to give (``want``),
    never a ``TypeError`` from deep inside."""
    if not ok:
        shown_value = " ".join(repr(value).split())[:60]
        raise InputError(f"{call}: {name} = {shown_value}: give {want}")


def is_path(value) -> bool:
    """Whether ``value`` can name a file: a ``str`` or an ``os.PathLike`` of text (a
    ``pathlib.Path``)."""
    import os

    return isinstance(value, str) or (isinstance(value, os.PathLike)
                                      and isinstance(os.fspath(value), str))


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
