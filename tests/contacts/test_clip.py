"""Narrow-phase kernels: convex polygon overlap (eq. 10 normal) and partner projection.

Tolerances: exact-arithmetic inputs (unit squares, octagons) must come out to a few ulp, stated as
1e-12 (coordinates O(1), a dozen float operations per vertex). Random polygons are compared with an
exact rational (``fractions.Fraction``) reference built by a different algorithm (vertex/edge
enumeration, not clipping), so any difference is the kernel's round-off: O(10) operations on O(1)
numbers, well inside 1e-11.
"""
from __future__ import annotations

import math
from fractions import Fraction
from typing import NamedTuple

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError

from siku_core.geometry.clip import (
    REL_TOL,
    make_overlap_scratch,
    overlap,
    overlap_scratch,
    polygon_area_centroid,
    project_partner,
)
from siku_core.geometry.quat import from_tangent, latlon_to_xyz, q_from_latlon, to_tangent

R_EARTH = 6_371_000.0


def square(x0, y0, a=1.0):
    return np.array([[x0, y0], [x0 + a, y0], [x0 + a, y0 + a], [x0, y0 + a]], dtype=float)


def regular(n, r=1.0, cx=0.0, cy=0.0, phase=0.0):
    t = phase + 2.0 * np.pi * np.arange(n) / n
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1)


def rotate(poly, angle, about=(0.0, 0.0)):
    c, s = math.cos(angle), math.sin(angle)
    p = poly - np.asarray(about)
    return np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], axis=1) + about


def centroid(poly):
    _, cx, cy = polygon_area_centroid(poly)
    return np.array([cx, cy])


class Result(NamedTuple):
    """``overlap``'s tuple with the points as arrays."""

    area: float
    c: np.ndarray
    ncross: int
    p1: np.ndarray
    p2: np.ndarray
    n: np.ndarray


def unpack(res):
    area, cx, cy, ncross, p1x, p1y, p2x, p2y, nx, ny = res
    return Result(
        area, np.array([cx, cy]), ncross, np.array([p1x, p1y]), np.array([p2x, p2y]),
        np.array([nx, ny]),
    )


def assert_finite_unit_normal(res):
    assert all(math.isfinite(v) for v in res)
    r = unpack(res)
    assert r.area >= 0.0
    assert abs(np.hypot(*r.n) - 1.0) < 1e-12


def assert_oriented(res, poly1, poly2):
    """n points from polygon 1 towards polygon 2."""
    n = unpack(res)[5]
    d = centroid(poly2) - centroid(poly1)
    assert n @ d >= -1e-12 * max(1.0, np.hypot(*d))


def assert_point_sets_close(a, b, tol):
    a = sorted(map(tuple, a))
    b = sorted(map(tuple, b))
    assert len(a) == len(b)
    for p, q in zip(a, b):
        assert math.hypot(p[0] - q[0], p[1] - q[1]) <= tol, (a, b)


# --------------------------------------------------------------------------- exact reference
def _exact_cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _inside_exact(p, poly):
    n = len(poly)
    return all(_exact_cross(poly[k], poly[(k + 1) % n], p) >= 0 for k in range(n))


