"""Built-in processes (physics that changes the ice, ``siku_core.interfaces.Process``):
``thermodynamics`` (zero-layer growth and melt), ``ridging`` (overlap of ice pressed beyond
its plastic limit becomes thicker ice), ``refreeze`` (broken joints that freeze again) and
``joint_strength`` (joints of unequal, Weibull-distributed strength).
One module each; this package registers them."""
from __future__ import annotations

from siku_core import hookimpl

from .joint_strength import JointStrength
from .refreeze import Refreeze
from .ridging import Ridging
from .thermodynamics import Thermodynamics

__all__ = ["JointStrength", "Refreeze", "Ridging", "Thermodynamics"]


@hookimpl
def siku_register_processes():
    return [Thermodynamics, Ridging, Refreeze, JointStrength]
