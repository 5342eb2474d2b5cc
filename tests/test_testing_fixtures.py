"""The module-scoped simulation factory of siku's pytest plugin: one run built once and shared
by the tests of a module, and the plugin guide's example of it (from the example plugin's
tests, shown verbatim in docs/howto/plugins.md) passes."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "siku_example_plugin"
SHARED = '''
import pytest

BUILT = []


@pytest.fixture(scope="module")
def drifted(siku_module_simulation_factory):
    sim = siku_module_simulation_factory(elements=[(-150.0, 75.0)], dt=600.0,
                                         duration=3600.0, forcing=[{"source": "coriolis"}])
    BUILT.append(sim)
    return sim.run()


def test_first(drifted):
    assert drifted.step_index == 6


def test_second(drifted):
    assert len(BUILT) == 1 and BUILT[0] is drifted
'''


def _pytest(args, cwd):
    env = {**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), str(EXAMPLE),
                                                       os.environ.get("PYTHONPATH")]))}
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "-p", "siku_core.testing.fixtures", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_one_run_is_built_for_the_module(tmp_path):
    (tmp_path / "test_shared_run.py").write_text(SHARED, encoding="utf-8")
    r = _pytest(["test_shared_run.py"], tmp_path)
    assert r.returncode == 0 and "2 passed" in r.stdout, r.stdout[-3000:] + r.stderr[-3000:]


def test_the_guide_s_shared_run_passes():
    r = _pytest(["-k", "shared_run", "tests/test_example_plugin.py"], EXAMPLE)
    assert r.returncode == 0 and "2 passed" in r.stdout, r.stdout[-3000:] + r.stderr[-3000:]
