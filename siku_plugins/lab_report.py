"""Moved: what the virtual ice tests report is part of :mod:`siku_plugins.lab` (one module for
the tests, the report and the command, with no import circle between them); this path keeps
importing, with a :class:`DeprecationWarning`."""
from siku_core.deprecation import moved_module

moved_module(__name__, "siku_plugins.lab")
