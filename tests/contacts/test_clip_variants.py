"""``bench.clip_variants.boundary_quads`` (the boundary-integral clip of two quadrilaterals
measured against the engine's clip) gives the engine's result wherever it calls itself valid.

Fuzzed (hypothesis): two convex quadrilaterals, the second placed at a random offset, or with
one vertex set at a distance from 1e-13 to 1e-5 of the size off an edge line of the first
(the tolerance rules act below ``1e-9``), or as the first's mirror image across an edge moved
by as little (a touching pair). Wherever the variant is valid it agrees with
:func:`~siku_core.geometry.clip.overlap_inline` to round-off: both compute every vertex of
the overlap from coordinates of size ``L`` to within ``delta = 10 eps L / sin(theta)``, with
``theta`` the smallest angle at which two edges cross (a crossing of nearly parallel edges is
ill-conditioned in either method), so the areas agree to the perimeter (``< 8 L``) times
``delta``, the centroids to that times ``2 L`` over the area, the crossing points to
``delta`` (each, unordered) and the normals to about ``2 delta`` over the chord; the
crossings are counted alike. A touching pair is never valid.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from siku_core.geometry.clip import REL_TOL, make_overlap_scratch, overlap_inline

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.clip_variants import boundary_quads  # noqa: E402

EPS = np.finfo(float).eps

angles4 = st.lists(st.floats(0.0, 2 * math.pi), min_size=4, max_size=4).filter(
    lambda a: min(np.diff(np.r_[np.sort(a), min(a) + 2 * math.pi])) > 0.3)


def _quad(angles, radius, centre=(0.0, 0.0)):
    th = np.sort(np.asarray(angles))
    return np.c_[centre[0] + radius * np.cos(th), centre[1] + radius * np.sin(th)]


def _both(A, B):
    xy, tag = make_overlap_scratch(4, 4)
    w = np.empty(40)
    c = B.mean(axis=0)  # a point inside B stands for its centre
    ref = overlap_inline(A, B, xy, tag, c[0], c[1], False)
    return ref, boundary_quads(A, B, xy, w, c[0], c[1])


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _crossing_sine(A, B):
    """Smallest ``|sin|`` of the angle between an edge of ``A`` and an edge of ``B`` that
    cross (1 when none do): a crossing point at angle ``theta`` is found to about
    ``eps L / sin(theta)``."""
    smin = 1.0
    for k in range(4):
        a0, a1 = A[k], A[(k + 1) % 4]
        for m in range(4):
            b0, b1 = B[m], B[(m + 1) % 4]
            ea, eb = a1 - a0, b1 - b0
            s0 = _cross(eb, a0 - b0)
            s1 = _cross(eb, a1 - b0)
            t0 = _cross(ea, b0 - a0)
            t1 = _cross(ea, b1 - a0)
            if s0 * s1 < 0 and t0 * t1 < 0:
                smin = min(smin, abs(_cross(ea, eb)) / (np.linalg.norm(ea) * np.linalg.norm(eb)))
    return smin


def _agree(A, B, ref, var):
    """The variant's result is the engine's to the round-off of the overlap's vertices."""
    L = max(np.abs(A).max(), np.abs(B).max())
    delta = 10 * EPS * L / _crossing_sine(A, B)  # a vertex of the overlap, either method
    area = ref[0]
    assert var[4] == ref[3]  # the crossings, counted alike
    assert abs(var[1] - area) <= 10 * L * delta  # the perimeter (< 8 L) times delta
    assert max(abs(var[2] - ref[1]), abs(var[3] - ref[2])) <= 10 * L * delta * (2 * L) / area
    if ref[3] == 2:
        p = np.array([[ref[4], ref[5]], [ref[6], ref[7]]])
        q = np.array([[var[5], var[6]], [var[7], var[8]]])
        assert min(np.abs(p - q).max(), np.abs(p - q[::-1]).max()) <= delta
        chord = math.hypot(*(p[1] - p[0]))
        assert max(abs(var[9] - ref[8]), abs(var[10] - ref[9])) <= 4 * delta / chord