def exact_reference(poly1, poly2):
    """Exact overlap of two CCW convex polygons with generic float vertices (rational arithmetic).

    Different algorithm from the kernel: the overlap polygon's vertices are the vertices of each
    polygon inside the other plus the proper edge-edge intersections (the boundary crossings),
    ordered by angle about their mean. Returns (area, centroid, crossing points) as Fractions.
    """
    p1 = [(Fraction(x), Fraction(y)) for x, y in poly1]
    p2 = [(Fraction(x), Fraction(y)) for x, y in poly2]
    pts = [p for p in p1 if _inside_exact(p, p2)] + [p for p in p2 if _inside_exact(p, p1)]
    cross = []
    n1, n2 = len(p1), len(p2)
    for i in range(n1):
        a, b = p1[i], p1[(i + 1) % n1]
        for k in range(n2):
            c, d = p2[k], p2[(k + 1) % n2]
            d1, d2 = _exact_cross(c, d, a), _exact_cross(c, d, b)
            d3, d4 = _exact_cross(a, b, c), _exact_cross(a, b, d)
            if d1 * d2 < 0 and d3 * d4 < 0:
                t = d1 / (d1 - d2)
                cross.append((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])))
    pts += cross
    if len(pts) < 3:
        return Fraction(0), None, cross
    mx = sum(float(p[0]) for p in pts) / len(pts)
    my = sum(float(p[1]) for p in pts) / len(pts)
    pts.sort(key=lambda p: math.atan2(float(p[1]) - my, float(p[0]) - mx))
    a2 = Fraction(0)
    sx = Fraction(0)
    sy = Fraction(0)
    for i in range(len(pts)):
        (xa, ya), (xb, yb) = pts[i], pts[(i + 1) % len(pts)]
        cr = xa * yb - xb * ya
        a2 += cr
        sx += (xa + xb) * cr
        sy += (ya + yb) * cr
    if a2 == 0:
        return Fraction(0), None, cross
    return a2 / 2, (sx / (3 * a2), sy / (3 * a2)), cross


def random_convex(rng, n_points, center_spread=1.0):
    c = rng.uniform(-center_spread, center_spread, 2)
    r = rng.uniform(0.3, 1.0)
    pts = c + r * rng.uniform(-1, 1, (n_points, 2))
    hull = ConvexHull(pts)
    return np.ascontiguousarray(pts[hull.vertices])  # counter-clockwise in 2-D


# --------------------------------------------------------------------------- analytic cases
def test_offset_squares_generic_two_crossings():
    """Unit squares offset by (0.5, 0.25): overlap [0.5,1]x[0.25,1], crossings (0.5,1), (1,0.25)."""
    a, b = square(0, 0), square(0.5, 0.25)
    res = overlap(a, b)
    area, c, ncross, p1, p2, n = unpack(res)
    assert abs(area - 0.375) < 1e-12
    assert np.allclose(c, [0.75, 0.625], atol=1e-12, rtol=0)
    assert ncross == 2
    assert_point_sets_close([p1, p2], [(0.5, 1.0), (1.0, 0.25)], 1e-12)
    # perpendicular to P1P2 = (0.5, -0.75), pointing from a to b
    expected = np.array([0.75, 0.5]) / math.hypot(0.75, 0.5)
    assert np.allclose(n, expected, atol=1e-12, rtol=0)
    assert abs(n @ (p2 - p1)) < 1e-12


def test_offset_squares_collinear_edges_use_centroid_line():
    """Offset (0.5, 0): top and bottom edges collinear, area 0.5, centroid (0.75, 0.5), n = (1, 0).

    Both boundaries overlap along segments; the crossing count is not 2 (collinear stretches are
    class changes), so the normal follows the centroid line (1, 0).
    """
    a, b = square(0, 0), square(0.5, 0)
    for p, q, nref in ((a, b, (1.0, 0.0)), (b, a, (-1.0, 0.0))):
        area, c, ncross, _, _, n = unpack(overlap(p, q))
        assert abs(area - 0.5) < 1e-12
        assert np.allclose(c, [0.75, 0.5], atol=1e-12, rtol=0)
        assert ncross != 2
        assert np.allclose(n, nref, atol=1e-12, rtol=0)


def test_square_over_rotated_square_is_regular_octagon():
    """Square of side 1 and its 45° rotation about the centre: regular octagon of inradius 1/2.

    Area = 8 tan(pi/8) (1/2)² = 2 (sqrt(2) - 1); eight crossings; concentric, so n = (1, 0).
    """
    a = square(-0.5, -0.5)
    b = rotate(a, math.pi / 4)
    area, c, ncross, _, _, n = unpack(overlap(a, b))
    assert abs(area - 2.0 * (math.sqrt(2.0) - 1.0)) < 1e-12
    assert np.allclose(c, [0.0, 0.0], atol=1e-12)
    assert ncross == 8
    assert np.allclose(n, [1.0, 0.0], atol=1e-12, rtol=0)


