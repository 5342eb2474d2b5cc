"""The coherent clip (``siku_core.geometry.coherent``) gives the full clip's result to round-off
wherever its check accepts a hint, and the full clip's result bit for bit where it declines.

Fuzzed (hypothesis): two convex polygons (3 to 6 vertices; quadrilaterals take the engine's
unrolled path), the second then rotated about a point and translated by a small or a large
amount, so that the crossing edges of the first configuration (the hint) may or may not still
cross; pairs pressed into touching; pairs moved apart. The bound is the one
``tests/contacts/test_clip_variants.py`` derives for two exact methods that compute every
vertex of the overlap from coordinates of size ``L`` to ``delta = 10 eps L / sin(theta)``
(``theta`` the smallest angle at which two edges cross): areas to the perimeter times
``delta``, centroids to that times ``2 L`` over the area, crossing points to ``delta``
(unordered), normals to ``4 delta`` over the chord, and the crossings counted alike.

The strongest check is :func:`test_every_accepted_hint_is_the_overlap`: every one of the
``n1² n2²`` possible hints of a pair is tried, and every hint the check accepts must give the
clip's overlap; so the check is sound whatever the engine kept (a check that dropped the test
of either chain, of ``X`` or ``Y`` inside the other polygon, or of the margins fails it).
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from siku_core.geometry.clip import REL_TOL, make_overlap_scratch, overlap_inline
from siku_core.geometry.coherent import (
    NO_HINT,
    coherent_overlap,
    crossing_edges,
    overlap_coherent,
    pack_hint,
)
from tests.contacts.test_clip_variants import _cross, _quad

EPS = np.finfo(float).eps


def _poly(angles, radius, centre=(0.0, 0.0)):
    """A convex CCW polygon with vertices at ``angles`` on a circle (the tests' quadrilateral
    generator for any count)."""
    return _quad(angles, radius, centre)


def angles(n):
    return st.lists(st.floats(0.0, 2 * math.pi), min_size=n, max_size=n).filter(
        lambda a: min(np.diff(np.r_[np.sort(a), min(a) + 2 * math.pi])) > 0.3)


sizes = st.integers(3, 6)


def _crossing_sine(A, B):
    """Smallest ``|sin|`` of the angle between an edge of ``A`` and one of ``B`` that cross."""
    smin = 1.0
    for k in range(len(A)):
        a0, a1 = A[k], A[(k + 1) % len(A)]
        for m in range(len(B)):
            b0, b1 = B[m], B[(m + 1) % len(B)]
            ea, eb = a1 - a0, b1 - b0
            if _cross(eb, a0 - b0) * _cross(eb, a1 - b0) < 0 and \
                    _cross(ea, b0 - a0) * _cross(ea, b1 - a0) < 0:
                smin = min(smin, abs(_cross(ea, eb)) / (np.linalg.norm(ea) * np.linalg.norm(eb)))
    return smin


def _clip(A, B):
    xy, tag = make_overlap_scratch(len(A), len(B))
    c = B.mean(axis=0)  # a point inside B stands for its centre
    return overlap_inline(A, B, xy, tag, c[0], c[1], False), c


def _agree(A, B, ref, coh):
    """``coh`` (coherent_overlap's tuple, accepted) is ``ref`` (the clip's) to round-off."""
    L = max(np.abs(A).max(), np.abs(B).max())
    delta = 10 * EPS * L / _crossing_sine(A, B)
    area = ref[0]
    assert coh[4] == ref[3] == 2
    assert abs(coh[1] - area) <= 10 * L * delta
    assert max(abs(coh[2] - ref[1]), abs(coh[3] - ref[2])) <= 10 * L * delta * (2 * L) / area
    p = np.array([[ref[4], ref[5]], [ref[6], ref[7]]])
    q = np.array([[coh[5], coh[6]], [coh[7], coh[8]]])
    assert min(np.abs(p - q).max(), np.abs(p - q[::-1]).max()) <= delta
    chord = math.hypot(*(p[1] - p[0]))
    assert max(abs(coh[9] - ref[8]), abs(coh[10] - ref[9])) <= 4 * delta / chord


def _hint_of(A, B):
    ref, _ = _clip(A, B)
    return crossing_edges(A, B, ref[4], ref[5], ref[6], ref[7]) if ref[3] == 2 else NO_HINT


def _moved(B, turn, shift, about):
    c, s = math.cos(turn), math.sin(turn)
    return (B - about) @ np.array([[c, s], [-s, c]]) + about + shift


def _check_step(A, B, h):
    """One evaluation from hint ``h``: accepted means the clip's overlap to round-off;
    :func:`overlap_coherent` returns either that or the clip's tuple bit for bit, and keeps
    the hint of the clip's crossings when it clips."""
    ref, c = _clip(A, B)
    coh = coherent_overlap(A, B, c[0], c[1], h)
    if coh[0]:
        _agree(A, B, ref, coh)
    hints = np.array([h], np.int32)
    xy, tag = make_overlap_scratch(len(A), len(B))
    got = overlap_coherent(A, B, xy, tag, c[0], c[1], False, hints, 0)
    if coh[0]:
        assert got == tuple(coh[1:]) and hints[0] == h
    else:
        assert got == ref  # the fallback is the clip, bit for bit
        assert hints[0] == (_hint_of(A, B) if ref[3] == 2 else NO_HINT)
    return coh[0]


