"""The rooms of the packages: which module lives where, and the move that put it there.

``MOVES`` is the table, old dotted module → new dotted module. Run from the repository root::

    python tools/rooms.py --apply         # git mv every module of the table, leave a
                                          # deprecation alias at each old path, then rewrite
    python tools/rooms.py --rewrite-only  # rewrite only (the moves are already done)
    python tools/rooms.py --check         # list what a rewrite would change; exit 1 if any

The rewrite turns every reference to an old module into its new one, across the tree (``*.py``,
``*.md``, ``*.toml``, ``*.tmpl``): absolute and relative imports (``from .errors import x`` in a
module that moved a level down becomes ``from ..errors import x``; ``from pkg import old`` of a
moved module is split off as ``from newpkg import new``), dotted paths in strings, docstrings,
comments and prose (``siku_core.simulation.Simulation``), and file paths
(``siku_core/contact_loops.py``). It is idempotent: a tree already rewritten is left as it is,
so code written against the old paths can be merged into the new tree and rewritten again.

What it leaves alone, because it names the old paths on purpose: the alias modules at the old
paths, the changelog, the frozen plugins of ``tests/data/frozen_plugins``, the list of
historical imports (``tests/test_public_api.py``, ``tools/import_history.py``), this file and
its test (``tests/test_rooms.py``), any line that speaks of a deprecation, and the "Deprecated"
sections of Markdown pages.
"""
from __future__ import annotations

import argparse
import ast
import io
import re
import subprocess
import sys
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")


def _room(pkg: str, room: str, names: str) -> list[tuple[str, str]]:
    return [(f"{pkg}.{n}", f"{pkg}.{room}.{n}") for n in names.split()]


#: old module -> new module
MOVES: dict[str, str] = dict(
    # the contact phase: the loops and their instances, the model and its view, joints,
    # dampers, the stable step, stress and what follows a change of the ice
    # (the law's contract, siku_core.contact_law, stays with the other contracts a plugin
    # imports at the top of siku_core: docs/reference/api.md)
    _room("siku_core", "contact",
          "contact_loops contact_model contact_tables contact_frames contact_joints "
          "contact_overlaps contacts_view damping joint_metrics stable_step kernel_cache stress "
          "ice_follow")
    + [("siku_core.contacts", "siku_core.contact.contact_forces")]
    # the run: the loop, its schedules, guards, restart, limits, what it prints, the output rules,
    # the element state it builds, the command line
    + _room("siku_core", "run",
            "simulation schedule guard restart progress summary phase_log limits ramp outputs "
            "elements cli")
    # the scene: files, the Python builder, their messages, units, packs and cells
    + [("siku_core.scene", "siku_core.scene.scene_file")]
    + _room("siku_core", "scene", "scene_api scene_messages units packs cells")
    # the geometry of elements in lon/lat (the writers, the exchange grid)
    + [("siku_io.output.element_geometry", "siku_core.geometry.element_geometry")]
    # waves: plane waves, the JONSWAP sea and its methods, the spectral sea, attenuation,
    # breaking
    + [("siku_forcing.waves", "siku_forcing.waves.wave_field")]
    + _room("siku_forcing", "waves",
            "wave_methods wave_kernels wave_lines wave_breaking spectral spectral_fast "
            "spectral_transport attenuation")
    # gridded fields: the CF reader and kernels, the regular grid and the exchange grid
    + [("siku_forcing.gridded", "siku_forcing.gridded.gridded_field")]
    + _room("siku_forcing", "gridded", "gridded_drag gridded_kernel gridded_reader cf")
    + [("siku_io.analysis.regular_grid", "siku_forcing.gridded.regular_grid"),
       ("siku_io.coupling.exchange", "siku_forcing.gridded.exchange")]
)

