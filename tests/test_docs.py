"""The docs agree with the code: the scene reference covers every key of the scene models (with
the model's type, default, unit and allowed range), and every TOML example parses.

``python tests/test_docs.py`` prints the reference tables generated from the models, to paste
into ``docs/reference/scene.md`` when a key is added (then write the description column).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
import types
import typing
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import pytest
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from siku_core.scene.scene_file import SceneCfg, scene_from_text
from siku_core.testing import toml_value
from siku_core.scene.units import parse_duration

import doc_blocks  # noqa: E402  (tests/doc_blocks.py)

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SCENE_MD = DOCS / "reference" / "scene.md"
HEADER = "| key | type | default | unit | allowed | meaning |"


# ---------------------------------------------------------------------------- generator
def _is_model(a: Any) -> bool:
    return isinstance(a, type) and issubclass(a, BaseModel)


def _strip_annotated(ann: Any) -> tuple[Any, list]:
    meta: list = []
    while typing.get_origin(ann) is Annotated:
        base, *m = typing.get_args(ann)
        for x in m:
            meta.extend(getattr(x, "metadata", [x]))
            meta.append(x)
        ann = base
    return ann, meta


def _non_none(ann: Any) -> list:
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        return [a for a in typing.get_args(ann) if a is not type(None)]
    return [ann]


def _is_duration(meta: list) -> bool:
    return any(getattr(m, "func", None) is parse_duration for m in meta)


def type_text(ann: Any, meta: list | None = None) -> str:
    """The TOML type of an annotation (with the field's own metadata), in words."""
    parts = []
    for a in _non_none(ann):
        a, m = _strip_annotated(a)
        m = m + list(meta or [])
        origin, args = typing.get_origin(a), typing.get_args(a)
        lens = {type(x).__name__: getattr(x, "min_length", None) or getattr(x, "max_length", None)
                for x in m if type(x).__name__ in ("MinLen", "MaxLen")}
        if _is_duration(m):
            parts.append("duration")
        elif origin is Literal:
            parts.append("string")
        elif origin is list:
            inner = _strip_annotated(args[0])[0]
            if lens.get("MinLen") is not None and lens.get("MinLen") == lens.get("MaxLen"):
                parts.append("[" + ", ".join([type_text(args[0])] * lens["MinLen"]) + "]")
            elif _is_model(inner):
                parts.append("array of tables")
            else:
                parts.append(f"list of {type_text(args[0])}")
        elif origin is dict:
            parts.append("tables" if _is_model(args[1]) else "table")
        elif _is_model(a):
            parts.append("table")
        else:
            parts.append({float: "float", int: "integer", str: "string", bool: "boolean"}.get(
                a, getattr(a, "__name__", str(a))))
    return " or ".join(parts)


def field_type(info: Any) -> str:
    return type_text(info.annotation, list(info.metadata))


def _plain(value: Any) -> Any:
    if isinstance(value, BaseModel):
        return {k: _plain(v) for k, v in value.model_dump(exclude_defaults=True).items()}
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def default_text(info: Any) -> str:
    if info.default_factory is not None:
        value = info.default_factory()
    elif info.default is PydanticUndefined:
        return "required"
    else:
        value = info.default
    if value is None:
        return "unset"
    text = toml_value(_plain(value))
    return text.replace("{  }", "{}")


def _num(v: float) -> str:
    return f"{v:g}"


def allowed_text(info: Any) -> str:
    found = list(info.metadata)
    choices: list[str] = []
    for a in _non_none(info.annotation):
        a, meta = _strip_annotated(a)
        found += meta
        if typing.get_origin(a) is Literal:
            choices += [f'"{c}"' for c in typing.get_args(a)]
    if choices:
        return "one of " + ", ".join(choices)
    lo = hi = ""
    min_items = None
    for c in found:
        name = type(c).__name__
        if name == "Gt":
            lo = f"{_num(c.gt)} <"
        elif name == "Ge":
            lo = f"{_num(c.ge)} ≤"
        elif name == "Lt":
            hi = f"< {_num(c.lt)}"
        elif name == "Le":
            hi = f"≤ {_num(c.le)}"
        elif name == "MinLen" and not field_type(info).startswith("["):
            min_items = c.min_length
    if lo and hi:
        return f"{lo} x {hi}"
    if lo:  # "0 <" reads "> 0"
        num, op = lo.rsplit(" ", 1)
        return f"{'>' if op == '<' else '≥'} {num}"
    if hi:
        return hi
    if min_items is not None:
        return f"at least {min_items} items"
    return "—"


def unit_of(info: Any) -> str | None:
    """The unit the model declares (``[unit]`` in the description; ``s`` for durations)."""
    m = re.search(r"\[([^\]]+)\]", info.description or "")
    if m:
        return m.group(1)
    if _is_duration(list(info.metadata)):
        return "s"
    for a in _non_none(info.annotation):
        if _is_duration(_strip_annotated(a)[1]):
            return "s"
    return None


def meaning_of(info: Any) -> str:
    return re.sub(r"\s*\[[^\]]+\]", "", info.description or "").strip()


def tables(model: type[BaseModel] = SceneCfg, path: str = "") -> list[tuple[str, type]]:
    """``(TOML table name, model)`` for every model reachable from the scene."""
    out = [(path or "top level", model)]
    for key, info in model.model_fields.items():
        for a in _non_none(info.annotation):
            a, _ = _strip_annotated(a)
            origin, args = typing.get_origin(a), typing.get_args(a)
            dotted = f"{path.strip('[]')}.{key}" if path and path != "top level" else key
            if _is_model(a):
                out += tables(a, f"[{dotted}]")
            elif origin is list and _is_model(_strip_annotated(args[0])[0]):
                out += tables(_strip_annotated(args[0])[0], f"[[{dotted}]]")
            elif origin is dict and _is_model(args[1]):
                out += tables(args[1], f"[{dotted}.NAME]")
    return out


def rows(model: type[BaseModel]) -> dict[str, list[str]]:
    """Generated cells ``[key, type, default, unit, allowed, meaning]`` per key."""
    out = {}
    for key, info in model.model_fields.items():
        out[key] = [f"`{key}`", field_type(info), f"`{default_text(info)}`",
                    unit_of(info) or "", allowed_text(info), meaning_of(info)]
    return out


def render() -> str:
    parts = []
    for name, model in tables():
        parts.append(f"## `{name}`\n\n{HEADER}\n|---|---|---|---|---|---|")
        for cells in rows(model).values():
            parts[-1] += "\n| " + " | ".join(cells) + " |"
    return "\n\n".join(parts)


# ---------------------------------------------------------------------------- reference
def sections(text: str) -> dict[str, str]:
    """Markdown ``## `name` `` sections by name."""
    out = {}
    for m in re.finditer(r"^## `([^`]+)`\s*$(.*?)(?=^## |\Z)", text, re.MULTILINE | re.DOTALL):
        out[m.group(1)] = m.group(2)
    return out


def doc_rows(section: str) -> dict[str, list[str]]:
    out = {}
    for line in section.splitlines():
        m = re.match(r"^\|\s*`([A-Za-z_]\w*)`\s*\|", line)
        if m:
            out[m.group(1)] = [c.strip() for c in line.strip().strip("|").split("|")]
    return out


@pytest.fixture(scope="module")
def reference() -> dict[str, str]:
    return sections(SCENE_MD.read_text(encoding="utf-8"))


@pytest.mark.parametrize("table, model", tables(), ids=[t for t, _ in tables()])
def test_scene_reference_documents_every_key_as_the_model_defines_it(reference, table, model):
    assert table in reference, (
        f"docs/reference/scene.md has no section '## `{table}`' for {model.__name__}; "
        "run `python tests/test_docs.py` for the generated tables")
    documented = doc_rows(reference[table])
    for key, want in rows(model).items():
        assert key in documented, f"scene.md [{table}]: key '{key}' is not documented"
        got = documented[key]
        assert len(got) == 6, f"scene.md [{table}] `{key}`: expected 6 cells, got {got}"
        names = ("key", "type", "default", "unit", "allowed")
        for i, name in enumerate(names):
            if name == "unit" and not want[3]:
                assert got[3], f"scene.md [{table}] `{key}`: give a unit (or '1', or '—')"
                continue
            assert got[i] == want[i], (
                f"scene.md [{table}] `{key}`: {name} is {got[i]!r}, the model says {want[i]!r}")
        assert got[5], f"scene.md [{table}] `{key}`: describe what it means"
    extra = set(documented) - set(rows(model))
    assert not extra, f"scene.md [{table}] documents keys the model does not have: {extra}"


# ---------------------------------------------------------------------------- TOML examples
BASE_TIME = '\n[time]\nduration = "1h"\ndt = 60\n'
BASE_ELEMENTS = "\n[[elements.polygon]]\nvertices = [[0, 80], [1, 80], [1, 81], [0, 81]]\n"


def toml_blocks() -> list[tuple[str, str]]:
    out = []
    for md in sorted(DOCS.rglob("*.md")):
        text = md.read_text(encoding="utf-8")
        for m in re.finditer(r"^```toml\s*\n(.*?)^```", text, re.MULTILINE | re.DOTALL):
            line = text[: m.start()].count("\n") + 1
            out.append((f"{md.relative_to(ROOT)}:{line}", m.group(1)))
    return out


def as_scene(block: str) -> str:
    """A complete scene: a fragment gets a [time] table (and one element if it has none)."""
    if re.search(r"^\[time\]", block, re.MULTILINE):
        return block
    text = block + BASE_TIME
    if not re.search(r"^\[\[?elements", block, re.MULTILINE):
        text += BASE_ELEMENTS
    return text


def test_docs_have_toml_examples():
    where = {w.split(":")[0] for w, _ in toml_blocks()}
    assert "docs/reference/scene.md" in where and "docs/howto/plugins.md" in where


def test_plugin_guide_shows_the_example_scene_as_shipped():
    scene = ROOT / "examples" / "siku_example_plugin" / "scenes" / "tilt_drift.toml"
    guide = (DOCS / "howto" / "plugins.md").read_text(encoding="utf-8")
    assert f"```toml\n{scene.read_text(encoding='utf-8')}```" in guide


def test_plugin_guide_code_matches_the_example_package():
    """The code excerpts of the guide are verbatim from the example package."""
    pkg = ROOT / "examples" / "siku_example_plugin"
    guide = (DOCS / "howto" / "plugins.md").read_text(encoding="utf-8")
    sources = "\n".join(p.read_text(encoding="utf-8") for p in sorted(pkg.rglob("*.py")))
    for m in re.finditer(r"^```python\s*\n(.*?)^```", guide, re.MULTILINE | re.DOTALL):
        for chunk in re.split(r"^\s*\.\.\.\s*$", m.group(1), flags=re.MULTILINE):
            chunk = chunk.strip("\n")
            if chunk and "make_scene(" not in chunk:
                assert chunk in sources, f"plugins.md excerpt not found in the example:\n{chunk}"


@pytest.mark.parametrize("where, block", toml_blocks(), ids=[w for w, _ in toml_blocks()])
def test_toml_examples_in_the_docs_parse(where, block):
    if re.search(r"^\[(project|tool|build-system)\b", block, re.MULTILINE):  # pyproject.toml
        tomllib.loads(block)
        return
    if re.search(r"^scene = ", block, re.MULTILINE):  # a sweep file (docs/howto/ensembles.md)
        from siku_io.ensemble.sweep import sweep_from_text

        sw = sweep_from_text(block, where, ROOT / "examples" / "sweeps")
        assert sw.members
        return
    scene_from_text(as_scene(block), where)


def _quickstart_scenes() -> list[str]:
    text = (DOCS / "quickstart.md").read_text(encoding="utf-8")
    return [b for b in re.findall(r"```toml\n(.*?)```", text, re.S) if "[time]" in b]


def test_the_quickstart_scenes_run_as_written():
    """The one-floe scene and the two-floe contact scene run with the quickstart's own dt (the
    contact scene's step is accepted by the stability check); the floes are about 10 km each
    way; the wind (10 m/s westerly) moves them east and the frozen pair moves as one."""
    from siku_core.geometry.quat import centers
    from siku_core.run.simulation import Simulation

    def lon(s):
        return np.degrees(np.arctan2(*centers(s.state.q)[:, 1::-1].T))

    one, two = _quickstart_scenes()
    sim = Simulation(scene_from_text(one, "quickstart one floe"), out=False, progress=False)
    assert np.sqrt(sim.state.area[0]) == pytest.approx(10e3, rel=0.01)
    sim2 = Simulation(scene_from_text(two, "quickstart two floes"), out=False, progress=False)
    assert sim2.dt == sim2.dt_requested == 2.0 and sim2.contacts.n_joints == 1
    for s in (sim, sim2):
        before = lon(s)
        s.run()
        assert np.all(lon(s) > before)  # moved east
    assert sim2.contacts.n_intact == 1
    V = sim2.state.V
    assert np.hypot(*(V[0] - V[1])) < 1e-3 * np.hypot(*V[0])


# ---------------------------------------------------------------------------- every block
ALL_BLOCKS = [b for page in doc_blocks.pages() for b in doc_blocks.blocks(page)]
RUN_PAGES = sorted({b.page for b in ALL_BLOCKS if b.runs})
#: how a stand-in for a file a reader made with a long command is made (in the test's folder)
STAND_INS = {
    # `siku run` (24 h, minutes): the same default scene, 20 minutes of it
    "siku_default.h5": ["siku", "run", "--set", "time.duration=20min", "--no-plots",
                        "--no-progress", "--out", "siku_default.h5"],
}


def test_every_block_of_every_page_runs_or_says_why_not():
    """Every fenced block of every page in docs/ has a language; a block that is neither run
    (bash, python, a scene saved with <!-- file: -->), parsed (toml) nor a listing (text) says
    why with <!-- not run: REASON -->."""
    assert len(doc_blocks.pages()) >= 15
    for b in ALL_BLOCKS:
        assert b.lang in ("bash", "python", "toml", "text"), (
            f"{b.where}: a block without a language (```bash, ```python, ```toml or ```text)")
        if "not run" in b.notes:
            assert len(b.notes["not run"]) > 15, f"{b.where}: say why the block is not run"
            assert b.lang in ("bash", "python"), f"{b.where}: 'not run' on a {b.lang} block"
        if b.runs and re.search(r"\bwget\b|\bcdsapi\b|\bcurl\b", b.code):
            assert "network" in b.notes, f"{b.where}: downloads: mark it <!-- network -->"
    assert {"docs/quickstart.md", "docs/howto/meshes.md", "docs/howto/results.md",
            "docs/howto/coupling.md", "docs/howto/forcing_data.md"} <= set(RUN_PAGES)


def test_blocks_say_what_they_need_from_the_page():
    """A block runs where its page says: a page whose blocks read a clone's files
    (``examples/``, ``tests/``) says, before the first such block, that they run from the root
    of a clone (elsewhere a page runs in an empty folder); a python block that uses a name of
    an earlier block says so just before it ("above")."""
    for page in doc_blocks.pages():
        text = page.read_text(encoding="utf-8")
        page_blocks = doc_blocks.blocks(page)
        clone = [b for b in page_blocks if doc_blocks.reads_clone(b)]
        if clone:
            head = "\n".join(text.split("\n")[: clone[0].line - 1])
            assert doc_blocks.runs_in_clone(head), (
                f"{clone[0].where}: reads a clone's files; say before it that the page's blocks "
                "run from the root of a clone of siku")
        for b in page_blocks:
            if b.lang == "python" and b.runs:
                names = doc_blocks.continued_names(b.code)
                if names:
                    assert "above" in doc_blocks.text_before(text, b), (
                        f"{b.where}: uses {', '.join(names)} of an earlier block; say so just "
                        "before it (e.g. 'for the mesh built above')")


def test_the_block_rules_can_fail():
    """The checks of the test above on made-up blocks: a name from elsewhere is found, one the
    block defines is not; a path into examples/ is a clone's, a file named like one is not."""
    assert doc_blocks.continued_names("import numpy as np\nx = np.ones(3)\nprint(mesh, x)\n"
                                      "def f(a):\n    return a + b\n") == ["b", "mesh"]
    blk = doc_blocks.Block("p.md", 3, "bash", "cd examples/coupling && ls\n")
    assert doc_blocks.reads_clone(blk)
    assert not doc_blocks.reads_clone(doc_blocks.Block("p.md", 3, "bash", "ls my_examples/\n"))
    assert doc_blocks.runs_in_clone("Run these from the root of a clone of siku.")
    page = "intro\n```python\nx = 1\n```\nfor x above:\n```python\nprint(x)\n```\n"
    second = [b for b in doc_blocks.FENCE.finditer(page)][1]
    b = doc_blocks.Block("p.md", page[: second.start()].count("\n") + 1, "python", "print(x)\n")
    assert doc_blocks.text_before(page, b).strip() == "for x above:"


@pytest.fixture(scope="session")
def stand_ins(tmp_path_factory) -> dict[str, Path]:
    made: dict[str, Path] = {}
    folder = tmp_path_factory.mktemp("stand_ins")

    def get(name: str) -> Path:
        if name not in made:
            subprocess.run(STAND_INS[name], cwd=folder, check=True, timeout=600,
                           capture_output=True)
            made[name] = folder / name
        return made[name]
    return get


@pytest.mark.parametrize("page", RUN_PAGES)
def test_page_runs_as_written(page, tmp_path, monkeypatch, stand_ins):
    """The page's blocks, in order, as a reader runs them: in a clean folder holding a copy of
    examples/ (nothing reaches the source tree), scenes saved where the page says, bash blocks
    through bash, python blocks in one namespace; downloads go to stand-ins."""
    import matplotlib

    matplotlib.use("Agg")
    doc_blocks.prepare(tmp_path, clone=doc_blocks.runs_in_clone(ROOT / page))
    bin_ = doc_blocks.network_stand_ins(tmp_path, sys.executable)
    env = {**os.environ, "MPLBACKEND": "Agg", "SIKU_NO_PROGRESS": "1",
           "PATH": os.pathsep.join([str(bin_), str(Path(sys.executable).parent),
                                    os.environ.get("PATH", "")])}
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(bin_))
    # the stand-in, not an installed cdsapi that another test (bmi-era5) imported already
    monkeypatch.delitem(sys.modules, "cdsapi", raising=False)
    before = _source_tree_state()
    scope: dict = {"__name__": "__docs__"}
    for b in (b for b in ALL_BLOCKS if b.page == page):
        for name in filter(None, re.split(r"[,\s]+", b.notes.get("stand-in", ""))):
            shutil.copy(stand_ins(name), tmp_path / name)
        if not b.runs:
            continue
        if "file" in b.notes:
            target = tmp_path / b.notes["file"]
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(b.code, encoding="utf-8")
        elif b.lang == "bash":
            r = subprocess.run(["bash", "-e", "-c", b.code], cwd=tmp_path, env=env,
                               capture_output=True, text=True, timeout=600)
            assert r.returncode == 0, f"{b.where}:\n{b.code}\n{r.stdout[-3000:]}{r.stderr[-3000:]}"
        else:
            exec(compile(b.code, b.where, "exec"), scope)
    assert _source_tree_state() == before, "a block wrote into the source tree"