@settings(max_examples=300, deadline=None)
@given(n1=sizes, n2=sizes, data=st.data(), lg_radius=st.floats(1.0, 4.0),
       ratio=st.floats(0.3, 2.0), dist=st.floats(0.0, 2.0), direction=st.floats(0, 2 * math.pi),
       lg_turn=st.floats(-8.0, 0.5), turn_sign=st.sampled_from([-1.0, 1.0]),
       lg_shift=st.floats(-8.0, -0.3), shift_dir=st.floats(0, 2 * math.pi))
def test_the_next_evaluation_from_the_last_crossings(n1, n2, data, lg_radius, ratio, dist,
                                                     direction, lg_turn, turn_sign, lg_shift,
                                                     shift_dir):
    """A pair, its hint from the clip, then the second polygon turned by ``10**lg_turn`` rad
    about a point of the first and moved by ``10**lg_shift`` of the size (tiny steps keep the
    crossing edges, large ones change them or part the pair): agree or clip in full."""
    r = 10.0 ** lg_radius
    A = _poly(data.draw(angles(n1)), r)
    B = _poly(data.draw(angles(n2)), r * ratio,
              (dist * r * math.cos(direction), dist * r * math.sin(direction)))
    h = _hint_of(A, B)
    _check_step(A, B, h)
    shift = 10.0 ** lg_shift * r * np.array([math.cos(shift_dir), math.sin(shift_dir)])
    B2 = _moved(B, turn_sign * 10.0 ** lg_turn, shift, A[0])
    _check_step(A, B2, h)


@settings(max_examples=40, deadline=None)
@given(n1=sizes, n2=sizes, data=st.data(), lg_radius=st.floats(1.0, 4.0),
       ratio=st.floats(0.3, 2.0), dist=st.floats(0.3, 1.8), direction=st.floats(0, 2 * math.pi))
def test_every_accepted_hint_is_the_overlap(n1, n2, data, lg_radius, ratio, dist, direction):
    r = 10.0 ** lg_radius
    A = _poly(data.draw(angles(n1)), r)
    B = _poly(data.draw(angles(n2)), r * ratio,
              (dist * r * math.cos(direction), dist * r * math.sin(direction)))
    ref, c = _clip(A, B)
    accepted = 0
    for a in range(n1):
        for b in range(n2):
            for cc in range(n1):
                for d in range(n2):
                    coh = coherent_overlap(A, B, c[0], c[1], pack_hint(a, b, cc, d))
                    if coh[0]:
                        _agree(A, B, ref, coh)
                        accepted += 1
    assert accepted <= 1  # only the true crossing edges describe the overlap
    if ref[3] == 2 and ref[0] > 2.0 * REL_TOL * max(np.abs(A).max(), np.abs(B).max()) ** 2:
        # a generic overlap (no vertex within 4 tol of a line of the other) is always found
        L = max(np.abs(A).max(), np.abs(B).max())
        clear = all(abs(_cross(A[(k + 1) % n1] - A[k], p - A[k])) >
                    8 * REL_TOL * L * np.linalg.norm(A[(k + 1) % n1] - A[k])
                    for k in range(n1) for p in B) and \
            all(abs(_cross(B[(k + 1) % n2] - B[k], p - B[k])) >
                8 * REL_TOL * L * np.linalg.norm(B[(k + 1) % n2] - B[k])
                for k in range(n2) for p in A)
        if clear:
            assert accepted == 1