#: the docstring of each new subpackage
ROOMS = {
    "siku_core.contact": "The contact phase: the loops over joints and pairs and their cached "
                         "instances, the contact\nmodel and the read-only view a component sees "
                         "(``contacts_view``), joints, dampers, the\nstable step, stress and "
                         "what follows a change of the ice. A contact law's contract is\n"
                         "``siku_core.contact_law``.",
    "siku_core.run": "The run: the time-step loop (``simulation``), its schedules, guards, "
                     "restart, limits,\nprogress and summary, the output rules, the element "
                     "state it builds, and the command line.",
    "siku_core.scene": "Scenes: the TOML file and its validation (``scene_file``), the Python "
                       "builder (``scene_api``),\ntheir messages, durations with units, packs "
                       "and the smallest free cells.",
    "siku_forcing.waves": "Surface waves: plane waves and the JONSWAP sea (``wave_field``), "
                          "how a field sums its sea,\nthe spectral sea, attenuation laws and "
                          "wave-induced breaking.",
    "siku_forcing.gridded": "Gridded fields: velocity fields from NetCDF files "
                            "(``gridded_field``), their CF reader and\ninterpolation kernels, "
                            "the regular grid and the exchange grid of a coupled model\n"
                            "(``exchange``).",
}

#: old modules whose alias keeps some names that had already moved before (name -> home)
EXTRA_ALIASES = {
    "siku_core.contacts": ("MOVED_TO_CONTACT_LAW", "siku_core.contact_law"),
}

#: files that name the old paths on purpose (beside the aliases at the old paths)
KEEP = {"CHANGELOG.md", "tools/rooms.py", "tools/import_history.py", "tests/test_public_api.py",
        "tests/test_rooms.py"}
KEEP_UNDER = ("tests/data/frozen_plugins/", ".git/")
SUFFIXES = (".py", ".md", ".toml", ".tmpl")
LINE = 100  # the longest line (pyproject.toml, [tool.ruff])
_DEPRECATION = re.compile(r"deprecat", re.I)
_IMPORTED = re.compile(r"(?:^|[\s\"'`;])import\s+(?:[\w.]+(?:\s+as\s+\w+)?\s*,\s*)*$")


# ------------------------------------------------------------------ the layout
def path_of(module: str, package: bool = False) -> Path:
    parts = module.split(".")
    if package:
        return Path(*parts, "__init__.py")
    return Path(*parts[:-1], parts[-1] + ".py")


def clashes() -> set[str]:
    """Old modules whose name is a new package (``siku_forcing.waves``): their alias is the
    package's ``__init__``."""
    parents = {new.rsplit(".", 1)[0] for new in MOVES.values()}
    return {old for old in MOVES if old in parents}


def new_modules(root: Path) -> set[str]:
    """Every module and package of the tree as it stands (and of the new layout)."""
    out = set()
    for pkg in PACKAGES:
        for path in (root / pkg).rglob("*.py"):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out.add(".".join(parts))
    for new in MOVES.values():
        parts = new.split(".")
        for i in range(1, len(parts) + 1):
            out.add(".".join(parts[:i]))
    return out


def alias_files() -> set[str]:
    out = {path_of(old).as_posix() for old in MOVES if old not in clashes()}
    out |= {path_of(old, package=True).as_posix() for old in clashes()}
    return out


# ------------------------------------------------------------------ rewriting
def _module_of(rel: Path) -> str | None:
    parts = list(rel.with_suffix("").parts)
    if parts[0] not in PACKAGES:
        return None
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _resolve(module: str, is_pkg: bool, level: int, base: str) -> str:
    pkg = module.split(".")
    if not is_pkg:
        pkg = pkg[:-1]
    pkg = pkg[:len(pkg) - (level - 1)]
    return ".".join(pkg + ([base] if base else []))


def _relative(module: str, is_pkg: bool, target: str) -> str:
    """``target`` written relative to ``module`` (``.x``, ``..x``), when both are in one
    top-level package; else ``target``."""
    here = module.split(".") if is_pkg else module.split(".")[:-1]
    there = target.split(".")
    if here[0] != there[0]:
        return target
    common = 0
    while common < min(len(here), len(there)) and here[common] == there[common]:
        common += 1
    dots = "." * (len(here) - common + 1)
    return dots + ".".join(there[common:])


def _map_module(name: str, present: set[str]) -> str | None:
    """The new home of ``name`` if it is an old module (or under one), else ``None``."""
    if name in MOVES:
        return MOVES[name]
    return None


