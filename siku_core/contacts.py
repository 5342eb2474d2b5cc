"""Deprecated: the entry points of the contact loops moved to
:mod:`siku_core.contact.contact_forces`, the contact-law layouts and break modes to
:mod:`siku_core.contact_law` (siku 0.2.0).

Each name that this module held keeps importing from here, with a
:class:`DeprecationWarning` naming its new home (:func:`siku_core.deprecation.moved_names`).
"""
from siku_core.deprecation import moved_names

_MOVES: dict[str, str] = {}
_0 = (
    'ContactElements', 'ContactIndex', 'JointTable', 'PairTable', 'chunk_bounds', 'claim',
    'collision_forces', 'contact_loops', 'gather_forces', 'instantiate', 'joint_forces',
    'tasks',
)
_MOVES.update(dict.fromkeys(_0, 'siku_core.contact.contact_forces'))
_1 = (
    'BREAK_COMPRESSION', 'BREAK_EXTERNAL', 'BREAK_FLEXURE', 'BREAK_MODES', 'BREAK_SHEAR',
    'BREAK_STRAIN', 'BREAK_TENSION', 'COLLISION_LAYOUT', 'G_AREA', 'G_AREA_I', 'G_AREA_J',
    'G_CX', 'G_CY', 'G_K', 'G_MEFF', 'G_NX', 'G_NY', 'G_SIZE', 'G_VX', 'G_VY', 'G_WIDTH',
    'JOINT_LAYOUT', 'J_AX', 'J_AY', 'J_BX', 'J_BY', 'J_DT', 'J_EI', 'J_EJ', 'J_HI', 'J_HJ',
    'J_K', 'J_L0', 'J_MEFF', 'J_NU', 'J_S1X', 'J_S1Y', 'J_S2X', 'J_S2Y', 'J_SIZE', 'J_VAX',
    'J_VAY', 'J_VBX', 'J_VBY', 'J_W', 'OUT_LAYOUT', 'layout_table',
)
_MOVES.update(dict.fromkeys(_1, 'siku_core.contact_law'))
__getattr__ = moved_names(__name__, _MOVES)
