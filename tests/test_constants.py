"""One name, one meaning: no two modules of siku's packages assign the same public module-level
UPPER_CASE constant (importing a constant from the module that defines it is fine)."""
from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")


def _targets(node: ast.stmt) -> list[str]:
    """Names a module-level statement assigns (``A = ...``, ``A: int = ...``, ``A, B = ...``)."""
    if isinstance(node, ast.Assign):
        targets = node.targets
    elif isinstance(node, ast.AnnAssign):
        targets = [node.target]
    else:
        return []
    names = []
    for t in targets:
        for n in ast.walk(t):
            if isinstance(n, ast.Name):
                names.append(n.id)
    return names


def _is_public_constant(name: str) -> bool:
    return not name.startswith("_") and name.isupper() and len(name) > 1


def module_constants() -> dict[str, list[str]]:
    """Public UPPER_CASE constant -> the modules that assign it."""
    where = defaultdict(list)
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
            for name in {n for node in tree.body for n in _targets(node)}:
                if _is_public_constant(name):
                    where[name].append(module)
    return where


def test_no_two_modules_assign_the_same_constant():
    where = module_constants()
    assert len(where) > 20  # the walk found the packages' constants
    clashes = {name: mods for name, mods in where.items() if len(mods) > 1}
    assert not clashes, "constants assigned in more than one module: " + "; ".join(
        f"{name} in {', '.join(mods)}" for name, mods in sorted(clashes.items()))