class Rewriter:
    def __init__(self, root: Path):
        self.root = root
        self.present = new_modules(root)
        self.clash = clashes()
        self.reverse = {new: old for old, new in MOVES.items()}
        olds = sorted(MOVES, key=len, reverse=True)
        self.dotted = re.compile(r"(?<![\w.])(" + "|".join(re.escape(o) for o in olds)
                                 + r")(?![\w])(\.[A-Za-z_]\w*)?")
        self.paths = re.compile(r"(?<![\w/.])(" + "|".join(
            re.escape(path_of(o).as_posix()) for o in olds) + r")(?![\w])")
        self.path_map = {path_of(o).as_posix(): path_of(n).as_posix() for o, n in MOVES.items()}

    # dotted paths and file paths, anywhere in a line
    def _dotted(self, m: re.Match) -> str:
        old, tail = m.group(1), m.group(2) or ""
        if old in self.clash and tail and old + tail in self.present:
            return m.group(0)  # already new: a module of the package that took the old name
        if old in self.clash and not tail and m.string[m.end():m.end() + 1] not in ('"', ":") \
                and not _IMPORTED.search(m.string[:m.start()]):
            # the package itself; the old module in import statements (``import a, OLD``) and
            # as an entry point ("siku_forcing.waves", "siku_forcing.waves:name")
            return m.group(0)
        return MOVES[old] + tail

    def text(self, line: str) -> str:
        if _DEPRECATION.search(line):
            return line
        line = self.dotted.sub(self._dotted, line)
        return self.paths.sub(lambda m: self.path_map[m.group(1)], line)

    # import statements of Python source
    def imports(self, src: str, module: str | None, is_pkg: bool) -> str:
        try:
            tree = ast.parse(src)
        except SyntaxError:
            return src
        lines = src.splitlines(keepends=True)
        edits = []  # (start line, end line, replacement lines)
        old_module = self.reverse.get(module) if module else None
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or node.module == "__future__":
                continue
            new = self._import_from(node, module, is_pkg, old_module)
            if new is not None:
                edits.append((node.lineno, node.end_lineno, node.col_offset, new))
        for start, end, col, new in sorted(edits, reverse=True):
            first, last = lines[start - 1], lines[end - 1]
            indent = first[:col]
            rest = last[len(last.rstrip("\n")):]  # the newline
            tail = last.rstrip("\n")
            node_end = _end_col(src, start, end, col)
            after = tail[node_end:] if node_end is not None else ""
            text = "".join(_format(indent, stmt) + "\n" for stmt in new)
            text = text[:-1] + after + rest
            lines[start - 1:end] = [text]
        return "".join(lines)

    def _import_from(self, node: ast.ImportFrom, module, is_pkg, old_module):
        """The statements that replace ``node`` (a list of (base, [(name, asname)])), or
        ``None`` when it stays."""
        level, base = node.level, node.module or ""
        if level:
            if module is None:
                return None
            absolute = _resolve(module, is_pkg, level, base)
            if old_module is not None:
                # written against the old place of this module? (its base, or a module it
                # imports from its base, is not where the new place says)
                old_abs = _resolve(old_module, False, level, base)
                known = self.present | set(MOVES)
                stale = absolute not in self.present or absolute in MOVES or any(
                    f"{absolute}.{a.name}" not in known and f"{old_abs}.{a.name}" in known
                    for a in node.names)
                if stale and old_abs in known:
                    absolute = old_abs
        else:
            absolute = base
        groups: list[tuple[str, list[tuple[str, str | None]]]] = []
        changed = False
        for a in node.names:
            target_base = absolute
            name, asname = a.name, a.asname
            sub = f"{absolute}.{name}"
            if sub in MOVES and not (absolute in self.clash and sub in self.present
                                     and sub not in MOVES):
                new = MOVES[sub]
                target_base, newname = new.rsplit(".", 1)
                if newname != name:
                    asname = asname or name
                name = newname
            elif absolute in MOVES and not (absolute in self.clash and sub in self.present):
                target_base = MOVES[absolute]
            if groups and groups[-1][0] == target_base:
                groups[-1][1].append((name, asname))
            else:
                groups.append((target_base, [(name, asname)]))
        # the statement as written, resolved: does it already name the new places?
        if level:
            orig_abs = _resolve(module, is_pkg, level, base)
        else:
            orig_abs = base
        if len(groups) == 1 and groups[0][0] == orig_abs and all(
                (n, s) == (a.name, a.asname) for (n, s), a in zip(groups[0][1], node.names)):
            return None
        changed = True
        out = []
        for target_base, names in groups:
            if level and module is not None:
                written = _relative(module, is_pkg, target_base)
            else:
                written = target_base
            out.append((written, names))
        return out if changed else None

    def python(self, src: str, rel: Path) -> str:
        module = _module_of(rel)
        src = self.imports(src, module, rel.name == "__init__.py")
        return self.lines(src, markdown=False, prose=_prose_lines(src))

    def lines(self, src: str, markdown: bool, prose: set[int] = frozenset()) -> str:
        out = []
        skip_level = None
        for n, line in enumerate(src.splitlines(keepends=True), 1):
            if markdown:
                h = re.match(r"(#+)\s", line)
                if h:
                    level = len(h.group(1))
                    if skip_level is not None and level <= skip_level:
                        skip_level = None
                    if re.search(r"deprecat", line, re.I):
                        skip_level = level
                if skip_level is None:
                    m = re.match(r"(\s*)from\s+([\w.]+)\s+import\s+(.+?)\s*$", line)
                    if m and m.group(2).split(".")[0] in PACKAGES:
                        line = self._md_import(m, line)
            new = line if skip_level is not None else self.text(line)
            if n in prose and len(new.rstrip("\n")) > LINE and len(line.rstrip("\n")) <= LINE:
                new = _wrap(new)
            out.append(new)
        return "".join(out)

    def _md_import(self, m: re.Match, line: str) -> str:
        indent, base, names = m.groups()
        if names.startswith("(") or "#" in names:
            return line
        parsed = []
        for part in names.split(","):
            bits = part.strip().split(" as ")
            if not re.fullmatch(r"\w+", bits[0].strip()):
                return line
            parsed.append((bits[0].strip(), bits[1].strip() if len(bits) > 1 else None))
        node = ast.ImportFrom(module=base, names=[ast.alias(name=n, asname=s) for n, s in parsed],
                              level=0)
        new = self._import_from(node, None, False, None)
        if new is None:
            return line
        nl = "\n" if line.endswith("\n") else ""
        return "\n".join(_format(indent, stmt) for stmt in new) + nl


