"""The structural rules of the four packages, checked on their source with :mod:`ast`.

* **No import circle inside a package.** The modules of each top-level package
  (``siku_core``, ``siku_plugins``, ``siku_forcing``, ``siku_io``) and the imports between them
  form a directed graph; its strongly connected components must be single modules. Every
  import counts: at the top of a module, inside a function and under ``if TYPE_CHECKING:`` (a
  lazy import hides a circle, it does not remove it). ``from pkg import name`` is an edge to
  the module ``pkg.name`` when that is a module, else to ``pkg`` (its ``__init__``).
* **No import of another module's private name.** ``from x import _y`` and ``x._y`` on a
  module bound by an import name something that ``x`` keeps to itself; a name another module
  needs is public (no leading underscore) or lives in that module. Dunder names
  (``__version__``) are not private.

The rule that the engine names nothing above it is tests/test_layering.py.
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")


def modules(root: Path = ROOT, packages=PACKAGES) -> dict[str, Path]:
    """``{dotted module name: file}`` of every module of ``packages`` under ``root``."""
    out = {}
    for pkg in packages:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def imports_of(module: str, path: Path) -> list[tuple[str, str | None, int]]:
    """``(module imported, name or None, line)`` of every import statement in ``path``,
    wherever it stands (relative imports resolved against ``module``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = module.split(".")
                if path.name != "__init__.py":
                    pkg = pkg[:-1]
                pkg = pkg[:len(pkg) - (node.level - 1)]
                base = ".".join(pkg + ([base] if base else []))
            out += [(base, a.name, node.lineno) for a in node.names]
    return out


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """``{module: modules of mods it imports}`` (every import, see the module docstring)."""
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        for base, name, _ in imports_of(mod, path):
            target = f"{base}.{name}" if name and f"{base}.{name}" in mods else base
            if target in mods and target != mod:
                graph[mod].add(target)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of ``graph`` with more than one module (Tarjan's
    algorithm, iterative), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        found.append(sorted(comp))
    return found


def one_cycle(graph: dict[str, set[str]], comp: list[str]) -> list[str]:
    """A shortest closed path through the first module of ``comp`` inside ``comp`` (for the
    message: the circle to break)."""
    inside = set(comp)
    start = comp[0]
    came: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & inside):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(came[path[-1]])
                    return [start] + path[::-1][1:] + [start]
                if w not in came:
                    came[w] = v
                    nxt.append(w)
        frontier = nxt
    return comp


def package_circles(root: Path = ROOT, packages=PACKAGES) -> list[str]:
    """One line per import circle inside a package: its modules and one cycle through them."""
    mods = modules(root, packages)
    graph = import_graph(mods)
    out = []
    for pkg in packages:
        sub = {m: {t for t in graph[m] if t.split(".")[0] == pkg}
               for m in graph if m.split(".")[0] == pkg}
        for comp in circles(sub):
            out.append(f"{pkg}: {len(comp)} modules in a circle ({', '.join(comp)}); "
                       f"one cycle: {' -> '.join(one_cycle(sub, comp))}")
    return out


def private_imports(root: Path = ROOT, packages=PACKAGES) -> list[str]:
    """``file:line: what`` for every use of another module's private name: ``from x import
    _y`` and ``x._y`` where ``x`` is bound by ``import x`` (or ``import x as z``, ``from p
    import x`` of a module) in the same file."""
    mods = modules(root, packages)
    out = []
    for mod, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        rel = path.relative_to(root)
        bound: set[str] = set()  # local names bound to modules
        for base, name, line in imports_of(mod, path):
            if name is not None and _private(name) and base != mod:
                out.append(f"{rel}:{line}: from {base} import {name}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in mods:
                        bound.add(a.asname or a.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom):
                for a in node.names:
                    base = node.module or ""
                    if node.level:
                        pkg = mod.split(".")
                        if path.name != "__init__.py":
                            pkg = pkg[:-1]
                        pkg = pkg[:len(pkg) - (node.level - 1)]
                        base = ".".join(pkg + ([base] if base else []))
                    if f"{base}.{a.name}" in mods:
                        bound.add(a.asname or a.name)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and _private(node.attr)
                    and isinstance(node.value, (ast.Name, ast.Attribute))):
                dotted = _dotted(node.value)
                if dotted is not None and dotted.split(".")[0] in bound:
                    out.append(f"{rel}:{node.lineno}: {dotted}.{node.attr}")
    return out


def _dotted(node: ast.AST) -> str | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([node.id] + parts[::-1])


def test_no_import_circle_inside_a_package():
    """The modules of each package import each other without a circle (every import counts,
    lazy and ``TYPE_CHECKING`` ones too)."""
    assert len(modules()) > 100
    found = package_circles()
    assert not found, "import circles:\n" + "\n".join(found)


def test_no_private_name_of_another_module():
    """No module imports or reaches into another module's private (``_``) names."""
    found = private_imports()
    assert not found, "private names used across modules:\n" + "\n".join(found)


def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp_path


def test_a_lazy_or_type_checking_import_closes_a_circle(tmp_path):
    """The circle rule is not vacuous: an import inside a function or under
    ``TYPE_CHECKING`` closes a circle; a package with a one-way import has none."""
    root = _tree(tmp_path, {
        "pk/__init__.py": "",
        "pk/a.py": "from .b import f\n",
        "pk/b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .c import C\n"
                   "def f():\n    pass\n",
        "pk/c.py": "def g():\n    from pk import a\n",
        "pk/d.py": "from . import a\n",
    })
    found = package_circles(root, ("pk",))
    assert len(found) == 1 and "pk.a, pk.b, pk.c" in found[0], found
    assert "pk.d" not in found[0]
    (root / "pk/c.py").write_text("def g():\n    pass\n")
    assert package_circles(root, ("pk",)) == []


def test_a_private_import_is_named_with_its_line(tmp_path):
    """The private-name rule is not vacuous: ``from x import _y`` and ``x._y`` are flagged
    with file and line; a module's own private names, dunders and attributes of objects that
    are not modules are not."""
    root = _tree(tmp_path, {
        "pk/__init__.py": "__version__ = '1'\n",
        "pk/a.py": "_k = 1\ndef _f():\n    return _k\n",
        "pk/b.py": "from .a import _f\nfrom . import __version__\n",
        "pk/c.py": "import pk.a\nfrom pk import a as aa\nx = pk.a._k\ny = aa._f\n"
                   "class T:\n    _z = 1\nw = T()._z\n",
    })
    found = private_imports(root, ("pk",))
    assert sorted(found) == sorted([
        str(Path("pk/b.py")) + ":1: from pk.a import _f",
        str(Path("pk/c.py")) + ":3: pk.a._k",
        str(Path("pk/c.py")) + ":4: aa._f",
    ]), found
