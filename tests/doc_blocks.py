"""The code blocks of the pages in ``docs/``, and a runner that runs a page's blocks as a reader
would, in order, in a clean folder (``tests/test_docs.py``).

A page says how a block is used in an HTML comment on the line just before it (invisible when
the page is rendered):

- ``<!-- file: NAME -->``: the reader saves the block as ``NAME`` (a scene the page later runs);
- ``<!-- not run: REASON -->``: the block is not run here, and ``REASON`` says why (an excerpt
  checked elsewhere, a run of minutes that another test makes, a command for a cluster);
- ``<!-- stand-in: NAME, ... -->``: the block reads files a reader made earlier with a long
  command (``siku_default.h5`` from ``siku run``); short stand-ins made by the same command are
  put in the folder first;
- ``<!-- network -->``: the block downloads; it runs against stand-ins (``wget`` writes a
  stand-in file of the layout the page describes, ``cdsapi`` a stand-in ERA5 file).

A notebook page's code cells (MyST-NB's ``{code-cell} ipython3``, run again when the site is
built) are ``python`` blocks. Blocks of language ``text`` are listings and output, not
commands; ``toml`` blocks without a ``file`` comment are checked by parsing
(``test_toml_examples_in_the_docs_parse``). Every other block is run: ``bash`` through bash
(``set -e``), ``python`` in one namespace per page.

What a block needs is said where the reader sees it, and the runner gives a page nothing more:

- a page runs in an empty folder, unless it says, before its first block that reads them, that
  its blocks run from the root of a clone of siku (:func:`runs_in_clone`): then the folder holds
  copies of ``examples/`` and the helper scripts of ``tests/``, as a clone does;
- a ``python`` block that uses a name an earlier block defined says so in the text just before
  it (``the mesh built above``): :func:`continued_names` finds such names.
"""
from __future__ import annotations

import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```(\{code-cell\}|\w*)[^\n]*\n(.*?)^```[ \t]*$",
                   re.MULTILINE | re.DOTALL)
#: a notebook page's code cell (MyST-NB: ```{code-cell} ipython3) is a python block here too
CELL = "{code-cell}"
NOTE = re.compile(r"<!--\s*(file|not run|stand-in|network)\s*:?\s*(.*?)\s*-->")


@dataclass
class Block:
    page: str  # relative to the repository
    line: int
    lang: str
    code: str
    notes: dict[str, str] = field(default_factory=dict)

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"

    @property
    def runs(self) -> bool:
        if "not run" in self.notes or self.lang == "text":
            return False
        return self.lang in ("bash", "python") or "file" in self.notes


def pages() -> list[Path]:
    return sorted(DOCS.rglob("*.md"))


def blocks(page: Path) -> list[Block]:
    text = page.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        before = text[: m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        notes = {k: v for k, v in NOTE.findall(before)}
        lang = "python" if m.group(1) == CELL else m.group(1)
        out.append(Block(page.relative_to(ROOT).as_posix(), text[: m.start()].count("\n") + 1,
                         lang, m.group(2), notes))
    return out


#: how a page says that its blocks run from the root of a clone of siku
CLONE = re.compile(r"root of (?:a|the|your) clone", re.IGNORECASE)
#: what a block reads from a clone (beside the installed package)
FROM_CLONE = re.compile(r"(?<![\w/.])(?:examples|tests)/")


def runs_in_clone(page: Path | str) -> bool:
    """Whether the page says that its blocks run from the root of a clone of siku."""
    return bool(CLONE.search(Path(page).read_text(encoding="utf-8")
                             if isinstance(page, Path) else page))


def reads_clone(block: Block) -> bool:
    """Whether a run block reads files of a clone (``examples/``, ``tests/``)."""
    return block.runs and bool(FROM_CLONE.search(block.code))


def text_before(page_text: str, block: Block) -> str:
    """The page's text between the block before ``block`` (or the top) and ``block``."""
    lines = page_text.split("\n")[: block.line - 1]
    head = "\n".join(lines)
    fences = [m.end() for m in FENCE.finditer(head)]
    return head[fences[-1]:] if fences else head


def continued_names(code: str) -> list[str]:
    """Names a python block uses without defining or importing them (nor builtins): what it
    takes from an earlier block of its page."""
    import ast
    import builtins

    tree = ast.parse(code)
    bound: set[str] = set()
    used: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            bound.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            bound.add(node.name)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
        elif isinstance(node, ast.ExceptHandler) and node.name:
            bound.add(node.name)
        elif isinstance(node, ast.Name):
            (bound if isinstance(node.ctx, (ast.Store, ast.Del)) else used).add(node.id)
    return sorted(u for u in used - bound if not hasattr(builtins, u))


def prepare(folder: Path, clone: bool = True) -> None:
    """A clean folder; for a page that runs from the root of a clone (``clone``), with what a
    clone holds beside the docs: ``examples/`` and the helper scripts of ``tests/`` that pages
    run (copies: nothing a block writes reaches the source)."""
    if not clone:
        return
    shutil.copytree(ROOT / "examples", folder / "examples",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "*.h5", "*.nc"))
    (folder / "tests").mkdir()
    shutil.copy(ROOT / "tests" / "bmi_check.py", folder / "tests")


