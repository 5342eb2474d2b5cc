"""Leads as numbers (siku_io.analysis.leads): synthetic fields with known lines.

Lines drawn between cell centres (``skimage.draw.line``) must come back one lead each (a
crossing splits none of them), at their direction within 5 degrees and their length (between
the end cells' centres) within one cell (bands two cells wide: within two, as their skeleton
may stop half a cell short at each end); two crossing lines give one intersection at their
angle. The default scene's leads are in tests/test_default_scene.py.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_io.analysis.leads import detect
from siku_forcing.gridded.regular_grid import Grid, GridCfg

R = 6371e3
PS = GridCfg(kind="polar_stereographic", x=(-1.5e6, 1.5e6), y=(-1.5e6, 1.5e6),
             resolution=50e3)
LINES = [((10, 10), (40, 50)), ((5, 30), (55, 30)), ((45, 3), (56, 22)), ((2, 40), (2, 58))]


def draw(shape, lines, width=1):
    from skimage.draw import line

    m = np.zeros(shape, bool)
    for (r0, c0), (r1, c1) in lines:
        rr, cc = line(r0, c0, r1, c1)
        m[rr, cc] = True
    if width == 2:  # and the cells beside it: a band two cells wide
        m |= np.roll(m, 1, axis=1) | np.roll(m, 1, axis=0)
    return m


def truth(grid, lines):
    """Length [m] and direction [degrees from x] of each line in the grid's plane."""
    X, Y = np.meshgrid(grid.x, grid.y)
    out = []
    for (r0, c0), (r1, c1) in lines:
        dx, dy = X[r1, c1] - X[r0, c0], Y[r1, c1] - Y[r0, c0]
        out.append((math.hypot(dx, dy), math.degrees(math.atan2(dy, dx)) % 180.0))
    return out


def match(found, expected, cell):
    """Pair each expected line with the found lead nearest in direction and length; each
    within 5 degrees and ``cell`` [m] of it."""
    assert len(found) == len(expected)
    left = list(found)
    for length, angle in expected:
        best = min(left, key=lambda f: abs(f.length - length) / cell + min(
            abs(f.orientation - angle), 180 - abs(f.orientation - angle)) / 5)
        left = [f for f in left if f is not best]
        d = abs(best.orientation - angle) % 180
        assert min(d, 180 - d) < 5.0, (best.orientation, angle)
        assert abs(best.length - length) <= cell, (best.length, length)


@pytest.mark.parametrize("width", [1, 2])
def test_synthetic_lines_come_back_as_leads(width):
    grid = Grid(PS, R)
    m = draw(grid.shape, LINES, width)
    leads, crossings = detect(m, grid, min_length=3)
    # the skeleton of a band w cells wide stops up to (w - 1)/2 cells short of each end
    match(leads, truth(grid, LINES), 50e3 * (1 + (width - 1)))
    # the first two lines cross once
    assert len(crossings) == 1
    (a, b), angle = crossings[0].leads, crossings[0].angle
    want = {round(t[1]) for t in truth(grid, LINES[:2])}
    assert {round(leads[a].orientation), round(leads[b].orientation)} <= {
        w + d for w in want for d in range(-4, 5)}
    exp = abs(truth(grid, LINES[:1])[0][1] - truth(grid, LINES[1:2])[0][1]) % 180
    assert angle == pytest.approx(min(exp, 180 - exp), abs=5.0)


