"""Scenes: the TOML file and its validation (``scene_file``), the Python builder (``scene_api``),
their messages, durations with units, packs and the smallest free cells.

The module ``siku_core.scene`` of siku 0.1 is
:mod:`siku_core.scene.scene_file` since 0.2.0.

Each name that this module held keeps importing from here, with a
:class:`DeprecationWarning` naming its new home (:func:`siku_core.deprecation.moved_names`).
"""
from siku_core.deprecation import moved_names

_MOVES: dict[str, str] = {}
_0 = (
    'ComponentCfg', 'ContactCfg', 'CoverCfg', 'Duration', 'ElementsCfg', 'FieldCfg',
    'FlagName', 'ForcingCfg', 'MAX_DEPTH', 'MaterialCfg', 'MeshCfg', 'OutputCfg', 'PackCfg',
    'Pair', 'PlanetCfg', 'PolygonCfg', 'ProcessCfg', 'RunCfg', 'Scene', 'SceneCfg',
    'SceneError', 'SourceCfg', 'TimeCfg', 'UTCDateTime', 'WriterCfg', 'apply_overrides',
    'check_argument', 'explain_validation_error', 'format_validation_error', 'is_duration',
    'is_path', 'load_scene', 'override_value', 'parse_duration', 'parse_toml',
    'read_input_text', 'refuse_unitless_durations', 'scene_from_text',
)
_MOVES.update(dict.fromkeys(_0, 'siku_core.scene.scene_file'))
__getattr__ = moved_names(__name__, _MOVES)