@settings(max_examples=300, deadline=None)
@given(a=angles4, b=angles4, lg_radius=st.floats(2.0, 4.0), ratio=st.floats(0.3, 2.0),
       dist=st.floats(0.0, 2.0), direction=st.floats(0.0, 2 * math.pi))
def test_where_valid_the_boundary_clip_is_the_engines_clip(a, b, lg_radius, ratio, dist,
                                                         direction):
    r = 10.0 ** lg_radius
    A = _quad(a, r)
    B = _quad(b, r * ratio, (dist * r * math.cos(direction), dist * r * math.sin(direction)))
    ref, var = _both(A, B)
    if var[0]:
        _agree(A, B, ref, var)


@settings(max_examples=300, deadline=None)
@given(a=angles4, b=angles4, lg_radius=st.floats(2.0, 4.0), dist=st.floats(0.2, 1.5),
       direction=st.floats(0.0, 2 * math.pi), edge=st.integers(0, 3), vertex=st.integers(0, 3),
       lg_off=st.floats(-13.0, -5.0), side=st.sampled_from([-1.0, 1.0]))
def test_near_a_tolerance_rule_it_agrees_or_declines(a, b, lg_radius, dist, direction, edge,
                                                     vertex, lg_off, side):
    """An overlapping pair, ``B`` then moved across ``A``'s edge ``edge`` until its vertex
    ``vertex`` lies ``10**lg_off`` of the size off that edge's line (either side): within
    three tolerances of it the variant declines; farther, it agrees where valid."""
    r = 10.0 ** lg_radius
    A = _quad(a, r)
    B = _quad(b, r, (dist * r * math.cos(direction), dist * r * math.sin(direction)))
    p0, p1 = A[edge], A[(edge + 1) % 4]
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    inward = np.array([-u[1], u[0]])
    off = side * 10.0 ** lg_off * r
    B = B + (off - np.dot(B[vertex] - p0, inward)) * inward
    ref, var = _both(A, B)
    L = max(np.abs(A).max(), np.abs(B).max())
    if abs(off) < 3.0 * REL_TOL * L:
        assert not var[0]
    elif var[0]:
        _agree(A, B, ref, var)


@settings(max_examples=200, deadline=None)
@given(a=angles4, lg_radius=st.floats(2.0, 4.0), edge=st.integers(0, 3),
       lg_depth=st.floats(-15.0, -10.0))
def test_a_touching_pair_is_never_valid(a, lg_radius, edge, lg_depth):
    """``A`` and its mirror image across an edge, pressed into it by ``10**lg_depth`` of the
    size: the engine's touching case (or apart); the variant declines."""
    r = 10.0 ** lg_radius
    A = _quad(a, r)
    p0, p1 = A[edge], A[(edge + 1) % 4]
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    nrm = np.array([-u[1], u[0]])  # into A
    B = (A - 2.0 * ((A - p0) @ nrm)[:, None] * nrm)[::-1] + 10.0 ** lg_depth * r * nrm
    _, var = _both(A, B)
    assert not var[0]


def test_a_plain_overlap_is_valid_and_the_engines():
    """Two unit-scaled squares overlapping at a corner: valid, and the exact overlap."""
    A = np.array([[-500.0, -500.0], [500.0, -500.0], [500.0, 500.0], [-500.0, 500.0]])
    B = A + np.array([700.0, 600.0])
    ref, var = _both(A, B)
    assert var[0]
    _agree(A, B, ref, var)
    assert math.isclose(var[1], 300.0 * 400.0, rel_tol=1e-14)
    assert math.isclose(var[2], 350.0, rel_tol=1e-14) and math.isclose(var[3], 300.0,
                                                                      rel_tol=1e-14)