def test_leads_on_a_lonlat_grid_are_measured_in_metres():
    """On a lonlat grid at 70°N a cell is cos(70°) as wide as it is tall: a line drawn at
    45° in cells runs at atan(1 / cos 70°) = 71° from east on the ground."""
    grid = Grid(GridCfg(kind="lonlat", lon=(-30, 30), lat=(65, 75), resolution=0.25), R)
    lines = [((5, 20), (30, 45))]
    leads, _ = detect(draw(grid.shape, lines), grid, min_length=3)
    assert len(leads) == 1
    lat = grid.y[(5 + 30) // 2]
    want = math.degrees(math.atan2(1.0, math.cos(math.radians(lat))))
    assert leads[0].orientation == pytest.approx(want, abs=5.0)
    cell = R * math.radians(0.25)
    length = 25 * cell * math.hypot(1.0, math.cos(math.radians(lat)))
    assert abs(leads[0].length - length) <= cell


def test_short_and_empty_masks_give_no_leads():
    grid = Grid(PS, R)
    assert detect(np.zeros(grid.shape, bool), grid) == ([], [])
    leads, _ = detect(draw(grid.shape, [((10, 10), (10, 11))]), grid, min_length=3)
    assert leads == []


def test_the_opening_of_a_lead_is_the_velocity_jump_across_it():
    """A band one cell wide where the divergence is du / cell opens at du."""
    grid = Grid(PS, R)
    m = draw(grid.shape, [((5, 30), (55, 30))])
    div = np.where(m, 0.02 / 50e3, 0.0)
    leads, _ = detect(m, grid, div, min_length=3)
    assert len(leads) == 1 and leads[0].opening == pytest.approx(0.02, rel=1e-3)


# ---------------------------------------------------------------- broken joints at coarse cells
D = 9e3  # m: joint spacing along a crack (the default scene's elements are about 9 km across)
CRACKS = {  # (start, end) [m] in the grid's plane
    "crossing": [((-300e3, -100e3), (300e3, 100e3)), ((-100e3, -300e3), (150e3, 320e3))],
    "parallel": [((-300e3, -60e3), (300e3, -60e3)), ((-300e3, 60e3), (300e3, 60e3))],
    "far_apart": [((-500e3, -300e3), (-100e3, -300e3)), ((200e3, 50e3), (200e3, 450e3))],
    # a web: three cracks along x crossed by three along y, 200 km apart (the old zone labels
    # chained its junctions into one, and every pair of leads "crossed" at its middle)
    "web": [((-310e3, y), (310e3, y)) for y in (-200e3, 0.0, 200e3)]
    + [((x, -310e3), (x, 310e3)) for x in (-200e3, 0.0, 200e3)],
}
CROSSES = {"crossing": [(0, 1)], "parallel": [], "far_apart": [],
           "web": [(a, b) for a in range(3) for b in range(3, 6)]}
#: the finest cells [m] at which a pattern may be refused: a crossing's zone reaches two cells
#: each side, so crossings must be more than five cells apart (the web's are 200 km apart), and
#: the cracks several cells long beyond it (the crossing pair's 600 km are 7.5 cells of 80 km)
REFUSED_FROM = {"crossing": 80e3, "parallel": 80e3, "far_apart": 80e3, "web": 40e3}


def _broken_joint_mask(cracks, cell):
    """The ``broken_joints > 0`` mask of ``siku grid`` for cracks whose joint midpoints lie every
    ``D`` along each line, on a polar stereographic grid of ``cell`` [m]."""
    grid = Grid(GridCfg(kind="polar_stereographic", x=(-800e3, 800e3), y=(-800e3, 800e3),
                        resolution=cell), R)
    m = np.zeros(grid.shape, bool)
    for (x0, y0), (x1, y1) in cracks:
        n = int(math.hypot(x1 - x0, y1 - y0) // D) + 1
        x, y = np.linspace(x0, x1, n), np.linspace(y0, y1, n)
        i = np.searchsorted(grid.x_edges, x) - 1
        j = np.searchsorted(grid.y_edges, y) - 1
        m[j, i] = True
    return grid, m


def _crossing_point(a, b):
    (p, q), (r, s) = (np.array(a[0]), np.array(a[1])), (np.array(b[0]), np.array(b[1]))
    t = np.linalg.solve(np.column_stack([q - p, r - s]), r - p)[0]
    return p + t * (q - p)


@pytest.mark.parametrize("pattern", sorted(CRACKS))
@pytest.mark.parametrize("cell", [10e3, 20e3, 40e3, 80e3, 160e3])
def test_broken_joint_leads_are_exact_or_refused(pattern, cell):
    """Cracks drawn by their broken joints' midpoints, at cells no finer than the joint spacing:
    each crack is one lead, its length within one cell (the centres of its end cells), and the
    crossings are exactly the crossing pairs, within two cells of the true point; or the table
    is refused (``unresolved``: the mask wider than ``MAX_CRACK_WIDTH``, or the crossings taking
    most of the skeleton, or two crossings' zones touching). Cells finer than
    ``REFUSED_FROM`` must resolve the pattern: a refusal everywhere would pass."""
    from siku_io.analysis.leads import unresolved

    cracks = CRACKS[pattern]
    grid, m = _broken_joint_mask(cracks, cell)
    if unresolved(m) is not None:
        assert cell >= REFUSED_FROM[pattern], f"refused too fine: {unresolved(m)}"
        return
    leads, crossings = detect(m, grid, min_length=3)
    assert len(leads) == len(cracks)
    want = sorted(math.hypot(x1 - x0, y1 - y0) for (x0, y0), (x1, y1) in cracks)
    got = sorted(f.length for f in leads)
    for g, w in zip(got, want):
        assert abs(g - w) <= cell * math.sqrt(2), (g, w)
    assert len(crossings) == len(CROSSES[pattern])
    points = [_crossing_point(cracks[a], cracks[b]) for a, b in CROSSES[pattern]]
    for c in crossings:  # each near its own true crossing point
        x, y = grid.to_plane(np.array([c.where[0]]), np.array([c.where[1]]))
        d = [np.hypot(float(x[0]) - p[0], float(y[0]) - p[1]) for p in points]
        k = int(np.argmin(d))
        assert d[k] <= 2 * cell * math.sqrt(2), (d[k], cell)
        points.pop(k)
        assert 80 <= c.angle <= 90 if pattern == "web" else True
