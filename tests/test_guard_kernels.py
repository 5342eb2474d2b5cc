"""The NaN guard's kernels (``siku_core.diagnostics``): one pass without an early exit, so
every position of a bad value has to be found, the last one included."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.diagnostics import all_finite, fastest, speeds_within


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("n", [1, 7, 64, 1001])
def test_all_finite_finds_a_bad_value_anywhere(bad, n):
    a = np.linspace(-1e300, 1e300, n)
    assert all_finite(a)
    for k in sorted({0, n // 2, n - 1}):
        b = a.copy()
        b[k] = bad
        assert not all_finite(b)
    assert all_finite(np.empty(0))


@pytest.mark.parametrize("n", [1, 5, 33, 1000])
def test_speeds_within_agrees_with_the_fastest_element(n):
    rng = np.random.default_rng(n)
    V = rng.normal(0.0, 3.0, (n, 2))
    i, s2 = fastest(V)
    assert speeds_within(V, s2)  # the largest speed is within itself
    assert not speeds_within(V, np.nextafter(s2, 0.0))
    W = V.copy()
    W[n - 1, 1] = math.nan
    assert not speeds_within(W, math.inf)
    assert speeds_within(np.empty((0, 2)), 0.0)
