"""``import siku_core`` loads the engine only (xarray's test_lazy_import, STYLE.md §9)."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

HEAVY = ("netCDF4", "h5py", "xarray")
PLUGINS = ("siku_plugins", "siku_forcing", "siku_io")


def imported_after(statement: str) -> set[str]:
    """Top-level module names present in ``sys.modules`` after ``statement``, in a new Python."""
    code = f"{statement}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    r = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True,
                       timeout=120,
                       env={**os.environ, "SIKU_DISABLE_PLUGIN_AUTOLOAD": "1"})
    assert r.returncode == 0, r.stderr
    return {m.split(".")[0] for m in json.loads(r.stdout.splitlines()[-1])}


def test_import_siku_core_loads_no_io_libraries_and_no_plugins():
    mods = imported_after("import siku_core")
    assert not mods & set(HEAVY + PLUGINS), sorted(mods & set(HEAVY + PLUGINS))


@pytest.mark.parametrize("statement", [
    "import siku_core.testing",
    "import siku_core.testing.conformance",
    "import siku_core.scene.scene_file, siku_core.run.simulation, siku_core.run.cli",
])
def test_engine_modules_and_testing_helpers_load_no_io_libraries(statement):
    mods = imported_after(statement)
    assert not mods & set(HEAVY), sorted(mods & set(HEAVY))
    assert not mods & set(PLUGINS), sorted(mods & set(PLUGINS))