@settings(max_examples=200, deadline=None)
@given(n1=sizes, n2=sizes, data=st.data(), lg_radius=st.floats(1.0, 4.0),
       dist=st.floats(0.2, 1.5), direction=st.floats(0, 2 * math.pi), edge=st.integers(0, 5),
       vertex=st.integers(0, 5), lg_off=st.floats(-15.0, -5.0),
       side=st.sampled_from([-1.0, 1.0]))
def test_near_a_tolerance_rule_it_agrees_or_clips(n1, n2, data, lg_radius, dist, direction, edge,
                                                  vertex, lg_off, side):
    """The second polygon moved across the first's edge ``edge`` until its vertex ``vertex``
    lies ``10**lg_off`` of the size off that edge's line (either side), with the hint of the
    pair before the move and of the pair after it: agree or clip in full."""
    r = 10.0 ** lg_radius
    A = _poly(data.draw(angles(n1)), r)
    B = _poly(data.draw(angles(n2)), r, (dist * r * math.cos(direction),
                                         dist * r * math.sin(direction)))
    h0 = _hint_of(A, B)
    edge %= n1
    vertex %= n2
    p0, p1 = A[edge], A[(edge + 1) % n1]
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    inward = np.array([-u[1], u[0]])
    B = B + (side * 10.0 ** lg_off * r - np.dot(B[vertex] - p0, inward)) * inward
    _check_step(A, B, h0)
    _check_step(A, B, _hint_of(A, B))


@settings(max_examples=200, deadline=None)
@given(n=sizes, data=st.data(), lg_radius=st.floats(1.0, 4.0), edge=st.integers(0, 5),
       lg_depth=st.floats(-16.0, -10.0), slide=st.floats(-0.5, 0.5))
def test_touching_and_nearly_touching_pairs_clip_in_full(n, data, lg_radius, edge, lg_depth,
                                                         slide):
    """The first polygon and its mirror image across an edge, slid along it and pressed into
    it by ``10**lg_depth`` of the size (the clip's touching case): every hint is declined."""
    r = 10.0 ** lg_radius
    A = _poly(data.draw(angles(n)), r)
    edge %= n
    p0, p1 = A[edge], A[(edge + 1) % n]
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    nrm = np.array([-u[1], u[0]])  # into A
    B = (A - 2.0 * ((A - p0) @ nrm)[:, None] * nrm)[::-1] + 10.0 ** lg_depth * r * nrm \
        + slide * (p1 - p0)
    c = B.mean(axis=0)
    for a in range(n):
        for b in range(n):
            for cc in range(n):
                for d in range(n):
                    assert not coherent_overlap(A, B, c[0], c[1], pack_hint(a, b, cc, d))[0]
    _check_step(A, B, _hint_of(A, B))


def test_a_pair_that_parts_clips_in_full_and_forgets_its_hint():
    """Two squares overlapping at a corner, then moved apart: the hint is declined, the result
    is the clip's (no overlap) and the pair keeps no hint."""
    A = np.array([[-500.0, -500.0], [500.0, -500.0], [500.0, 500.0], [-500.0, 500.0]])
    B = A + np.array([700.0, 600.0])
    h = _hint_of(A, B)
    assert h != NO_HINT and _check_step(A, B, h)
    hints = np.array([h], np.int32)
    xy, tag = make_overlap_scratch(4, 4)
    got = overlap_coherent(A, B + 500.0, xy, tag, 1200.0, 1100.0, False, hints, 0)
    assert got[0] == 0.0 and hints[0] == NO_HINT


def test_a_corner_overlap_is_exact():
    """Two squares overlapping at a corner, from the clip's hint: the exact overlap
    (300 m × 400 m, centroid (350, 300) m, crossings (500, 100) and (200, 500) m)."""
    A = np.array([[-500.0, -500.0], [500.0, -500.0], [500.0, 500.0], [-500.0, 500.0]])
    B = A + np.array([700.0, 600.0])
    coh = coherent_overlap(A, B, 700.0, 600.0, _hint_of(A, B))
    assert coh[0] and coh[4] == 2
    assert math.isclose(coh[1], 300.0 * 400.0, rel_tol=1e-14)
    assert math.isclose(coh[2], 350.0, rel_tol=1e-14) and math.isclose(coh[3], 300.0,
                                                                      rel_tol=1e-14)
    assert sorted([(coh[5], coh[6]), (coh[7], coh[8])]) == [(200.0, 500.0), (500.0, 100.0)]
