"""Broad-phase kernels: brute force (reference), sweep and prune, and the 3-D cell grid agree
pair for pair, in mid-latitudes, around the north pole and across the antimeridian."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.geometry.quat import great_circle_distance
from siku_plugins.broad_phase.kernels import (
    brute_force_pairs,
    cell_grid_pairs,
    sweep_and_prune_pairs,
)

METHODS = {
    "sweep_and_prune": sweep_and_prune_pairs,
    "cell_grid": cell_grid_pairs,
}


def unit(lat_deg, lon_deg):
    lat = np.radians(lat_deg)
    lon = np.radians(lon_deg)
    return np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=-1)


def scene(kind, n=300, seed=0):
    """A cluster of ``n`` elements, mean spacing ~0.5°, radii 0.15–0.45° (a few neighbours each).

    * mid: 40–50°N, 10°W–10°E;
    * pole: 83–90°N, all longitudes, one element exactly at the pole;
    * antimeridian: 5°S–5°N, 175°E–185°E (stored as -180..180), several exactly at 180°.
    """
    rng = np.random.default_rng(seed)
    if kind == "mid":
        lat = rng.uniform(40, 50, n)
        lon = rng.uniform(-10, 10, n)
    elif kind == "pole":
        # uniform in area on the cap: cos(colatitude) uniform
        z = rng.uniform(math.cos(math.radians(7.0)), 1.0, n)
        lat = np.degrees(np.arcsin(z))
        lon = rng.uniform(-180, 180, n)
        lat[0] = 90.0
    elif kind == "antimeridian":
        lat = rng.uniform(-5, 5, n)
        lon = rng.uniform(175, 185, n)
        lon[:5] = 180.0
        lon = (lon + 180.0) % 360.0 - 180.0
    else:  # pragma: no cover
        raise ValueError(kind)
    centers = unit(lat, lon)
    radii = np.radians(rng.uniform(0.15, 0.45, n))
    skip = rng.random(n) < 0.3
    return centers, radii, skip


def reference_pairs(centers, radii, skin, skip, guard=1e-10):
    """Independent reference: arctan2 great-circle angles against the sum of the radii + skin.

    Returns (definitely in, ambiguous) sets; pairs within ``guard`` rad of the threshold are
    ambiguous (round-off decides) and excluded from the comparison.
    """
    n = len(radii)
    i, j = np.triu_indices(n, 1)
    ang = great_circle_distance(centers[i], centers[j])
    thr = np.minimum(radii[i] + radii[j] + skin, math.pi)
    keep = ~(skip[i] & skip[j])
    inside = keep & (ang <= thr - guard)
    close = keep & (np.abs(ang - thr) <= guard)
    return set(zip(i[inside].tolist(), j[inside].tolist())), set(
        zip(i[close].tolist(), j[close].tolist())
    )


def check_format(pairs):
    assert pairs.dtype == np.int64 and pairs.ndim == 2 and pairs.shape[1] == 2
    if len(pairs):
        assert np.all(pairs[:, 0] < pairs[:, 1])
        order = np.lexsort((pairs[:, 1], pairs[:, 0]))
        assert np.array_equal(order, np.arange(len(pairs)))
        assert len(np.unique(pairs, axis=0)) == len(pairs)


@pytest.mark.parametrize("kind", ["mid", "pole", "antimeridian"])
@pytest.mark.parametrize("skin_deg", [0.0, 0.05])
def test_all_methods_agree_with_brute_force(kind, skin_deg):
    centers, radii, skip = scene(kind)
    skin = math.radians(skin_deg)
    ref = brute_force_pairs(centers, radii, skin, skip)
    check_format(ref)
    assert len(ref) > 150  # a real contact network, not an empty scene
    inside, ambiguous = reference_pairs(centers, radii, skin, skip)
    got = set(map(tuple, ref.tolist()))
    assert inside <= got and not (got - inside - ambiguous)
    for name, method in METHODS.items():
        pairs = method(centers, radii, skin, skip)
        check_format(pairs)
        assert np.array_equal(pairs, ref), name


@pytest.mark.parametrize("kind", ["mid", "pole", "antimeridian"])
@pytest.mark.parametrize("axis", [0, 1, 2, -1])
def test_sweep_and_prune_any_axis(kind, axis):
    centers, radii, skip = scene(kind, seed=3)
    ref = brute_force_pairs(centers, radii, 0.001, skip)
    assert np.array_equal(sweep_and_prune_pairs(centers, radii, 0.001, skip, axis), ref)


def test_pairs_across_antimeridian_and_pole_are_found():
    """Neighbours split by lon = ±180° and by the pole are candidates."""
    centers = unit(np.array([0.0, 0.0, 89.9, 89.9]), np.array([179.9, -179.9, 0.0, 180.0]))
    radii = np.radians(np.full(4, 0.11))
    skip = np.zeros(4, dtype=bool)
    expected = np.array([[0, 1], [2, 3]])
    for method in (brute_force_pairs, sweep_and_prune_pairs, cell_grid_pairs):
        assert np.array_equal(method(centers, radii, 0.0, skip), expected)


@pytest.mark.parametrize("kind", ["mid", "pole", "antimeridian"])
def test_skip_drops_only_static_static_pairs(kind):
    centers, radii, skip = scene(kind, seed=5)
    none = np.zeros(len(radii), dtype=bool)
    full = brute_force_pairs(centers, radii, 0.0, none)
    both = skip[full[:, 0]] & skip[full[:, 1]]
    assert both.any() and (~both).any()
    expected = full[~both]
    for method in (brute_force_pairs, sweep_and_prune_pairs, cell_grid_pairs):
        assert np.array_equal(method(centers, radii, 0.0, skip), expected)
        assert len(method(centers, radii, 0.0, np.ones(len(radii), dtype=bool))) == 0


def _rotate_about(axis, v, angle):
    axis = axis / np.linalg.norm(axis)
    return (
        v * math.cos(angle)
        + np.cross(axis, v) * math.sin(angle)
        + axis * (axis @ v) * (1 - math.cos(angle))
    )


@pytest.mark.parametrize(
    "c1, c2, r1, r2, skin",
    [
        # quarter circle: angle exactly pi/2 = pi/8 + pi/8 + pi/4
        ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), math.pi / 8, math.pi / 8, math.pi / 4),
        # skin only, radii zero
        ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), 0.0, 0.0, math.pi / 2),
        # small angle on an oblique great circle: 0.01 + 0.02 + 0.005
        ("oblique", None, 0.01, 0.02, 0.005),
    ],
)
def test_pair_exactly_at_threshold_counts(c1, c2, r1, r2, skin):
    """Angle == r1 + r2 + skin (to round-off) is a candidate (<=); 1e-9 rad further is not."""
    if c1 == "oblique":
        a = unit(np.array(23.0), np.array(-71.0))
        c1 = a
        c2 = _rotate_about(np.cross(a, [0.3, 0.5, 0.8]), a, r1 + r2 + skin)
    centers = np.array([c1, c2], dtype=float)
    radii = np.array([r1, r2])
    skip = np.zeros(2, dtype=bool)
    for method in (brute_force_pairs, sweep_and_prune_pairs, cell_grid_pairs):
        assert np.array_equal(method(centers, radii, skin, skip), [[0, 1]])
        assert len(method(centers, radii, skin - 1e-9, skip)) == 0


def test_threshold_clamped_at_pi():
    """Radii summing past pi make every pair a candidate, antipodal ones included."""
    centers = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    radii = np.array([1.6, 1.6, 0.0])
    skip = np.zeros(3, dtype=bool)
    for method in (brute_force_pairs, sweep_and_prune_pairs, cell_grid_pairs):
        assert np.array_equal(method(centers, radii, 0.0, skip), [[0, 1], [0, 2], [1, 2]])


def test_empty_single_and_coincident():
    skip1 = np.zeros(1, dtype=bool)
    for method in (brute_force_pairs, sweep_and_prune_pairs, cell_grid_pairs):
        out = method(np.empty((0, 3)), np.empty(0), 0.0, np.zeros(0, dtype=bool))
        assert out.shape == (0, 2) and out.dtype == np.int64
        out = method(np.array([[0.0, 0.0, 1.0]]), np.array([0.1]), 0.0, skip1)
        assert out.shape == (0, 2)
        # coincident centres with zero radii touch (angle 0 <= 0)
        c = np.array([[0.6, 0.0, 0.8], [0.6, 0.0, 0.8], [0.0, 1.0, 0.0]])
        out = method(c, np.zeros(3), 0.0, np.zeros(3, dtype=bool))
        assert np.array_equal(out, [[0, 1]])


def test_global_scene_with_mixed_radii():
    """2000 elements over the whole sphere, radii spanning a factor 15: grid cells are sized by
    the largest radius, so this also exercises crowded cells."""
    rng = np.random.default_rng(42)
    n = 2000
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    # mean spacing sqrt(4 pi / n) = 0.08 rad; 2 % of the elements are five times larger
    radii = rng.uniform(0.02, 0.06, n) * np.where(rng.random(n) < 0.02, 5.0, 1.0)
    skip = rng.random(n) < 0.1
    ref = brute_force_pairs(v, radii, 0.002, skip)
    assert len(ref) > n
    for name, method in METHODS.items():
        assert np.array_equal(method(v, radii, 0.002, skip), ref), name
