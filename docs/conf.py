"""Sphinx configuration of siku's documentation site.

Sphinx with MyST: the pages are the Markdown files of this folder as they read on the
repository (MyST renders them unchanged; MyST-NB runs the notebooks at build: the tutorial and
the gallery's pages ``gallery/*.md``, each drawing its figures from a small scene), autodoc
and napoleon render the public docstrings (numpy style, units in brackets) into the API
reference, and the small extension
``_ext/siku_docs.py`` keeps the Markdown pages valid for both readers (HTML anchors of the
references page as targets, links that leave docs/ to the repository). Build:

    python -m sphinx -W -b html docs docs/_build/html
    python -m sphinx -W -b linkcheck docs docs/_build/linkcheck
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))

project = "siku"
author = "The siku developers"
copyright = "the siku developers, GPL-3.0-or-later"
extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "siku_docs"]
# MyST-NB reads every page with the MyST parser and runs the notebooks among them (a page whose
# top matter says ``file_format: mystnb``: tutorial.md) at every build, in a Jupyter kernel
source_suffix = {".md": "myst-nb"}
nb_execution_mode = "force"
nb_execution_raise_on_error = True  # a cell that fails fails the build
nb_execution_show_tb = True
nb_execution_timeout = 600  # [s] per cell: the first run on a machine compiles siku's kernels
# each notebook runs in a new empty folder, as a reader's does: the files its cells write (the
# gallery's runs) never reach the source tree
nb_execution_in_temp = True
# SIKU_DOCS_GALLERY=skip: the gallery's pages are read and checked but their cells not run (the
# suite's quick build; its doc-block tests run those cells, and a full build runs them here)
if os.environ.get("SIKU_DOCS_GALLERY") == "skip":
    nb_execution_excludepatterns = ["gallery/*"]
# the kernel imports the siku of this tree (the one documented), whatever is installed
os.environ["PYTHONPATH"] = os.pathsep.join(
    [str(HERE.parent), *filter(None, [os.environ.get("PYTHONPATH")])])
os.environ.pop("MPLBACKEND", None)  # the kernel's own (inline): the notebook's plots are shown
root_doc = "index"
exclude_patterns = ["_build", "_ext", "gallery/make_gallery.py", "jupyter_execute"]
myst_enable_extensions = ["colon_fence"]
myst_heading_anchors = 3
# the generated table page of bench.accuracy (explanation/speed_accuracy_table.md) starts at H3
suppress_warnings = ["myst.header"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_numpy_docstring = True
html_theme = "alabaster"
# linkcheck: the pages' links within the site and to the repository; the outside world is not
# reached from a build
linkcheck_ignore = [r"https?://.*"]
#: where links that leave docs/ point (the repository's files)
siku_repository = "https://github.com/siku-model/siku/blob/main/"