WGET = '''\
import sys
import datetime as dt
from pathlib import Path

from siku_forcing.synthetic import DEFAULT_ANTICYCLONE, write_ncep_pair

# a stand-in for wget URL: an NCEP/NCAR-layout file of the same name (April of the URL's year,
# the default scene's drifting anticyclone), written where wget would write the download
name = sys.argv[-1].rsplit("/", 1)[-1]
comp, stem = name.split(".", 1)
year = int(stem.split(".")[-2])
tmp = Path(".standin")
u, v = write_ncep_pair(tmp, DEFAULT_ANTICYCLONE, dt.datetime(year, 4, 1), 30 * 24.0,
                       stem=stem.removesuffix(".nc"))
(u if comp == "uwnd" else v).replace(name)
for p in (u, v):
    p.unlink(missing_ok=True)
tmp.rmdir()
print("stand-in for", sys.argv[-1], "->", name)
'''

CDSAPI = '''\
"""A stand-in for the cdsapi client: retrieve writes an ERA5-layout file (u10, v10 on
valid_time, latitude, longitude) of a uniform 8 m/s westerly for the days asked."""
import numpy as np
import pandas as pd
import xarray as xr


class Client:
    def retrieve(self, name, request, target):
        days = [f"{request['year'][0]}-{request['month'][0]}-{d}" for d in request["day"]]
        t = pd.date_range(days[0], pd.Timestamp(days[-1]) + pd.Timedelta("1D"), freq="1h")
        lat, lon = np.arange(90.0, -90.1, -2.5), np.arange(-180.0, 180.0, 2.5)  # coarse
        shape = (len(t), len(lat), len(lon))
        ds = xr.Dataset(
            {"u10": (("valid_time", "latitude", "longitude"), np.full(shape, 8.0, "f4"),
                     {"units": "m s**-1"}),
             "v10": (("valid_time", "latitude", "longitude"), np.zeros(shape, "f4"),
                     {"units": "m s**-1"})},
            coords={"valid_time": t, "latitude": ("latitude", lat, {"units": "degrees_north"}),
                    "longitude": ("longitude", lon, {"units": "degrees_east"})})
        ds.to_netcdf(target)
'''


def network_stand_ins(folder: Path, python: str) -> Path:
    """A folder with ``wget`` (a script) and ``cdsapi`` (a module) stand-ins; put it first on
    ``PATH`` and ``sys.path``."""
    bin_ = folder / ".standin_bin"
    bin_.mkdir()
    (bin_ / "wget").write_text(f"#!{python}\n" + WGET, encoding="utf-8")
    (bin_ / "wget").chmod(0o755)
    (bin_ / "cdsapi.py").write_text(CDSAPI, encoding="utf-8")
    return bin_
