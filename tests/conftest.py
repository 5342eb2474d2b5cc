"""Shared test configuration."""
from __future__ import annotations

import numba
import pytest


@pytest.fixture(autouse=True)
def _numba_threads():
    """Every test starts with the thread count the previous one started with: code under test
    (the benchmarks' entry points, ``siku run --threads``) sets numba's threads for the whole
    process, and a test that counts on two threads must not inherit one."""
    n = numba.get_num_threads()
    yield
    numba.set_num_threads(n)
