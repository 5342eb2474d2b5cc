"""The rooms of the packages (tools/rooms.py): the tree names every module at its new place,
every old place still imports with a warning naming the new one, and the rewrite of code written
against the old places gives the new places and changes nothing a second time."""
from __future__ import annotations

import importlib
import importlib.util
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _tool():
    spec = importlib.util.spec_from_file_location("rooms", ROOT / "tools" / "rooms.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


rooms = _tool()


def test_the_tree_names_no_module_at_its_old_place():
    """Code, tests, docs, examples and entry points use the new paths only (the rewrite finds
    nothing to change)."""
    assert rooms.rewrite(ROOT, write=False) == []


@pytest.mark.parametrize("old, new", sorted(rooms.MOVES.items()))
def test_an_old_module_path_imports_with_a_warning_naming_its_new_home(old, new):
    """A moved module's old path gives the new module (a module whose name is now a package,
    its names), with a DeprecationWarning naming the new home."""
    importlib.import_module(new)
    for name in [m for m in sys.modules if m == old]:
        if sys.modules[name].__name__ != name:
            del sys.modules[name]  # a shim that became its new module: run it again
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
        if module.__name__ == old:  # an alias of names: the package, or siku_core.contacts
            name = next(n for n, home in module.__getattr__.moves.items() if home == new)
            assert getattr(module, name) is getattr(sys.modules[new], name)
        else:
            assert module is sys.modules[new]
    assert any(issubclass(w.category, DeprecationWarning) and new in str(w.message)
               for w in rec), [str(w.message) for w in rec]


OLD = '''\
"""Uses :mod:`siku_core.contact_model` and ``siku_core/contact_loops.py``."""
from .contacts import joint_forces
from .errors import SceneError
from .scene import load_scene
from . import parallel
from siku_core import scene, simulation
from siku_forcing.waves import PlaneWaves
import siku_io.coupling.exchange as ex


def f():
    from .diagnostics import catalogue
    return "siku_forcing.gridded_reader", ex
'''

NEW = '''\
"""Uses :mod:`siku_core.contact.contact_model` and ``siku_core/contact/contact_loops.py``."""
from .contact_forces import joint_forces
from ..errors import SceneError
from ..scene.scene_file import load_scene
from .. import parallel
from siku_core.scene import scene_file as scene
from siku_core.run import simulation
from siku_forcing.waves.wave_field import PlaneWaves
import siku_forcing.gridded.exchange as ex


def f():
    from ..diagnostics import catalogue
    return "siku_forcing.gridded.gridded_reader", ex
'''


def test_the_rewrite_moves_old_code_to_the_new_places_once():
    """A module written at its old place (siku_core/contact_model.py) and merged into its new
    one: its relative imports are resolved against the old place, its absolute ones, module
    imports, dotted paths and file paths mapped; a second rewrite changes nothing."""
    rw = rooms.Rewriter(ROOT)
    where = Path("siku_core/contact/contact_model.py")
    assert rw.python(OLD, where) == NEW
    assert rw.python(NEW, where) == NEW
