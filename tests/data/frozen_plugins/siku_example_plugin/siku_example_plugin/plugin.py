"""The hooks siku calls: named by the entry point ``[project.entry-points.siku] example``.

Each ``siku_register_*`` hook returns a list of component classes; siku checks every class
against its interface (base class, ``name``, the parameter names of its methods) when it builds
its registry, so a mistake shows up in ``siku plugins``, not in the middle of a run.
"""
from __future__ import annotations

from siku_core import hookimpl

from .centres_csv import CentresCSV
from .euler import Euler
from .laws import BrittleBond
from .tilt import SeaSurfaceTilt


@hookimpl
def siku_register_forcing_sources():
    return [SeaSurfaceTilt]


@hookimpl
def siku_register_integrators():
    return [Euler]


@hookimpl
def siku_register_contact_laws():
    return [BrittleBond]


@hookimpl
def siku_register_writers():
    return [CentresCSV]
