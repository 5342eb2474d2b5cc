"""Floating elements (``[[process]] name = "floating"``): heave, roll and pitch of each element
in still water and in the scene's waves (``process``), the waterplane geometry
(``geometry``), the kernels (``kernels``) and capytaine's added mass and damping, cached
(``hydro``, the optional extra ``siku[hydro]``)."""
from __future__ import annotations

from siku_core import hookimpl

from .process import Floating

__all__ = ["Floating"]


@hookimpl
def siku_register_processes():
    return [Floating]