def _prose_lines(src: str) -> set[int]:
    """Lines of ``src`` that are prose: comments and the lines of triple-quoted strings."""
    out = set()
    try:
        for tok in tokenize.generate_tokens(io.StringIO(src).readline):
            if tok.type == tokenize.COMMENT and not tok.line[:tok.start[1]].strip():
                out.add(tok.start[0])
            elif tok.type == tokenize.STRING and (tok.end[0] > tok.start[0] or tok.string.lstrip(
                    "rbuRBU").startswith(('"""', "'''"))):
                out.update(range(tok.start[0], tok.end[0] + 1))
    except (tokenize.TokenError, SyntaxError):
        return set()
    return out


def _wrap(line: str) -> str:
    """A prose line longer than ``LINE`` split at spaces, its continuations indented as its
    text (past a comment's ``#``/``#:`` and a bullet's ``*``/``-``)."""
    nl = "\n" if line.endswith("\n") else ""
    line = line.rstrip("\n")
    lead = re.match(r"\s*(#:?\s+)?([*-]\s+)?", line)
    indent = re.match(r"\s*", line).group(0)
    cont = indent + (lead.group(1) or "") + " " * len(lead.group(2) or "")
    rows = []
    while len(line) > LINE:
        cut = line.rfind(" ", len(cont) + 1, LINE + 1)
        if cut <= len(cont):
            break
        rows.append(line[:cut].rstrip())
        line = cont + line[cut + 1:].lstrip()
    rows.append(line)
    return "\n".join(rows) + nl