def test_star_of_david_triangles():
    """Two equilateral triangles (circumradius 1) rotated by 60°: regular hexagon, 6 crossings.

    Hexagon area = 2/3 of the triangle's 3 sqrt(3)/4, i.e. sqrt(3)/2.
    """
    t1 = regular(3, 1.0, phase=math.pi / 2)
    t2 = regular(3, 1.0, phase=-math.pi / 2)
    area, c, ncross, _, _, _ = unpack(overlap(t1, t2))
    assert abs(area - math.sqrt(3.0) / 2.0) < 1e-12
    assert np.allclose(c, [0.0, 0.0], atol=1e-12)
    assert ncross == 6


def test_triangle_cutting_square_corner():
    """Triangle (0.5,0.5), (1.5,0.5), (0.5,1.5) over the unit square: its hypotenuse x + y = 2
    only touches the square's corner (1, 1), so the overlap is [0.5,1]² (area 0.25); the
    boundaries cross at (1, 0.5) and (0.5, 1) and n is perpendicular to that chord."""
    sq = square(0, 0)
    tri = np.array([[0.5, 0.5], [1.5, 0.5], [0.5, 1.5]])
    res = overlap(sq, tri)
    assert_finite_unit_normal(res)
    area, c, ncross, p1, p2, n = unpack(res)
    assert abs(area - 0.25) < 1e-12
    assert np.allclose(c, [0.75, 0.75], atol=1e-12, rtol=0)
    assert ncross == 2
    assert_point_sets_close([p1, p2], [(1.0, 0.5), (0.5, 1.0)], 1e-12)
    assert np.allclose(n, [math.sqrt(0.5), math.sqrt(0.5)], atol=1e-12, rtol=0)


@pytest.mark.parametrize("inner_first", [True, False])
def test_contained_polygon_gives_inner_area_and_centroid(inner_first):
    outer = regular(7, 2.0, 0.1, -0.2)
    inner = regular(5, 0.5, 0.4, 0.3, phase=0.3)
    a_in, cx, cy = polygon_area_centroid(inner)
    p, q = (inner, outer) if inner_first else (outer, inner)
    res = overlap(p, q)
    assert_finite_unit_normal(res)
    area, c, ncross, _, _, n = unpack(res)
    assert abs(area - a_in) < 1e-12
    assert np.allclose(c, [cx, cy], atol=1e-12, rtol=0)
    assert ncross == 0
    d = centroid(q) - centroid(p)
    assert np.allclose(n, d / np.hypot(*d), atol=1e-12, rtol=0)


def test_contained_concentric_normal_is_x():
    outer = square(-1, -1, 2.0)
    inner = square(-0.25, -0.25, 0.5)
    area, _, ncross, _, _, n = unpack(overlap(inner, outer))
    assert abs(area - 0.25) < 1e-12
    assert ncross == 0
    assert tuple(n) == (1.0, 0.0)


def test_inner_polygon_sharing_an_edge():
    """[0,0.5]x[0,1] inside the unit square, sharing its left edge: the inner boundary enters the
    outer's interior at (0.5, 0) and (0.5, 1), so n is perpendicular to that chord: (+-1, 0)."""
    sq = square(0, 0)
    half = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 1.0], [0.0, 1.0]])
    for p, q, nx in ((sq, half, -1.0), (half, sq, 1.0)):
        res = overlap(p, q)
        area, c, ncross, p1, p2, n = unpack(res)
        assert abs(area - 0.5) < 1e-12
        assert np.allclose(c, [0.25, 0.5], atol=1e-12, rtol=0)
        assert ncross == 2
        assert_point_sets_close([p1, p2], [(0.5, 0.0), (0.5, 1.0)], 1e-12)
        assert np.allclose(n, [nx, 0.0], atol=1e-12, rtol=0)


