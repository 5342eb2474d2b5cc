"""Deprecated: the xarray backend and its helpers moved to :mod:`siku_io.output.xr` (siku 0.2.0).

``import siku_io.xr`` gives that module, with a :class:`DeprecationWarning`
(:func:`siku_core.deprecation.moved_module`).
"""
from siku_core.deprecation import moved_module

moved_module(__name__, "siku_io.output.xr")
