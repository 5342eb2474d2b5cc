"""Deprecated: this module moved to :mod:`siku_core.contact.contact_joints` (siku 0.2.0).

``import siku_core.contact_joints`` gives that module, with a :class:`DeprecationWarning`
(:func:`siku_core.deprecation.moved_module`).
"""
from siku_core.deprecation import moved_module

moved_module(__name__, "siku_core.contact.contact_joints")