@pytest.mark.parametrize(
    "other, nref",
    [
        (square(1, 0), (1.0, 0.0)),  # full shared edge
        (square(1, 0.5), (1.0, 0.5)),  # half shared edge
        (square(1, 1), (1.0, 1.0)),  # corner to corner
        (np.array([[1.0, 0.5], [2.0, 0.0], [2.0, 1.0]]), None),  # vertex on an edge
    ],
)
def test_touching_gives_zero_area_and_finite_normal(other, nref):
    sq = square(0, 0)
    for p, q in ((sq, other), (other, sq)):
        res = overlap(p, q)
        assert_finite_unit_normal(res)
        area, c, ncross, _, _, n = unpack(res)
        assert area <= 1e-15
        assert ncross == 0
        d = centroid(q) - centroid(p)
        assert np.allclose(n, d / np.hypot(*d), atol=1e-12, rtol=0)
        assert_oriented(res, p, q)
        if nref is not None and p is sq:
            assert np.allclose(n, np.array(nref) / np.hypot(*nref), atol=1e-12, rtol=0)
        # the reported point is where they touch: on the boundary of both (x == 1)
        assert abs(c[0] - 1.0) < 1e-12


def test_disjoint_gives_zero_and_centroid_line():
    a = square(0, 0)
    b = square(3, 4)
    res = overlap(a, b)
    assert_finite_unit_normal(res)
    area, c, ncross, p1, p2, n = unpack(res)
    assert area == 0.0 and ncross == 0
    assert tuple(c) == (0.0, 0.0) and tuple(p1) == (0.0, 0.0) and tuple(p2) == (0.0, 0.0)
    assert np.allclose(n, [0.6, 0.8], atol=1e-15, rtol=0)


@pytest.mark.parametrize("nverts", [3, 4, 6, 64])
def test_identical_polygons(nverts):
    p = regular(nverts, 1.3, 0.2, -0.1, phase=0.2)
    a_ref, cx, cy = polygon_area_centroid(p)
    res = overlap(p, p.copy())
    assert_finite_unit_normal(res)
    area, c, ncross, _, _, n = unpack(res)
    assert abs(area - a_ref) <= 1e-12 * a_ref
    assert np.allclose(c, [cx, cy], atol=1e-12, rtol=0)
    assert ncross == 0
    assert tuple(n) == (1.0, 0.0)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("nverts", [3, 6, 64])
def test_nearly_identical_polygons(seed, nverts):
    """Vertices perturbed by up to 1e-12 (below REL_TOL): area within 1e-9 relative, finite."""
    rng = np.random.default_rng(seed)
    p = regular(nverts, 1.0, phase=rng.uniform(0, 1))
    q = p + rng.uniform(-1e-12, 1e-12, p.shape)
    a_ref = polygon_area_centroid(p)[0]
    for x, y in ((p, q), (q, p)):
        res = overlap(x, y)
        assert_finite_unit_normal(res)
        area, c, _, _, _, _ = unpack(res)
        assert abs(area - a_ref) <= 1e-9 * a_ref
        assert np.allclose(c, [0.0, 0.0], atol=1e-9)
        assert_oriented(res, x, y)


def test_nearly_touching_and_slivers_are_finite():
    sq = square(0, 0)
    for dx in (1.0 - 1e-15, 1.0 - 1e-12, 1.0 - 1e-9, 1.0 + 1e-15, 1.0 + 1e-12):
        for dy in (0.0, 1e-13, 0.5, 1.0 - 1e-13):
            for ang in (0.0, 1e-14, 1e-9):
                other = rotate(square(dx, dy), ang, about=(dx, dy))
                for p, q in ((sq, other), (other, sq)):
                    res = overlap(p, q)
                    assert_finite_unit_normal(res)
                    assert_oriented(res, p, q)
                    # at most a strip 1e-9 wide plus the 1e-9 rad tilt's triangle (1e-9/2)
                    assert res[0] <= 2e-9


