"""Deprecated: the Basic Model Interface moved to :mod:`siku_io.coupling.bmi` (siku 0.2.0).

``import siku_io.bmi`` gives that module, with a :class:`DeprecationWarning`
(:func:`siku_core.deprecation.moved_module`).
"""
from siku_core.deprecation import moved_module

moved_module(__name__, "siku_io.coupling.bmi")
