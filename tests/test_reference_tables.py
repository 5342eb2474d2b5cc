"""The reference tables of the documentation are the code's: every generated region of a page
(``<!-- generated: NAME -->``, ``docs/_ext/siku_tables.py``) holds the table the code gives now,
the site's extension renders them from the code, and the tables cover every layout entry, break
mode, built-in contact-law parameter (with its unit) and declared per-element field (with its
units)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from siku_core import contact_law
from siku_core.plugins import get_registry

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))
import siku_tables  # noqa: E402


@pytest.mark.parametrize("page", siku_tables.pages(), ids=lambda p: p.name)
def test_every_generated_region_holds_the_codes_table(page):
    text = page.read_text(encoding="utf-8")
    for name, table in siku_tables.regions(text):
        assert table == siku_tables.render(name), (
            f"{page.relative_to(ROOT)}: the table '{name}' differs from the code; rewrite it "
            "with python docs/_ext/siku_tables.py --write")


def test_every_table_is_on_a_page_and_the_site_renders_it_from_the_code():
    shown = {name for p in siku_tables.pages()
             for name, _ in siku_tables.regions(p.read_text(encoding="utf-8"))}
    assert shown == set(siku_tables.TABLES)
    stale = "<!-- generated: break-modes -->\n| a stale table |\n<!-- end generated -->"
    fresh = siku_tables.refresh(stale)
    assert "stale" not in fresh and siku_tables.render("break-modes") in fresh
    import siku_docs

    class App:
        class config:
            siku_repository = "https://example.org/"

    source = [stale]
    siku_docs._rewrite(App, "reference/tables", source)
    assert siku_tables.render("break-modes") in source[0]


def test_the_tables_cover_what_the_code_declares():
    laws = siku_tables.render("contact-law-parameters")
    reg = get_registry()
    for name, e in reg.entries["contact_law"].items():
        if e.package != "siku":
            continue
        for pname, p in e.cls.params.items():
            unit = p.unit or "—"
            assert f"| `{name}` | `{pname}` |" in laws and f"| {unit} |" in laws, (name, pname)
    fields = siku_tables.render("declared-fields")
    for kind in siku_tables.KINDS:
        for name, e in reg.entries.get(kind, {}).items():
            for f in getattr(e.cls, "owned_fields", ()) if e.package == "siku" else ():
                assert f"| `{f.name}` | `{f.units}` |" in fields, (kind, name, f.name)
    modes = siku_tables.render("break-modes")
    for mode in contact_law.BreakMode:
        assert f"| {int(mode)} | `{mode.name.lower()}` |" in modes
    guide = (ROOT / "docs" / "howto" / "contact_laws.md").read_text(encoding="utf-8")
    for layout, size, prefix in ((contact_law.COLLISION_LAYOUT, contact_law.G_SIZE, "G"),
                                 (contact_law.JOINT_LAYOUT, contact_law.J_SIZE, "J")):
        assert len(layout) == size and f"`{prefix}_SIZE = {size}` entries" in guide