def _end_col(src: str, start: int, end: int, col: int) -> int | None:
    """The column where the import statement at ``start:col`` ends on line ``end``."""
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.ImportFrom) and node.lineno == start and node.col_offset == col:
            return node.end_col_offset
    return None


def _format(indent: str, stmt) -> str:
    base, names = stmt
    parts = [n if s is None else f"{n} as {s}" for n, s in names]
    one = f"{indent}from {base} import {', '.join(parts)}"
    if len(one) <= 100:
        return one
    rows, row = [], indent + "    "
    for p in parts:
        piece = p + ","
        if len(row) + len(piece) + 1 > 100 and row.strip():
            rows.append(row.rstrip())
            row = indent + "    "
        row += piece + " "
    rows.append(row.rstrip())
    return f"{indent}from {base} import (\n" + "\n".join(rows) + f"\n{indent})"


def tracked_files(root: Path) -> list[Path]:
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=root,
                         capture_output=True, text=True, check=True).stdout.split("\n")
    return [Path(p) for p in out if p.endswith(SUFFIXES) or p.endswith("pyproject.toml")]


def rewrite(root: Path, write: bool = True) -> list[str]:
    """Rewrite every file of the tree; returns the files that changed."""
    rw = Rewriter(root)
    keep = KEEP | alias_files()
    changed = []
    for rel in tracked_files(root):
        posix = rel.as_posix()
        if posix in keep or posix.startswith(KEEP_UNDER) or not (root / rel).is_file():
            continue
        src = (root / rel).read_text(encoding="utf-8")
        new = rw.python(src, rel) if rel.suffix == ".py" else rw.lines(
            src, markdown=rel.suffix in (".md", ".tmpl"))
        if new != src:
            changed.append(posix)
            if write:
                (root / rel).write_text(new, encoding="utf-8")
    return changed


