"""Points on the sphere for meshes: chords and arcs, spherical polygon areas (lon/lat <-> unit
vectors are :mod:`siku_core.geometry.sphere`'s)."""
from __future__ import annotations

import numpy as np

from siku_core.scene.scene_file import PlanetCfg

#: the default planet radius of a scene [m] (``[planet] radius``)
DEFAULT_RADIUS: float = PlanetCfg.model_fields["radius"].default


def unit_rows(p: np.ndarray) -> np.ndarray:
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def chord_of(arc_m, R: float):
    """Chord on the unit sphere of an arc length in metres."""
    return 2.0 * np.sin(np.minimum(np.asarray(arc_m, dtype=float) / (2.0 * R), np.pi / 2))


def arc_of(chord, R: float):
    """Arc length in metres of a chord on the unit sphere."""
    return 2.0 * R * np.arcsin(np.minimum(np.asarray(chord, dtype=float) / 2.0, 1.0))


def spherical_polygon_areas(offsets, xyz, R: float = 1.0) -> np.ndarray:
    """Areas of spherical polygons with great-circle edges (CSR of unit vectors) [R² units].

    Fan from the first vertex, each triangle by Oosterom–Strackee:
    ``tan(E/2) = a·(b×c) / (1 + a·b + b·c + c·a)``; counter-clockwise (seen from outside) is
    positive.
    """
    n = len(offsets) - 1
    out = np.zeros(n)
    lens = np.diff(offsets)
    first = np.repeat(offsets[:-1], np.maximum(lens - 2, 0))
    cell = np.repeat(np.arange(n), np.maximum(lens - 2, 0))
    k = np.arange(len(first)) - np.repeat(np.cumsum(np.maximum(lens - 2, 0)) -
                                          np.maximum(lens - 2, 0), np.maximum(lens - 2, 0))
    a = xyz[first]
    b = xyz[first + 1 + k]
    c = xyz[first + 2 + k]
    num = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = 1.0 + np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, c) + \
        np.einsum("ij,ij->i", c, a)
    np.add.at(out, cell, 2.0 * np.arctan2(num, den))
    return out * R * R
