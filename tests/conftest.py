"""Shared test configuration."""
from __future__ import annotations

import numba
import pytest

#: plugin packages kept frozen as they were written, with their own suites, which
#: tests/test_public_api.py runs against this tree in a separate process
collect_ignore_glob = ["data/*"]


@pytest.fixture(autouse=True)
def _numba_threads():
    """Every test starts with the thread count the previous one started with: code under test
    (the benchmarks' entry points, ``siku run --threads``) sets numba's threads for the whole
    process, and a test that counts on two threads must not inherit one."""
    n = numba.get_num_threads()
    yield
    numba.set_num_threads(n)


def pytest_configure(config):
    """The suite runs against siku's own components only, whatever plugins the user has
    installed (``pip install -e examples/siku_example_plugin``, as the plugin guide says, or
    any other): every distribution other than siku's own that declares a ``siku`` entry point
    when the session starts is named in ``SIKU_SKIP_PLUGINS`` (inherited by the commands the
    tests start). Plugins the tests install themselves (``siku_fake_install``) still load."""
    import importlib.metadata as md
    import os

    # pytest-xdist's workers (``-n N``) share the cores: each takes its share of numba's
    # threads (one each with as many workers as cores), since spinning threads of one worker
    # on a core another needs make both many times slower; a test that needs two threads
    # sets them itself
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
    if workers > 1:
        numba.set_num_threads(max(1, min(numba.config.NUMBA_NUM_THREADS,
                                         (os.cpu_count() or 1) // workers)))

    from siku_core.plugins import canonical_dist, get_registry, own_distribution, \
        skipped_distributions

    own = own_distribution()
    others = {canonical_dist(ep.dist.name) for ep in md.entry_points(group="siku")
              if ep.dist is not None and ep.dist.name != own}
    if others:
        os.environ["SIKU_SKIP_PLUGINS"] = ",".join(sorted(others | skipped_distributions()))
        get_registry(refresh=True)
