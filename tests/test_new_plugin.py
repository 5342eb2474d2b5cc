"""``siku new-plugin``: the package it writes registers one component of every kind (and a
command) by the names its README gives, its own tests pass as generated, and an existing target
is refused in one line."""
from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from siku_core.run.cli import main
from siku_core.plugins import get_registry

ROOT = Path(__file__).resolve().parents[1]

KINDS = {"contact_law": "spring", "forcing": "push", "process": "growth", "writer": "centres",
         "element_source": "squares"}


def test_the_generated_package_registers_every_kind(tmp_path, monkeypatch, siku_register, capsys):
    assert main(["new-plugin", "siku-kit-demo", "--dir", str(tmp_path)]) == 0
    root = tmp_path / "siku-kit-demo"
    assert f"{root}: a siku plugin package" in capsys.readouterr().out
    text = (root / "pyproject.toml").read_text(encoding="utf-8")
    assert '[project.entry-points.siku]\nsiku_kit_demo = "siku_kit_demo.plugin"' in text
    monkeypatch.syspath_prepend(str(root))
    plugin = importlib.import_module("siku_kit_demo.plugin")
    siku_register(plugin)
    reg = get_registry()
    for kind, short in KINDS.items():
        assert f"siku_kit_demo_{short}" in reg.names(kind), kind
        assert f"siku_kit_demo_{short}" in (root / "README.md").read_text(encoding="utf-8")
    # the command is registered with the others: it counts the elements of a scene
    scene = tmp_path / "scene.toml"
    scene.write_text('[time]\ndt = 1.0\nduration = 1.0\n[elements]\nthickness = 1.0\n'
                     '[[elements.source]]\nname = "siku_kit_demo_squares"\n'
                     'params = { nx = 2, ny = 2 }\n', encoding="utf-8")
    assert main(["siku-kit-demo-count", str(scene)]) == 0
    assert capsys.readouterr().out.strip() == f"{scene}: 4 elements"
    # an existing target: refused in one line, nothing written into it
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    assert main(["new-plugin", "siku-kit-demo", "--dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.strip().count("\n") == 0 and f"{root}: exists" in err
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before
    for bad in ("1plugin", "a b", "x-"):
        assert main(["new-plugin", bad, "--dir", str(tmp_path)]) == 2
        assert capsys.readouterr().err.strip().count("\n") == 0
        assert not (tmp_path / bad).exists()


@pytest.mark.slow
def test_the_generated_package_passes_its_own_tests(tmp_path):
    """Its default tests (the contact-law checks that compile no contact loop; the forcing,
    process, writer and element-source suites; the command), run as its author runs them."""
    assert main(["new-plugin", "siku-kit-demo", "--dir", str(tmp_path)]) == 0
    root = tmp_path / "siku-kit-demo"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(root)]),
           "NUMBA_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                        "-m", "not slow"], cwd=root, env=env, capture_output=True, text=True,
                       timeout=1800)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    assert " passed" in r.stdout and "failed" not in r.stdout
