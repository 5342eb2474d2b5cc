"""The reference tables of the documentation, rendered from the code so that they cannot drift.

A page holds a generated table between two comments::

    <!-- generated: NAME -->

    | ... the table ... |

    <!-- end generated -->

The site's extension (``siku_docs.py``) replaces every such region with the table rendered
from the code when it reads the page, and ``tests/test_reference_tables.py`` fails when a page
in the repository holds another table than the code gives (the pages read on the repository as
they read on the site). Rewrite the pages after a change of the code with::

    python docs/_ext/siku_tables.py --write

The tables (``TABLES``): ``collision-layout``, ``joint-layout``, ``out-layout`` (the contact
evaluators' vectors, ``siku_core.contact_law``), ``break-modes``, ``contact-law-parameters``
(every registered law's parameters with their units), ``declared-fields`` (the units of every
per-element field a registered component declares), ``engine-fields`` (the engine's own
per-element fields, ``siku_core.fields.ENGINE_FIELDS``)
The scene reference's key tables are checked against the scene model by ``tests/test_docs.py``.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
REGION = re.compile(r"(<!-- generated: ([a-z-]+) -->\n)(.*?)(<!-- end generated -->)", re.S)


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _layout(name: str) -> str:
    from siku_core import contact_law

    return contact_law.layout_table(getattr(contact_law, name))


def _break_modes() -> str:
    from siku_core.contact_law import BREAK_MODE_MEANINGS, BreakMode

    rows = ["| constant | value | name in outputs | meaning |", "|---|---|---|---|"]
    for mode in BreakMode:
        const = "—" if not mode else f"`BREAK_{mode.name}`"
        rows.append(f"| {const} | {int(mode)} | `{mode.name.lower()}` | "
                    f"{_cell(BREAK_MODE_MEANINGS[mode])} |")
    return "\n".join(rows)


def _default(value) -> str:
    if value is None:
        return "required"
    if isinstance(value, float):
        return f"`{value:g}`"
    return f"`{value!r}`" if not isinstance(value, str) else f'`"{value}"`'


def _registry():
    from siku_core.plugins import get_registry

    return get_registry()


def _builtin(kind: str) -> list[tuple[str, type]]:
    """The components of ``kind`` siku itself registers (not a third party's), by name."""
    entries = _registry().entries.get(kind, {})
    return sorted((n, e.cls) for n, e in entries.items() if e.package == "siku")


def _law_parameters() -> str:
    rows = ["| law | parameter | default | unit | meaning |", "|---|---|---|---|---|"]
    for name, cls in _builtin("contact_law"):
        for pname, p in cls.params.items():
            rows.append(f"| `{name}` | `{pname}` | {_default(p.default)} | {_cell(p.unit) or '—'} "
                        f"| {_cell(p.doc)} |")
    return "\n".join(rows)


KINDS = ("contact_law", "forcing", "field", "process", "integrator", "element_source",
         "writer", "attenuation_law", "broad_phase")


def _declared_fields() -> str:
    rows = ["| field | units | grid | declared by | meaning |", "|---|---|---|---|---|"]
    found = []
    for kind in KINDS:
        for name, cls in _builtin(kind):
            owner = f"{kind.replace('_', ' ')} `{name}`"
            for f in cls.owned_fields:
                found.append((f.name, f.units, f.grid, owner, f.long_name))
            for f in cls.optional_fields:
                found.append((f.name, f.units, f.grid, f"{owner} (when a parameter asks)",
                              f.long_name))
    for fname, units, grid, owner, meaning in sorted(found):
        rows.append(f"| `{fname}` | `{units}` | {grid} | {owner} | {_cell(meaning)} |")
    return "\n".join(rows)


def _engine_fields() -> str:
    from siku_core.fields import ENGINE_FIELDS

    rows = ["| name | units | standard name | restarted | meaning |", "|---|---|---|---|---|"]
    for f in ENGINE_FIELDS.values():
        rows.append(f"| `{f.name}` | `{f.units}` | {f.standard_name or '—'} | "
                    f"{'yes' if f.restart else 'no'} | {_cell(f.long_name)} |")
    return "\n".join(rows)


TABLES = {
    "collision-layout": lambda: _layout("COLLISION_LAYOUT"),
    "joint-layout": lambda: _layout("JOINT_LAYOUT"),
    "out-layout": lambda: _layout("OUT_LAYOUT"),
    "break-modes": _break_modes,
    "contact-law-parameters": _law_parameters,
    "declared-fields": _declared_fields,
    "engine-fields": _engine_fields,
}


def render(name: str) -> str:
    """The table ``name`` as Markdown (no trailing newline)."""
    try:
        return TABLES[name]()
    except KeyError:
        raise KeyError(f"no generated table {name!r}; one of {', '.join(TABLES)}") from None


def refresh(text: str) -> str:
    """``text`` with every generated region holding the table the code gives now."""
    return REGION.sub(lambda m: m.group(1) + "\n" + render(m.group(2)) + "\n\n" + m.group(4),
                      text)


def regions(text: str) -> list[tuple[str, str]]:
    """``(name, table)`` of every generated region of ``text``, as the text holds it."""
    return [(m.group(2), m.group(3).strip("\n")) for m in REGION.finditer(text)]


def pages() -> list[Path]:
    """The pages of docs/ that hold a generated region."""
    return sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts
                  and "<!-- generated: " in p.read_text(encoding="utf-8"))


def main(argv: list[str]) -> int:
    if argv not in ([], ["--write"]):
        print("usage: python docs/_ext/siku_tables.py [--write]", file=sys.stderr)
        return 2
    stale = []
    for page in pages():
        text = page.read_text(encoding="utf-8")
        new = refresh(text)
        if new != text:
            stale.append(page.relative_to(DOCS.parent).as_posix())
            if argv:
                page.write_text(new, encoding="utf-8")
    verb = "rewritten" if argv else "differ from the code (rewrite with --write)"
    print(f"{len(stale)} page(s) {verb}" + (": " + ", ".join(stale) if stale else ""))
    return 1 if stale and not argv else 0


if __name__ == "__main__":
    sys.path.insert(0, str(DOCS.parent))
    sys.exit(main(sys.argv[1:]))