def test_clockwise_partner_is_accepted():
    a, b = square(0, 0), square(0.5, 0.25)
    ref = unpack(overlap(a, b))
    res = unpack(overlap(a, b[::-1].copy()))
    assert abs(res[0] - ref[0]) < 1e-14 and res[2] == ref[2] == 2
    assert np.allclose(res[1], ref[1], atol=1e-14) and np.allclose(res[5], ref[5], atol=1e-14)
    assert_point_sets_close([res[3], res[4]], [ref[3], ref[4]], 1e-14)


def test_scratch_version_matches_and_checks_size():
    a, b = regular(6, 1.0), regular(5, 0.8, 0.7, 0.2)
    xy, tag = make_overlap_scratch(64, 64)
    assert overlap_scratch(a, b, xy, tag) == overlap(a, b)
    xy_small = np.empty((2, 3, 2))
    tag_small = np.empty((2, 3), dtype=np.int64)
    with pytest.raises(ValueError):
        overlap_scratch(a, b, xy_small, tag_small)


def test_physical_scale_and_offset_invariance():
    """Kilometre polygons in metres, 20 km from the tangent point: same geometry as unit ones."""
    a, b = square(0, 0), square(0.5, 0.25)
    ref = unpack(overlap(a, b))
    s, off = 1500.0, np.array([2.0e4, -1.3e4])
    res = unpack(overlap(a * s + off, b * s + off))
    assert abs(res[0] - ref[0] * s * s) < 1e-12 * s * s
    assert np.allclose(res[1], ref[1] * s + off, atol=1e-12 * 2e4, rtol=0)
    assert res[2] == 2
    assert np.allclose(res[5], ref[5], atol=1e-12)


def test_polygon_area_centroid_shoelace():
    area, cx, cy = polygon_area_centroid(square(1, 2, 2.0))
    assert (area, cx, cy) == (4.0, 2.0, 3.0)
    area, cx, cy = polygon_area_centroid(square(1, 2, 2.0)[::-1].copy())
    assert area == -4.0 and (cx, cy) == (2.0, 3.0)
    area, cx, cy = polygon_area_centroid(np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.0]]))
    assert area == 0.0 and (cx, cy) == (1.0, 0.0)
    t = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    assert np.allclose(polygon_area_centroid(t), (4.5, 1.0, 1.0), atol=1e-15)


# --------------------------------------------------------------------------- random, vs exact
def _random_pairs(seed, count, npts_range=(3, 14)):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        p = random_convex(rng, rng.integers(*npts_range))
        q = random_convex(rng, rng.integers(*npts_range))
        out.append((p, q))
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_convex_polygons_against_exact_reference(seed):
    checked_two = 0
    checked_overlap = 0
    for p, q in _random_pairs(seed, 60):
        res = overlap(p, q)
        assert_finite_unit_normal(res)
        assert_oriented(res, p, q)
        area, c, ncross, p1, p2, n = unpack(res)
        a_ref, c_ref, cross_ref = exact_reference(p, q)
        assert abs(area - float(a_ref)) <= 1e-12
        # generic positions: the crossing count is the number of proper edge intersections
        if a_ref > REL_TOL * 4:  # not a sliver below the touching threshold
            checked_overlap += 1
            assert np.allclose(c, [float(c_ref[0]), float(c_ref[1])], atol=1e-11, rtol=0)
            assert ncross == len(cross_ref)
            if ncross == 2:
                checked_two += 1
                assert_point_sets_close(
                    [p1, p2], [(float(x), float(y)) for x, y in cross_ref], 1e-11
                )
                assert abs(n @ (p2 - p1)) <= 1e-12 * np.hypot(*(p2 - p1))
            else:
                d = centroid(q) - centroid(p)
                assert np.allclose(n, d / np.hypot(*d), atol=1e-12, rtol=0)
    assert checked_overlap > 15 and checked_two > 10


