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
from siku_io.analysis.regular_grid import Grid, GridCfg

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
