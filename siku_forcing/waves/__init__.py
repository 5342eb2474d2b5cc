"""Surface waves: plane waves and the JONSWAP sea (``wave_field``), how a field sums its sea,
the spectral sea, attenuation laws and wave-induced breaking.

The module ``siku_forcing.waves`` of siku 0.1 is
:mod:`siku_forcing.waves.wave_field` since 0.2.0.

Each name that this module held keeps importing from here, with a
:class:`DeprecationWarning` naming its new home (:func:`siku_core.deprecation.moved_names`).
"""
from siku_core.deprecation import moved_names

_MOVES: dict[str, str] = {}
_0 = (
    'FREE', 'Field', 'ForcingSource', 'Jonswap', 'KAPPA', 'LINES_PARAMS', 'LinearWave',
    'LinesMixin', 'PHASE_STREAM', 'Param', 'PlaneWaves', 'SceneError', 'WATER_DRAG_PARAMS',
    'WaveField', 'Waves', 'drag_coefficient', 'drag_stability_limit', 'hookimpl', 'jonswap',
    'local_plane', 'log_layer_drag', 'plane_coords', 'plane_curvature', 'plane_evaluate',
    'record_type', 'siku_register_fields', 'siku_register_forcing_sources', 'wave_forces',
    'wavenumber', 'wrap_phase',
)
_MOVES.update(dict.fromkeys(_0, 'siku_forcing.waves.wave_field'))
__getattr__ = moved_names(__name__, _MOVES)
