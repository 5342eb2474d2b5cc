"""The contact-law guide (docs/howto/contact_laws.md) is true: its layout tables are the ones the
engine defines, its code is the example package's, and the law it shows (its laws.py block, the
example package's file, with the page's own hook) installs, runs its scene with the predicted
breaks and passes the conformance suite."""
from __future__ import annotations

import re
import types
from pathlib import Path

import numpy as np
import pytest

from siku_core import contact_law as contacts
from siku_core.contact_law import BREAK_TENSION
from siku_core.plugins import register_module, unregister_module
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import check_contact_law

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "howto" / "contact_laws.md"
PKG = ROOT / "examples" / "siku_example_plugin"


def guide() -> str:
    return GUIDE.read_text(encoding="utf-8")


def blocks(lang: str) -> list[str]:
    return [m.group(1) for m in re.finditer(rf"^```{lang}\s*\n(.*?)^```", guide(),
                                            re.MULTILINE | re.DOTALL)]


def block_after(marker: str, lang: str) -> str:
    text = guide()
    i = text.index(marker)
    m = re.compile(rf"^```{lang}\s*\n(.*?)^```", re.MULTILINE | re.DOTALL).search(text, i)
    assert m is not None, f"no {lang} block after {marker!r}"
    return m.group(1)


@pytest.mark.parametrize("layout, size", [
    (contacts.COLLISION_LAYOUT, contacts.G_SIZE), (contacts.JOINT_LAYOUT, contacts.J_SIZE),
    (contacts.OUT_LAYOUT, 4),
])
def test_the_layout_tables_are_the_engines(layout, size):
    """Each named index constant is its row's position, every entry has a row, and the guide
    shows the table generated from the layout."""
    assert len(layout) == size
    for k, (name, unit, meaning) in enumerate(layout):
        if not name.startswith("out["):
            assert getattr(contacts, name) == k, name
        assert unit and meaning
    assert contacts.layout_table(layout) in guide()


def test_the_guide_shows_the_example_law_scene_and_tests_verbatim():
    laws = (PKG / "siku_example_plugin" / "laws.py").read_text(encoding="utf-8")
    assert block_after("The whole of\n`siku_example_plugin/laws.py`:", "python") == laws
    plugin = (PKG / "siku_example_plugin" / "plugin.py").read_text(encoding="utf-8")
    assert block_after("Its hook, in `siku_example_plugin/plugin.py`:", "python").strip() in plugin
    scene = (PKG / "scenes" / "brittle_pull.toml").read_text(encoding="utf-8")
    assert scene in blocks("toml")
    tests = (PKG / "tests" / "test_example_plugin.py").read_text(encoding="utf-8")
    shown = block_after("check the physics of the law against a number", "python")
    for chunk in shown.split("\n\n\n"):
        assert chunk.strip() in tests, chunk


@pytest.fixture
def law_from_the_guide(monkeypatch):
    """The guide's laws.py and hook, as a plugin module registered like an installed package
    (entry points off, so an installed copy of the example plugin does not collide). The
    guide's laws.py is the example package's file, checked here as in the test above; the law
    is imported from that file, so that its contact loop is the one the example's own tests
    compile (a copy under another module name would compile a loop of its own)."""
    monkeypatch.setenv("SIKU_DISABLE_PLUGIN_AUTOLOAD", "1")
    monkeypatch.syspath_prepend(str(PKG))
    import siku_example_plugin.laws as laws

    assert Path(laws.__file__).resolve() == (PKG / "siku_example_plugin" / "laws.py").resolve()
    assert block_after("The whole of\n`siku_example_plugin/laws.py`:", "python") == \
        Path(laws.__file__).read_text(encoding="utf-8")
    plugin = types.ModuleType("guide_brittle_plugin")
    code = ("from siku_core import hookimpl\nfrom siku_example_plugin.laws import BrittleBond\n\n"
            + block_after("Its hook, in `siku_example_plugin/plugin.py`:", "python"))
    exec(compile(code, "guide_brittle_plugin", "exec"), plugin.__dict__)
    register_module(plugin)
    yield laws.BrittleBond
    unregister_module(plugin)


def test_the_guides_law_runs_its_scene_with_the_predicted_breaks(law_from_the_guide):
    """The scene's comment: both bonds break in tension at t = 2 h sigma_t / (K v) = 80 s,
    within a time step."""
    scene = next(b for b in blocks("toml") if 'law = "brittle_bond"' in b)
    sim = Simulation(scene_from_text(scene, "contact_laws.md"), out=False, progress=False)
    assert type(sim.contacts.law) is law_from_the_guide
    cm = sim.contacts
    assert cm.n_joints == 2
    sim.run()
    expected = 2.0 * 1.0 * 2.0e5 / (cm.jK * 0.01)
    assert np.all(np.abs(cm.break_time - expected) <= sim.dt)
    assert np.all(np.abs(expected - 80.0) < 0.01)  # the number the guide quotes
    assert set(cm.break_mode) == {BREAK_TENSION}


# slow: the same check (check_contact_law on siku_example_plugin.laws.BrittleBond, the file the
# guide shows verbatim, with the same two parameter sets) is the example's own
# test_brittle_bond_conforms, which tests/test_plugins.py runs in the default suite
@pytest.mark.slow
def test_the_guides_law_passes_the_conformance_suite(law_from_the_guide):
    check_contact_law(law_from_the_guide)
    check_contact_law(law_from_the_guide, {"stiffness_scale": 2.0, "friction": 0.3,
                                           "joint_damping_ratio": 0.5})


def test_the_break_mode_tables_list_every_mode_of_the_code():
    """The guide's table and the output reference's list of `/breaks/mode` name every
    `BreakMode` with its value (flexure and melt were once missing)."""
    from siku_core.contact_law import BreakMode

    output = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "output.md").read_text(
        encoding="utf-8")
    modes = re.search(r"`/breaks/mode` \(([^)]*)\)", " ".join(output.split())).group(1)
    for mode in BreakMode:
        if mode:
            assert f"| `BREAK_{mode.name}` | {int(mode)} |" in guide(), mode.name
        assert f"{int(mode)} {mode.name.lower()}" in modes, mode.name
