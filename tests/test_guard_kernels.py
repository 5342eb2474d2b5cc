"""The NaN guard's kernels (``siku_core.diagnostics``): one pass without an early exit, so
every position of a bad value has to be found, the last one included."""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.diagnostics import all_finite, fastest, rows_sound, speeds_within, state_sound


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


def _state(n, seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    return (rng.normal(0, 1e6, (n, 2)), rng.normal(0, 1e8, n), rng.normal(0, 2.0, (n, 2)),
            rng.normal(0, 1e-4, n), q)


@pytest.mark.parametrize("nch", [1, 3, 16])
@pytest.mark.parametrize("n", [1, 40, 5000])
def test_state_sound_finds_a_bad_value_in_any_array_and_chunk(n, nch):
    nch = min(nch, n)
    arrays = _state(n, n)
    i, s2 = fastest(arrays[2])
    assert state_sound(*arrays, s2, nch)
    assert not state_sound(*arrays, np.nextafter(s2, 0.0), nch)  # the speed limit, exactly
    for a in range(5):
        for k in sorted({0, n // 2, n - 1}):
            for bad in (math.nan, math.inf):
                b = [x.copy() for x in arrays]
                b[a].reshape(n, -1)[k, -1] = bad
                assert not state_sound(*b, math.inf, nch)


@pytest.mark.parametrize("n", [1, 40, 5000])
def test_rows_sound_checks_the_rows_it_is_given_and_no_other(n):
    """An MPI rank checks its own elements among its ghosts: a bad value or a speed above the
    limit in a listed row fails, as :func:`state_sound` of those rows does; one in a row not
    listed (a ghost, checked by its owner) does not."""
    arrays = _state(n, n + 1)
    rows = np.arange(0, n, 2)
    other = np.arange(1, n, 2)
    mine = [a[rows] for a in arrays]
    _, s2 = fastest(mine[2])
    assert rows_sound(*arrays, s2, rows) and state_sound(*mine, s2, 1)
    assert not rows_sound(*arrays, np.nextafter(s2, 0.0), rows)  # the speed limit, exactly
    for a in range(5):
        for bad in (math.nan, math.inf, -math.inf):
            b = [x.copy() for x in arrays]
            b[a].reshape(n, -1)[rows[-1], -1] = bad
            assert not rows_sound(*b, math.inf, rows)
            if len(other):
                c = [x.copy() for x in arrays]
                c[a].reshape(n, -1)[other[-1], 0] = bad
                assert rows_sound(*c, math.inf, rows)
    assert rows_sound(*arrays, 0.0, np.zeros(0, np.int64))
