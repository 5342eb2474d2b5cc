"""Linear kinematic features (siku_io.analysis.lkf) on fields with known answers.

Points on a triangular lattice of spacing ``H`` (its Delaunay cells are equilateral, unique);
a *crack* is a straight line between lattice rows across which the points on one side slide
along it. Each side moves rigidly, so only the cells straddling a line deform: the active cells
are exactly the bands along the cracks, and a crack along a lattice direction (0 or 60 deg) is a
band whose centroids lie on two lines parallel to it, so its principal axis is the crack's
direction within the tilt that one cell more at one end of a line than the other gives: at most
a row's height over the feature's length (``ROW / length`` rad). Two such cracks crossing are
one group of cells; split at the junction they give arms along 0 and 60 deg whose intersection
angles are 60 deg. The points are material points: a crack active over two intervals is one
track living two intervals.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_io.analysis.lkf import detect, intersection_angles, lifetimes, segment_distance
from siku_io.analysis.sirex import DAY, cell_gradients, cells, sirex, total_rate

H = 5e3  # lattice spacing [m]
N = 60  # points a row and rows
T = 3600.0  # interval [s]
SLIP = 0.01 * H  # slide per interval [m]: a straddling cell deforms at about 0.2 /day


def lattice():
    i, j = np.meshgrid(np.arange(N), np.arange(N))
    x = (i + 0.5 * (j % 2)) * H
    y = j * H * np.sqrt(3.0) / 2.0
    return x.ravel().astype(float), y.ravel().astype(float)


def slide(x, y, angle_deg, offset):
    """Displacement [m] of the points on the left of the line through the lattice's middle,
    shifted ``offset`` [m] across it, at ``angle_deg``: ``SLIP`` along the line."""
    t = np.radians(angle_deg)
    d = np.array([np.cos(t), np.sin(t)])
    cx, cy = 0.5 * x.max(), 0.5 * y.max()
    left = (d[0] * (y - cy) - d[1] * (x - cx)) > offset
    return np.where(left, SLIP * d[0], 0.0), np.where(left, SLIP * d[1], 0.0)


def interval_features(x0, y0, dx, dy):
    tri = cells(x0, y0)
    grad, _, cx, cy = cell_gradients(x0, y0, x0 + dx, y0 + dy, tri, T)
    return detect(tri, total_rate(grad), cx, cy, 0.05 / DAY), tri


# offsets half a row (a quarter spacing) off the lattice's points
ROW = H * np.sqrt(3.0) / 2.0


def tilt(f) -> float:
    """The largest tilt [deg] of a lattice-aligned feature's axis (module docstring)."""
    return float(np.degrees(ROW / f.length))


def test_a_straight_crack_is_one_feature_along_it():
    x, y = lattice()
    dx, dy = slide(x, y, 0.0, 0.25 * ROW)
    fs, _ = interval_features(x, y, dx, dy)
    assert len(fs) == 1
    assert min(fs[0].angle, 180.0 - fs[0].angle) < tilt(fs[0])
    assert (N - 3) * H <= fs[0].length <= N * H


def test_crossing_cracks_split_into_arms_at_sixty_degrees():
    x, y = lattice()
    ax, ay = slide(x, y, 0.0, 0.25 * ROW)
    bx, by = slide(x, y, 60.0, 0.25 * ROW)
    fs, _ = interval_features(x, y, ax + bx, ay + by)
    # the arms: each along one of the cracks
    assert len(fs) >= 3
    for f in fs:
        assert min(abs(f.angle - 0.0), abs(f.angle - 180.0), abs(f.angle - 60.0)) < tilt(f)
    angles = intersection_angles(fs, 3.0 * H)
    worst = 2 * max(tilt(f) for f in fs)
    assert len(angles) >= 2 and np.allclose(angles, 60.0, atol=worst)
    # the arms of one crack are parallel: not counted as intersecting
    assert len(angles) <= sum(1 for f in fs if f.angle < 30) * sum(1 for f in fs if f.angle > 30)


def test_a_crack_lives_while_it_is_active():
    """Crack A slides during intervals 0 and 1, crack B (a row apart from no point of A's
    band) only during interval 2: two tracks, of two intervals and of one."""
    x, y = lattice()
    a = slide(x, y, 0.0, 0.25 * ROW - 10 * ROW)
    b = slide(x, y, 0.0, 0.25 * ROW + 10 * ROW)
    moves = [a, a, b]
    pos = [(x.copy(), y.copy())]
    for dx, dy in moves:
        px, py = pos[-1]
        pos.append((px + dx, py + dy))
    per = [interval_features(*pos[k], *moves[k])[0] for k in range(3)]
    assert [len(f) for f in per] == [1, 1, 1]
    assert sorted(lifetimes(per, T)) == [T, 2 * T]
    s = sirex(pos, T, [4 * H, 8 * H], lkf_rate=0.05 / DAY)
    assert sorted(s.lkf_lifetimes) == [T, 2 * T] and s.lkf_counts == [1, 1, 1]
    assert len(s.lkf_intersections) == 0
    assert "median lifetime" in s.table()


def test_segment_distance():
    assert segment_distance((0, 0), (2, 0), (1, -1), (1, 1)) == 0.0  # crossing
    assert segment_distance((0, 0), (2, 0), (0, 3), (2, 3)) == pytest.approx(3.0)  # parallel
    assert segment_distance((0, 0), (1, 0), (4, 4), (4, 5)) == pytest.approx(5.0)  # apart
