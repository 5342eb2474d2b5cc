"""Gridded fields: velocity fields from NetCDF files (``gridded_field``), their CF reader and
interpolation kernels, the regular grid and the exchange grid of a coupled model
(``exchange``).

The module ``siku_forcing.gridded`` of siku 0.1 is
:mod:`siku_forcing.gridded.gridded_field` since 0.2.0.

Each name that this module held keeps importing from here, with a
:class:`DeprecationWarning` naming its new home (:func:`siku_core.deprecation.moved_names`).
"""
from siku_core.deprecation import moved_names

_MOVES: dict[str, str] = {}
_0 = (
    'ComponentReader', 'DataError', 'Field', 'GridSample', 'Gridded', 'KernelGrid', 'Param',
    'SPEED_UNITS', 'SceneError', 'cached_stress', 'classic_size', 'gridded_stress',
    'gridded_values', 'hookimpl', 'interpolate', 'iso_seconds', 'latlon_of', 'pole_vector',
    'record_type', 'siku_register_fields',
)
_MOVES.update(dict.fromkeys(_0, 'siku_forcing.gridded.gridded_field'))
__getattr__ = moved_names(__name__, _MOVES)
