"""Deprecated: this module moved to :mod:`siku_core.run.limits` (siku 0.2.0).

``import siku_core.limits`` gives that module, with a :class:`DeprecationWarning`
(:func:`siku_core.deprecation.moved_module`).
"""
from siku_core.deprecation import moved_module

moved_module(__name__, "siku_core.run.limits")
