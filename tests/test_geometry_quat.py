"""Latitude and longitude of points on the sphere near the poles (``siku_core.geometry.quat``).

``xyz_to_latlon`` takes the latitude as ``atan2(z, hypot(x, y))``, good to round-off at every
latitude. ``asin(z / r)`` is not: near a pole ``z / r = cos(colat) = 1 - colat²/2`` keeps only
``sqrt(eps) ≈ 1.5e-8`` rad of the colatitude, so the error is up to ``eps / colat`` rad (``R eps
/ colat`` in position), and 1e-9 rad from the pole ``z / r`` rounds to 1: the point lands on the
pole, 6 mm away on the Earth.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.geometry.quat import centers, farthest_moved2, latlon_to_xyz, xyz_to_latlon

ULP = math.ulp(0.5 * math.pi)  # 2.2e-16: spacing of latitudes next to the pole
PI2_LO = 6.123233995736766e-17  # pi/2 - float(pi/2)


def point(colat: float, lon: float, north: bool = True, r: float = 1.0) -> np.ndarray:
    """The point ``colat`` [rad] from the north (south) pole at ``lon``, components to within
    half an ulp each (no cancellation: ``sin`` and ``cos`` of the small angle)."""
    s = math.sin(colat)
    return r * np.array([s * math.cos(lon), s * math.sin(lon),
                         math.cos(colat) if north else -math.cos(colat)])


@pytest.mark.parametrize("north", [True, False], ids=["north", "south"])
@pytest.mark.parametrize("colat", [1e-3, 1e-6, 1e-9, 1e-12])
def test_latitude_near_the_pole_is_exact_to_round_off(colat, north):
    """``colat`` from a pole: the latitude is ``±(pi/2 - colat)`` within 2 ulp of ``pi/2``
    (4e-16 rad, 3 nm on the Earth) and the longitude exact; ``latlon_to_xyz`` gives the point
    back within 2 eps. The ``asin`` version is off by ``colat`` itself at 1e-9 (the point
    lands on the pole), by 1e-10 rad at 1e-6."""
    lon = 0.7
    for r in (1.0, 6_371_000.0):
        p = point(colat, lon, north, r)
        lat, lo = xyz_to_latlon(p)
        expected = 0.5 * math.pi - colat
        assert abs(abs(lat) - expected) <= 2 * ULP, f"latitude off by {abs(lat) - expected:.3e}"
        assert math.copysign(1.0, lat) == (1.0 if north else -1.0)
        assert lo == pytest.approx(lon, abs=2e-16, rel=2e-16)
        back = latlon_to_xyz(lat, lo)
        err = np.abs(back - p / r).max()
        assert err <= 2 * np.finfo(float).eps, f"round trip moved the point by {err:.3e}"


def colatitude(lat: float) -> float:
    """``pi/2 - lat`` for a latitude next to the north pole, to a few ulp relative: ``pi/2``
    in two parts (the difference with the high part is exact, Sterbenz)."""
    return (0.5 * math.pi - lat) + PI2_LO


@pytest.mark.parametrize("lon", [0.0, 0.7, -2.3, math.pi])
def test_point_1e_9_from_the_pole_round_trips(lon):
    """The latitude ``pi/2 - 1e-9`` through ``latlon_to_xyz -> xyz_to_latlon`` comes back with
    its colatitude to a few ulp relative (measured: the same double, on 80 000 random points
    1e-12 to 1e-3 rad from the pole). The ``asin`` version returned the pole itself (``z``
    rounds to 1): a relative error of 1."""
    lat = 0.5 * math.pi - 1e-9
    lat2, lon2 = xyz_to_latlon(latlon_to_xyz(lat, lon))
    rel = abs(colatitude(lat2) - colatitude(lat)) / colatitude(lat)
    assert rel <= 4 * np.finfo(float).eps, f"colatitude relative error {rel:.3e}"
    assert lon2 == pytest.approx(lon, rel=4e-16, abs=4e-16) or abs(lon2) == abs(lon) == math.pi


def test_farthest_moved2_is_the_largest_squared_drift_of_the_rows_given():
    """An MPI rank's drift test: the largest squared chord between the centres of the rows
    given and their earlier places, as from :func:`centers` of a copy of those rows; rows not
    given (ghosts) do not count; no rows, no drift."""
    rng = np.random.default_rng(3)
    q = rng.normal(size=(500, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    rows = np.sort(rng.choice(500, 300, replace=False))
    ref = centers(q[rows]) + rng.normal(0.0, 1e-3, (300, 3))
    d = centers(q[rows]) - ref
    assert farthest_moved2(q, rows, ref) == pytest.approx((d * d).sum(axis=1).max(), rel=1e-15)
    other = np.setdiff1d(np.arange(500), rows)
    far = q.copy()
    far[other] = far[other][::-1]  # the rows not given moved anywhere: the same answer
    assert farthest_moved2(far, rows, ref) == farthest_moved2(q, rows, ref)
    assert farthest_moved2(q, rows[:0], ref) == 0.0
