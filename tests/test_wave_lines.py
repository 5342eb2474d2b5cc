"""The interpolated sea (``jonswap`` with ``method = "lines"``, siku_forcing.waves.wave_lines)
against
the direct sum at every point, within its stated bound."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_forcing.waves import wave_lines
from siku_forcing.waves.wave_field import Jonswap


def seas(**kw):
    p = {k: v.default for k, v in Jonswap.params.items()}
    p.update(seed=7, origin=[-150.0, 75.0], **kw)
    a, b = Jonswap(dict(p)), Jonswap({**p, "method": "lines"})
    for w in (a, b):
        w._build()
    return a, b


def points(n=5000, half=0.005):
    rng = np.random.default_rng(3)
    lat = np.radians(75 + rng.uniform(-half, half, n))
    lon = np.radians(-150 + rng.uniform(-4 * half, 4 * half, n))
    return lat, lon


def errors(a, b, lat, lon, t):
    """Largest differences at the points: elevation [m], slope and orbital velocity per unit
    metric factor, curvature along a fixed direction."""
    A, B = a.evaluate(t, lat, lon), b.evaluate(t, lat, lon)
    m = math.cos(a.lat0) / np.cos(lat)
    se, sn = np.full(len(lat), 0.6), np.full(len(lat), 0.8)
    return {"eta": np.abs(A["eta"] - B["eta"]).max(),
            "slope": max(np.abs((A["eta_e"] - B["eta_e"]) / m).max(),
                         np.abs(A["eta_n"] - B["eta_n"]).max()),
            "u": max(np.abs((A["u"] - B["u"]) / m).max(), np.abs(A["v"] - B["v"]).max()),
            "curvature": np.abs(a.curvature(t, lat, lon, se, sn)
                                - b.curvature(t, lat, lon, se, sn)).max()}


def summed(a):
    """The largest each quantity can be: its summed amplitudes."""
    return {"eta": a.amp.sum(), "slope": (a.amp * a.k).sum(), "u": a.u_orbital.sum(),
            "curvature": (a.amp * a.k**2).sum()}


def test_lagrange_constant_is_the_node_polynomial_at_mid_interval():
    # prod |1/2 - i|, i = -3..4, is (1/2 3/2 5/2 7/2)², over 8!
    assert wave_lines.W_P == pytest.approx((0.5 * 1.5 * 2.5 * 3.5) ** 2 / 40320, rel=1e-15)


@pytest.mark.parametrize("depth, nd, tol", [(-1.0, 16, 1e-6), (30.0, 16, 1e-6),
                                            (-1.0, 1, 1e-6), (-1.0, 16, 1e-3)])
def test_the_interpolated_sea_is_the_direct_sum_within_its_bound_at_every_point(depth, nd, tol):
    a, b = seas(depth=depth, n_directions=nd, spreading=2.0, tolerance=tol)
    lat, lon = points()
    lines = b._lines()
    S = summed(a)
    for t in (0.0, 41.3):
        err = errors(a, b, lat, lon, t)
        assert lines._key is not None  # the tables were used, not the direct sum
        for q, e in err.items():
            # the bound holds (plus round-off of the sums) and is within the tolerance
            assert e <= lines.bounds[q] + 1e-12 * S[q], q
            assert lines.bounds[q] <= tol * S[q] * (1 + 1e-12), q


def test_the_bound_is_near_the_error_so_the_spacing_is_not_wasted():
    """At twice the chosen spacing (2⁸ times the bound) the error exceeds the tolerance."""
    a, b = seas(spreading=2.0)
    lat, lon = points()
    b._line_sea = wave_lines.LineSea(b, 1e-6, h=2.0 * b._lines().h)
    err = errors(a, b, lat, lon, 3.0)
    assert err["eta"] > 1e-6 * summed(a)["eta"]


def test_a_pack_wider_than_its_tables_are_worth_takes_the_direct_sum():
    a, b = seas()
    lat, lon = points(n=50, half=0.5)  # 50 points over 110 km: 10⁵ nodes a line
    A, B = a.evaluate(2.0, lat, lon), b.evaluate(2.0, lat, lon)
    assert b._lines()._key is None
    for q in A:
        assert np.array_equal(A[q], B[q])


def test_forces_of_the_interpolated_sea_within_the_slope_bound():
    from types import SimpleNamespace

    from siku_core.geometry.quat import q_from_latlon

    a, b = seas(spreading=2.0)
    lat, lon = points(n=500)
    q = np.array([q_from_latlon(x, y) for x, y in zip(lat, lon)])
    st = SimpleNamespace(m=np.full(500, 1e5), area=np.full(500, 100.0))
    F = {}
    for w in (a, b):
        F[w] = np.zeros((500, 3))
        w.add_forces(5.0, q, np.zeros((500, 3)), st, np.ones(500, bool), 9.81, True, 0.0,
                     F[w])
    m = math.cos(a.lat0) / np.cos(lat).min()
    # slope force -m g grad eta: off by at most m g (metric) times the slope bound per axis
    assert np.abs(F[a] - F[b]).max() <= 1e5 * 9.81 * m * b._lines().bounds["slope"] * 1.000001
    assert np.abs(F[a]).max() > 1e3 * np.abs(F[a] - F[b]).max()