# ------------------------------------------------------------------ moving
def _public_names(src: str) -> list[str]:
    """The public names a module binds at its top level (definitions, assignments and the
    names it imports from siku's packages)."""
    names = []
    for node in ast.parse(src).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            for t in node.targets:
                names += [n.id for n in ast.walk(t) if isinstance(n, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
        elif isinstance(node, ast.ImportFrom) and node.module != "__future__" and (
                node.level or (node.module or "").split(".")[0] in PACKAGES):
            names += [a.asname or a.name for a in node.names]
    return sorted({n for n in names if not n.startswith("_")})


def _shim(old: str, new: str) -> str:
    return (f'"""Deprecated: this module moved to :mod:`{new}` (siku 0.2.0).\n\n'
            f"``import {old}`` gives that module, with a :class:`DeprecationWarning`\n"
            "(:func:`siku_core.deprecation.moved_module`).\n"
            '"""\n'
            "from siku_core.deprecation import moved_module\n\n"
            f'moved_module(__name__, "{new}")\n')


def _names_alias(old: str, doc: str, moves: dict[str, str]) -> str:
    rows = []
    for home in sorted(set(moves.values())):
        names = sorted(n for n, h in moves.items() if h == home)
        text, row = [], "    "
        for n in names:
            piece = repr(n) + ", "
            if len(row) + len(piece) > 96:
                text.append(row.rstrip())
                row = "    "
            row += piece
        text.append(row.rstrip())
        rows.append(f"_{len(rows)} = (\n" + "\n".join(text) + "\n)\n")
        rows[-1] += f"_MOVES.update(dict.fromkeys(_{len(rows) - 1}, {home!r}))\n"
    return (f'"""{doc}\n\nEach name that this module held keeps importing from here, with a\n'
            ":class:`DeprecationWarning` naming its new home "
            "(:func:`siku_core.deprecation.moved_names`).\n"
            '"""\n'
            "from siku_core.deprecation import moved_names\n\n"
            "_MOVES: dict[str, str] = {}\n" + "".join(rows)
            + "__getattr__ = moved_names(__name__, _MOVES)\n")


def _git(*args: str) -> None:
    subprocess.run(["git", *args], cwd=ROOT, check=True)


def apply(root: Path) -> None:
    clash = clashes()
    # the sources of the clashing modules first: their package takes the name
    sources = {}
    for old, new in MOVES.items():
        src_path = root / path_of(old)
        if not src_path.exists():
            raise SystemExit(f"{path_of(old)}: not found (already moved? use --rewrite-only)")
        sources[old] = src_path.read_text(encoding="utf-8")
    for old in sorted(clash):
        tmp = path_of(old).with_suffix(".moving")
        _git("mv", path_of(old).as_posix(), tmp.as_posix())
    for room in sorted({new.rsplit(".", 1)[0] for new in MOVES.values()}):
        init = root / path_of(room, package=True)
        if not init.exists():
            init.parent.mkdir(parents=True, exist_ok=True)
            doc = ROOMS.get(room, "")
            init.write_text(f'"""{doc}\n"""\n' if doc else "", encoding="utf-8")
            _git("add", init.relative_to(root).as_posix())
    for old, new in MOVES.items():
        src = path_of(old).with_suffix(".moving") if old in clash else path_of(old)
        (root / path_of(new)).parent.mkdir(parents=True, exist_ok=True)
        _git("mv", src.as_posix(), path_of(new).as_posix())
    # the aliases at the old paths
    for old, new in MOVES.items():
        if old in clash:
            moves = dict.fromkeys(_public_names(sources[old]), new)
            doc = ROOMS[old] + (f"\n\nThe module ``{old}`` of siku 0.1 is\n:mod:`{new}` since "
                                "0.2.0.")
            (root / path_of(old, package=True)).write_text(_names_alias(old, doc, moves),
                                                           encoding="utf-8")
        elif old in EXTRA_ALIASES:
            var, home = EXTRA_ALIASES[old]
            moves = dict.fromkeys(_public_names(sources[old]), new)
            for name in (var, "moved_names"):
                moves.pop(name, None)
            extra = ast.literal_eval(_assigned(sources[old], var))
            moves.update(dict.fromkeys(extra, home))
            doc = (f"Deprecated: the entry points of the contact loops moved to\n:mod:`{new}`, "
                   f"the contact-law layouts and break modes to\n:mod:`{home}` (siku 0.2.0).")
            (root / path_of(old)).write_text(_names_alias(old, doc, moves), encoding="utf-8")
            _strip_assigned(root / path_of(new), var)
        else:
            (root / path_of(old)).write_text(_shim(old, new), encoding="utf-8")
        _git("add", path_of(old, package=old in clash).as_posix())
    for cache in list(root.rglob("*.nbi")) + list(root.rglob("*.nbc")):
        cache.unlink()


def _assigned(src: str, var: str) -> str:
    """The value of ``var = (...).split()`` at the top of ``src``, as a list literal."""
    for node in ast.parse(src).body:
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == var for t in node.targets):
            value = node.value
            if isinstance(value, ast.Call):  # "...".split()
                text = ast.literal_eval(value.func.value)
                return repr(text.split())
            return ast.unparse(value)
    raise SystemExit(f"{var} not found")


def _strip_assigned(path: Path, var: str) -> None:
    """Drop the alias block (``var = ...`` and the ``__getattr__`` built from it, with the
    comment above) from the moved module and its ``moved_names`` import."""
    src = path.read_text(encoding="utf-8")
    tree = ast.parse(src)
    lines = src.splitlines(keepends=True)
    first = None
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id in (var, "__getattr__") for t in node.targets):
            first = node.lineno if first is None else first
    if first is None:
        return
    start = first - 1
    while start > 0 and lines[start - 1].startswith("#"):
        start -= 1
    kept = lines[:start]
    while kept and not kept[-1].strip():
        kept.pop()
    text = "".join(kept)
    text = re.sub(r"^from \S*deprecation import moved_names\n", "", text, flags=re.M)
    path.write_text(text, encoding="utf-8")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--apply", action="store_true", help="move, alias and rewrite")
    g.add_argument("--rewrite-only", action="store_true", help="rewrite references only")
    g.add_argument("--check", action="store_true", help="list the files a rewrite changes")
    args = p.parse_args(argv)
    if args.apply:
        apply(ROOT)
    changed = rewrite(ROOT, write=not args.check)
    for path in changed:
        print(path)
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