def test_degenerate_lattice_polygons_against_exact_reference():
    """Convex hulls of points on a 5x5 integer lattice: shared vertices, vertices on edges,
    collinear and identical edges, touching and containment in every combination. The area is
    exact (integer inputs, no round-off beyond a few ulp), every output is finite, the normal is
    oriented from 1 to 2 and perpendicular to P1P2 when there are two crossings, and swapping the
    polygons changes nothing but the normal's sign."""
    rng = np.random.default_rng(0)

    def lattice_poly():
        while True:
            pts = rng.integers(0, 5, (rng.integers(3, 7), 2)).astype(float)
            try:
                hull = ConvexHull(pts)
            except QhullError:  # all points collinear: draw again
                continue
            return np.ascontiguousarray(pts[hull.vertices])

    counts = set()
    for _ in range(400):
        p, q = lattice_poly(), lattice_poly()
        res = overlap(p, q)
        assert_finite_unit_normal(res)
        assert_oriented(res, p, q)
        r = unpack(res)
        assert abs(r.area - float(exact_reference(p, q)[0])) <= 1e-12
        if r.ncross == 2:
            assert abs(r.n @ (r.p2 - r.p1)) <= 1e-12 * np.hypot(*(r.p2 - r.p1))
        r2 = unpack(overlap(q, p))
        assert abs(r2.area - r.area) <= 1e-12
        # opposite normals, unless the orientation rule cannot tell: n · (c2 - c1) == 0 (e.g. a
        # thin triangle piercing a quad, crossing chord parallel to the centroid line)
        d = centroid(q) - centroid(p)
        if abs(r.n @ d) > 1e-12:
            assert np.allclose(r2.n, -r.n, atol=1e-12)
        counts.add(r.ncross)
    assert {0, 2, 4} <= counts


def test_many_vertex_polygons_against_exact_reference():
    rng = np.random.default_rng(7)
    for _ in range(8):
        p = regular(64, rng.uniform(0.5, 1.0), *rng.uniform(-0.3, 0.3, 2), phase=rng.uniform())
        q = regular(rng.integers(3, 65), rng.uniform(0.5, 1.0), *rng.uniform(-0.9, 0.9, 2),
                    phase=rng.uniform())
        res = overlap(p, q)
        assert_finite_unit_normal(res)
        a_ref, _, cross_ref = exact_reference(p, q)
        assert abs(res[0] - float(a_ref)) <= 1e-12
        assert res[3] == len(cross_ref)


@pytest.mark.parametrize("seed", [11, 12])
def test_symmetry_area_equal_normals_opposite(seed):
    for p, q in _random_pairs(seed, 80):
        r12 = unpack(overlap(p, q))
        r21 = unpack(overlap(q, p))
        assert abs(r12[0] - r21[0]) <= 1e-12 * max(1.0, r12[0])
        assert r12[2] == r21[2]
        assert np.allclose(r12[5], -r21[5], atol=1e-9, rtol=0)
        if r12[0] > 0:
            assert np.allclose(r12[1], r21[1], atol=1e-11, rtol=0)


# --------------------------------------------------------------------------- projection
# Projected coordinates carry the round-off of unit vectors scaled by R: every rotation or
# normalisation rounds components of size 1 to ~1 ulp (2.2e-16), i.e. R * 2.2e-16 = 1.4e-9 m.
# The comparison chains ~4 such steps on each side, so 1e-8 m (1e-11 of a km element) bounds it.
PROJ_TOL_M = 1e-8

