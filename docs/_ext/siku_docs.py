"""A Sphinx extension for siku's Markdown pages, read as they are on the repository.

* ``<a id="name"></a>`` (the anchors of docs/reference/references.md, which GitHub renders)
  becomes a MyST target ``(name)=``, so ``references.md#name`` links resolve in the site;
* a generated region (``<!-- generated: NAME -->`` ... ``<!-- end generated -->``) holds the
  table the code gives when the site is built (``siku_tables.py``: layouts, break modes, the
  contact laws' parameters, the declared per-element fields), so the site cannot drift from
  the code;
* a link that leaves docs/ (``../../CHANGELOG.md``, ``../../examples/...``) points to the
  file in the repository (``siku_repository`` of conf.py).
"""
from __future__ import annotations

import re
from pathlib import Path

ANCHOR = re.compile(r'^<a id="([^"]+)"></a>\s*$', re.M)
OUTSIDE = re.compile(r"\]\(((?:\.\./)+)([^)#\s]+)(#[^)\s]*)?\)")


def _rewrite(app, docname: str, source: list[str]) -> None:
    from siku_tables import refresh

    text = ANCHOR.sub(r"(\1)=", refresh(source[0]))
    depth = len(Path(docname).parts) - 1  # folders between the page and docs/

    def link(m: re.Match) -> str:
        ups = m.group(1).count("../")
        if ups <= depth:
            return m.group(0)
        return f"]({app.config.siku_repository}{m.group(2)}{m.group(3) or ''})"

    source[0] = OUTSIDE.sub(link, text)


def setup(app):
    app.add_config_value("siku_repository", "", "env")
    app.connect("source-read", _rewrite)
    return {"parallel_read_safe": True, "version": "1"}
