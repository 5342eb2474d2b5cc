"""The layering of the packages: the engine (``siku_core``) names and imports nothing above it.

``docs/explanation/design.md``: "the engine never imports the packages above it, at import time
or later". The packages above it are found, not listed: every top-level package of the
distribution in the repository (``siku_*``) other than ``siku_core`` and every top-level module
that an installed ``siku`` entry point names.
"""
from __future__ import annotations

import importlib.metadata as md
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "siku_core"


def upper_packages() -> set[str]:
    """Top-level packages of the repository and of the ``siku`` entry points, but the engine."""
    names = {p.parent.name for p in ROOT.glob("siku_*/__init__.py")}
    for ep in md.entry_points(group="siku"):
        names.add(ep.value.split(":")[0].split(".")[0])
    names.discard("siku_core")
    return names


def test_the_upper_packages_are_found():
    # the finder must see the packages it guards against, or the checks below pass vacuously
    assert {"siku_plugins", "siku_forcing", "siku_io"} <= upper_packages()


def test_siku_core_names_no_upper_package_in_its_text():
    """No source or text file of the engine names an upper package: not in an import, not in a
    string (a module path imported later), not in a docstring or comment."""
    pattern = re.compile(r"\b(" + "|".join(sorted(upper_packages())) + r")\b")
    hits = []
    files = [p for p in CORE.rglob("*") if p.is_file() and p.suffix in (".py", ".toml", ".md",
                                                                          ".txt", ".cfg")]
    assert any(p.name == "simulation.py" for p in files)
    for path in files:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if pattern.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not hits, "siku_core names an upper package:\n" + "\n".join(hits)


def test_importing_every_engine_module_imports_no_upper_package():
    """Every module of ``siku_core`` imported in a fresh interpreter (the testing helpers
    included) leaves no upper package in ``sys.modules``."""
    code = (
        "import importlib, pkgutil, sys\n"
        "import siku_core\n"
        "for m in pkgutil.walk_packages(siku_core.__path__, 'siku_core.'):\n"
        "    importlib.import_module(m.name)\n"
        f"upper = {sorted(upper_packages())!r}\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in upper)\n"
        "print(len([m for m in sys.modules if m.startswith('siku_core')]))\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True).stdout.splitlines()
    assert int(out[0]) > 20  # the walk found the engine's modules
    assert out[1] == "", f"importing siku_core imported: {out[1]}"


def test_the_builtin_components_come_from_entry_points():
    """Built-ins register through the distribution's own ``siku`` entry points, the way a third
    party's do: every registered built-in component comes from a module one of them names (or
    from that package's modules)."""
    from siku_core.plugins import get_registry, own_distribution

    own = own_distribution()
    assert own is not None
    modules = {ep.value for ep in md.distribution(own).entry_points if ep.group == "siku"}
    reg = get_registry()
    seen = 0
    for kind, table in reg.entries.items():
        for name, entry in table.items():
            if entry.package == own:
                mod = entry.cls.__module__  # the entry point's module, or a module of its package
                assert any(mod == m or mod.startswith(m + ".") for m in modules), (kind, name, mod)
                seen += 1
    assert seen >= 20