PAIRS_DEG = [
    ((45.0, 10.0), (45.01, 10.01)),  # mid-latitudes
    ((0.0, 179.995), (0.0, -179.995)),  # either side of the antimeridian
    ((60.0, -179.99), (60.005, 179.99)),  # antimeridian at high latitude
    ((89.995, 0.0), (89.995, 180.0)),  # either side of the north pole
    ((90.0, 0.0), (89.99, 123.0)),  # one element exactly at the pole
    ((-89.995, 30.0), (-89.995, -150.0)),  # south pole
]


@pytest.mark.parametrize("ll1, ll2", PAIRS_DEG)
def test_project_partner_maps_shared_global_points_consistently(ll1, ll2):
    q1 = q_from_latlon(math.radians(ll1[0]), math.radians(ll1[1]))
    q2 = q_from_latlon(math.radians(ll2[0]), math.radians(ll2[1]))
    c1 = latlon_to_xyz(math.radians(ll1[0]), math.radians(ll1[1]))
    c2 = latlon_to_xyz(math.radians(ll2[0]), math.radians(ll2[1]))
    assert 0.5e3 < R_EARTH * math.acos(min(1.0, c1 @ c2)) < 2e3  # km-sized separation
    rng = np.random.default_rng(0)
    pts = []
    for _ in range(50):  # global points between and around the two centres
        w = rng.uniform()
        g = w * c1 + (1 - w) * c2 + rng.normal(size=3) * 1e-4
        pts.append(g / np.linalg.norm(g))
    v2 = np.array([to_tangent(q2, g, R_EARTH) for g in pts])
    v1 = np.array([to_tangent(q1, g, R_EARTH) for g in pts])
    out = np.empty_like(v2)
    ret = project_partner(q1, q2, v2, R_EARTH, out)
    assert ret is out or np.shares_memory(ret, out)
    assert np.max(np.hypot(*(out - v1).T)) < PROJ_TOL_M
    # same as the helper chain from_tangent(q2) -> to_tangent(q1), vertex by vertex
    chain = np.array([to_tangent(q1, from_tangent(q2, x, y, R_EARTH), R_EARTH) for x, y in v2])
    assert np.max(np.hypot(*(out - chain).T)) < PROJ_TOL_M


@pytest.mark.parametrize("ll1, ll2", PAIRS_DEG)
def test_projected_neighbour_polygons_overlap_consistently(ll1, ll2):
    """Two 1 km hexagons centred on the two elements: the overlap seen from either element has the
    same area, and the projected partner stays counter-clockwise. Gnomonic projection maps great
    circles to lines, so both views are images of the same spherical overlap; their areas differ
    by the projection's area factor 1/cos³(r/R) ≈ 1 + 1.5 (r/R)² ≈ 1 + 2e-8 at r ≈ 700 m, and the
    two views see the overlap at about the same r, so 1e-7 relative bounds the difference."""
    q1 = q_from_latlon(math.radians(ll1[0]), math.radians(ll1[1]))
    q2 = q_from_latlon(math.radians(ll2[0]), math.radians(ll2[1]))
    hexagon = regular(6, 800.0, phase=0.1)
    p21 = project_partner(q1, q2, hexagon, R_EARTH, np.empty_like(hexagon))
    p12 = project_partner(q2, q1, hexagon, R_EARTH, np.empty_like(hexagon))
    assert polygon_area_centroid(p21)[0] > 0
    r1 = unpack(overlap(hexagon, p21))
    r2 = unpack(overlap(hexagon, p12))
    assert r1[0] > 1e4
    assert abs(r1[0] - r2[0]) <= 1e-7 * r1[0]


def test_project_partner_identity():
    q = q_from_latlon(0.3, -2.0)
    v = regular(5, 3000.0, 100.0, -50.0)
    out = project_partner(q, q, v, R_EARTH, np.empty_like(v))
    assert np.max(np.abs(out - v)) < PROJ_TOL_M
