"""No compiled kernel takes more than a handful of positional arguments.

Bulk data crosses into a numba kernel as named records (:mod:`siku_core.records`), not as a
long positional list kept in order by hand: a kernel takes a handful of records and scalars.
This test parses the sources of the engine and the shipped packages (no import, no compile),
finds every function decorated with numba's ``njit`` or ``jit`` (the contact loops' template,
:mod:`siku_core.contact.contact_loops`, is one of these sources) and fails naming ``file:function``
for each that takes more than :data:`LIMIT` positional arguments.

:data:`PENDING` lists the kernels still converting, each by ``path:function``; the test also
fails when an entry no longer exists or no longer exceeds the limit (strike it then).
"""
from __future__ import annotations

import ast
import functools
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")
#: the most positional arguments a compiled kernel may take
LIMIT = 12

#: kernels over the limit that are being converted to records (``path:function``): none
PENDING: frozenset[str] = frozenset()

NUMBA_DECORATORS = {"njit", "jit"}


def _numba_names(tree: ast.Module) -> tuple[set[str], set[str]]:
    """The names a module binds to numba's ``njit``/``jit`` (``from numba import njit as x``)
    and to the numba module itself (``import numba as nb``)."""
    funcs: set[str] = set()
    mods: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "numba":
            for a in node.names:
                if a.name in NUMBA_DECORATORS:
                    funcs.add(a.asname or a.name)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "numba":
                    mods.add(a.asname or a.name)
    return funcs, mods


def _is_numba(dec: ast.expr, funcs: set[str], mods: set[str]) -> bool:
    """Whether a decorator is ``njit``/``jit``, bare or called, by name or as ``numba.x``."""
    if isinstance(dec, ast.Call):
        dec = dec.func
    if isinstance(dec, ast.Name):
        return dec.id in funcs
    return (isinstance(dec, ast.Attribute) and dec.attr in NUMBA_DECORATORS
            and isinstance(dec.value, ast.Name) and dec.value.id in mods)


@functools.lru_cache(maxsize=None)
def compiled_kernels(root: Path = ROOT) -> dict[str, int]:
    """Every numba-compiled function of :data:`PACKAGES` as ``path:function`` → its number of
    positional arguments (``*args``: counted as one more than the limit)."""
    found: dict[str, int] = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            funcs, mods = _numba_names(tree)
            if not funcs and not mods:
                continue
            rel = path.relative_to(root).as_posix()
            for node in ast.walk(tree):
                if not isinstance(node, ast.FunctionDef):
                    continue
                if not any(_is_numba(d, funcs, mods) for d in node.decorator_list):
                    continue
                a = node.args
                n = len(a.posonlyargs) + len(a.args)
                if a.vararg is not None:
                    n = max(n, LIMIT) + 1
                found[f"{rel}:{node.name}"] = n
    return found


def test_the_parser_finds_the_kernels():
    """The scan sees the engine's kernels, the contact loops' template included: a scan that
    found nothing would pass any limit."""
    found = compiled_kernels()
    for name in ("siku_core/contact/contact_loops.py:_collision_chunk",
                 "siku_core/contact/contact_loops.py:_joint_forces",
                 "siku_core/contact/contact_forces.py:_gather_forces",
                 "siku_core/contact/ice_follow.py:follow_contacts",
                 "siku_plugins/processes/ridging.py:ridge_pairs",
                 "siku_plugins/processes/thermodynamics.py:semtner_step",
                 "siku_forcing/gridded/exchange.py:_pair_forces"):
        assert name in found, name
    assert len(found) > 100


def test_the_parser_counts_positional_arguments(tmp_path):
    """Decorators by any name numba's are bound to, bare or called; positional-only and
    ``*args`` counted; a function numba does not compile ignored."""
    src = tmp_path / "siku_core" / "k.py"
    src.parent.mkdir()
    wide = ", ".join(f"a{i}" for i in range(LIMIT + 1))
    src.write_text(
        "import numba as nb\nfrom numba import njit as fast\n"
        f"@fast(cache=True)\ndef wide({wide}):\n    pass\n"
        f"@nb.jit\ndef narrow(a, /, b, *, c):\n    pass\n"
        f"@nb.njit()\ndef star(a, *rest):\n    pass\n"
        f"def plain({wide}):\n    pass\n")
    for pkg in ("siku_plugins", "siku_forcing", "siku_io"):
        (tmp_path / pkg).mkdir()
    found = compiled_kernels(tmp_path)
    assert found == {"siku_core/k.py:wide": LIMIT + 1, "siku_core/k.py:narrow": 2,
                     "siku_core/k.py:star": LIMIT + 1}


def test_no_kernel_takes_more_than_twelve_positional_arguments():
    found = compiled_kernels()
    wide = sorted(f"{k} ({n})" for k, n in found.items() if n > LIMIT and k not in PENDING)
    assert not wide, ("compiled kernels with more than 12 positional arguments (hand bulk "
                      "data over as named records, siku_core.records): " + ", ".join(wide))


def test_pending_is_not_stale():
    """A kernel still listed as converting exists and still exceeds the limit."""
    found = compiled_kernels()
    stale = sorted(k for k in PENDING if found.get(k, 0) <= LIMIT)
    assert not stale, ("PENDING lists kernels that are gone or within the limit now (strike "
                       "them): " + ", ".join(stale))
