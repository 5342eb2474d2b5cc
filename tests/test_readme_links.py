"""The README's Documentation list: one link per item, every link to a file that exists."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_documentation_item_is_one_working_link():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Documentation", 1)[1].split("\n## ", 1)[0]
    items = [ln for ln in section.splitlines() if ln.startswith("- ")]
    assert len(items) >= 15
    docs = {p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").rglob("*.md")}
    for item in items:
        m = re.fullmatch(r"- \[([^\[\]]+)\]\(([^()\s]+)\)", item)
        assert m, f"not one link on one line: {item!r}"
        assert (ROOT / m.group(2)).is_file(), f"broken link: {item!r}"
        docs.discard(m.group(2))
    # every how-to and explanation page is reachable from the README
    assert not {d for d in docs if d.startswith(("docs/howto/", "docs/explanation/"))
                and not d.endswith("_table.md")}, docs
