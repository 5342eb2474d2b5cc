"""The documentation site builds from the pages and the docstrings with warnings as errors
(a missing target, a broken cross-reference or a docstring autodoc cannot render fails), its
tutorial notebook runs at the build (a failing cell fails it), and its internal links check
(the README's command).

The gallery's pages (``docs/gallery/*.md``) are notebooks too: the quick build here reads and
checks them without running their cells (``SIKU_DOCS_GALLERY=skip``; tests/test_docs.py runs
those cells as a reader would), the full build (slow) runs them and finds their figures."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytest.importorskip("sphinx")
pytest.importorskip("myst_parser")
pytest.importorskip("myst_nb")


GALLERY = sorted(p.stem for p in (ROOT / "docs" / "gallery").glob("*.md"))


def _sphinx(builder: str, out: Path, fresh: bool = True,
            gallery: bool = False) -> subprocess.CompletedProcess:
    """``fresh``: read every page (``-E``); else reuse the pages read by the last build into
    ``out`` (the linkcheck after the html build: the same sources, read once). ``gallery``:
    run the gallery's cells too."""
    env = {**os.environ, "SIKU_DOCS_GALLERY": "run" if gallery else "skip"}
    return subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q",
                           *(["-E"] if fresh else []), "-b", builder, "-d",
                           str(out / ".doctrees"), str(ROOT / "docs"),
                           str(out / builder)], capture_output=True, text=True, timeout=900,
                          env=env)


def _images(html: Path, page: str) -> list[Path]:
    """The figures a notebook's cells drew into ``page`` (PNG files of the build)."""
    text = (html / f"{page}.html").read_text(encoding="utf-8")
    return [html / page.rsplit("/", 1)[0] / i if "/" in page else html / i
            for i in re.findall(r'<img[^>]*src="((?:\.\./)*_images/[0-9a-f]{16,}\.png)"', text)]


def test_the_site_builds_with_warnings_as_errors_and_its_links_resolve(tmp_path):
    r = _sphinx("html", tmp_path)
    assert r.returncode == 0, r.stderr[-4000:]
    html = tmp_path / "html"
    for page in ("index", "quickstart", "howto/plugins", "reference/scene",
                 "reference/references", "explanation/design"):
        assert (html / f"{page}.html").exists(), page
    api = (html / "reference" / "python_api.html").read_text(encoding="utf-8")
    for name in ("Simulation", "ContactLaw", "check_contact_law", "collision_geometry"):
        assert name in api, name
    # the tutorial notebook ran at this build: its printed drift and its plot are in the page
    tut = (html / "tutorial.html").read_text(encoding="utf-8")
    m = re.search(r"speed after 12 h: ([0-9.]+) m/s, ([0-9.]+) % of the wind", tut)
    assert m, "the tutorial's cells did not run"
    # free drift in a 10 m/s wind: a few per cent of it (Nansen's rule of thumb, about 2 %)
    assert 1.0 < float(m.group(2)) < 4.0, m.group(0)
    images = _images(html, "tutorial")
    assert images and all(i.stat().st_size > 10_000 for i in images)
    # the gallery's pages are read and rendered (their cells run in tests/test_docs.py)
    assert len(GALLERY) >= 3
    for page in GALLERY:
        assert (html / "gallery" / f"{page}.html").exists(), page
    # the references page's HTML anchors are targets of the site
    assert 'id="kulchitsky-et-al-2017"' in (html / "reference" / "references.html").read_text(
        encoding="utf-8")
    r = _sphinx("linkcheck", tmp_path, fresh=False)
    assert r.returncode == 0, r.stderr[-4000:]
    assert "broken" not in (tmp_path / "linkcheck" / "output.txt").read_text(encoding="utf-8")


@pytest.mark.slow
def test_the_full_build_draws_every_figure_of_the_gallery(tmp_path):
    """With the gallery's cells run (as a release's site is built): each page of the gallery
    holds the figures its cells drew and what they printed, and the build stays free of
    warnings."""
    r = _sphinx("html", tmp_path, gallery=True)
    assert r.returncode == 0, r.stderr[-4000:]
    html = tmp_path / "html"
    printed = {"bonded_block": r"bonds broken: \{", "cyclone_drift": r"24 floes, 2160 steps",
               "coastal_lead": r"joints broken in each hour: \["}
    assert set(printed) <= set(GALLERY)
    for page in GALLERY:
        images = _images(html, f"gallery/{page}")
        assert images and all(i.stat().st_size > 10_000 for i in images), page
        text = (html / "gallery" / f"{page}.html").read_text(encoding="utf-8")
        if page in printed:
            assert re.search(printed[page], text), f"{page}: its cells did not run"