def _cited_texts() -> dict[str, str]:
    texts = {p.relative_to(ROOT).as_posix(): p.read_text(encoding="utf-8")
             for p in [ROOT / "README.md", *doc_blocks.pages()]}
    from siku_core.run.cli import main

    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        main(["plugins"])
    texts["siku plugins"] = buf.getvalue()
    return texts


def test_sources_are_cited_by_author_and_year_and_listed_in_the_references():
    """No internal labels ("seed 004") and no uncited "the report": a page names the Siku
    report or Orzech et al. and links the references page, which lists both works in full."""
    refs = (DOCS / "reference" / "references.md").read_text(encoding="utf-8")
    assert "OCS Study BOEM 2017-043" in refs and "Kulchitsky, A., J. Hutchings, J. Johnson" in refs
    assert "10.1175/JTECH-D-17-0189.1" in refs and "Orzech, M. D." in refs
    for where, text in _cited_texts().items():
        assert not re.search(r"\bseeds?\s*0\d\d\b", text, re.I), f"{where}: an internal label"
        label = re.search(r".{0,40}\b(?:[Tt]he seed's|(?:of|in|[Tt]he) seed (?:prints|says|"
                          r"shows|gives|finds|paper|document)|Fig\. \d+ of the seed).{0,40}", text)
        assert not label, f"{where}: a source called 'the seed': {label.group(0)!r}"
        bare = re.search(r".{0,40}(?<!Siku )\b[Tt]he report\b.{0,40}", text)
        assert not bare, f"{where}: uncited 'the report': {bare.group(0)!r}"
        if where.endswith(".md") and where != "docs/reference/references.md" and \
                re.search(r"Siku report|Orzech|Kulchitsky", text):
            assert "references.md" in text, f"{where}: cites a work without linking References"


def test_the_output_reference_lists_every_diagnostic_with_its_unit():
    """docs/reference/output.md has a row `name` | `unit` | meaning for each diagnostic of
    siku's catalogue (the built-in components' included)."""
    from siku_core.diagnostics import catalogue

    page = (DOCS / "reference" / "output.md").read_text(encoding="utf-8")
    rows = dict(re.findall(r"^\| `(\w+)` \| `([^`]*)` \| .+\|$", page, re.MULTILINE))
    for name, (unit, _meaning) in catalogue().items():
        assert rows.get(name) == unit, f"output.md: diagnostic `{name}` [{unit}] not listed"


def _source_tree_state() -> set[str]:
    r = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                       capture_output=True, text=True)
    return set(r.stdout.splitlines()) if r.returncode == 0 else set()


if __name__ == "__main__":  # print the generated reference tables
    print(render())
