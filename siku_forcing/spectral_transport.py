"""Deprecated: this module moved to :mod:`siku_forcing.waves.spectral_transport` (siku 0.2.0).

``import siku_forcing.spectral_transport`` gives that module, with a :class:`DeprecationWarning`
(:func:`siku_core.deprecation.moved_module`).
"""
from siku_core.deprecation import moved_module

moved_module(__name__, "siku_forcing.waves.spectral_transport")
