"""Deprecation aliases: a name or a module that moved keeps importing from its old place, with a
:class:`DeprecationWarning` naming its new home.

The policy (``CHANGELOG.md``, ``docs/howto/plugins.md``): a name of the public surface
(``docs/reference/api.md``) that moves keeps working from its old place, with a warning, for at
least one minor release after the release that deprecates it (deprecated in 0.2.0: it works in
every 0.2.x and may go in 0.3.0 at the earliest). Every old place uses one of the two tools here:

* a module whose names moved ends with ``__getattr__ = moved_names(__name__, {...})`` (PEP 562:
  called only for names the module does not define, so what is still at home costs nothing);
* a module that moved leaves a shim at its old path, ``moved_module(__name__, "new.path")``,
  which makes the old name the new module itself (``import old`` and ``from old import x`` give
  the new module's objects).

A method whose signature changed warns through :func:`warn_deprecated` where the old form is
adapted (a contact law's ``joint_parameters(self, sim)``:
:class:`siku_core.contact_law.ContactLaw`).
"""
from __future__ import annotations

import importlib
import sys
import warnings
from collections.abc import Callable, Mapping
from types import ModuleType
from typing import Any

#: the release that deprecated the aliases made through this module, and the first release that
#: may remove them (one minor release later)
DEPRECATED_IN = "0.2.0"
REMOVAL_NOT_BEFORE = "0.3.0"


def warn_deprecated(what: str, instead: str, stacklevel: int = 2) -> None:
    """Warn that ``what`` is deprecated and say what to write ``instead``; ``stacklevel``
    counts from the caller of this function, as in :func:`warnings.warn`."""
    warnings.warn(_message(what, instead), DeprecationWarning, stacklevel=stacklevel + 1)


def _message(what: str, instead: str) -> str:
    return (f"{what} is deprecated: {instead} (deprecated in siku {DEPRECATED_IN}; it keeps "
            f"working, with this warning, until {REMOVAL_NOT_BEFORE} at the earliest)")


def warn_moved(old: str, new: str, stacklevel: int = 2) -> None:
    """Warn that ``old`` (a dotted path) is deprecated and lives at ``new`` now."""
    warn_deprecated(old, f"import it from its new home, {new}", stacklevel + 1)


def moved_names(module: str, moves: Mapping[str, str]) -> Callable[[str], Any]:
    """A module-level ``__getattr__`` (PEP 562) for the module named ``module``: each name of
    ``moves`` resolves to the object of that name in the module ``moves[name]`` (its new home),
    with a :class:`DeprecationWarning` naming the new home; any other name is an
    :class:`AttributeError`, as without it."""
    moves = dict(moves)

    def __getattr__(name: str) -> Any:
        home = moves.get(name)
        if home is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home), name)
        warn_moved(f"{module}.{name}", f"{home}.{name}", stacklevel=2)
        return value

    __getattr__.moves = moves  # what the module forwards, for the reference page and the tests
    return __getattr__


def moved_module(old: str, new: str) -> ModuleType:
    """Called by the shim left at a moved module's old path (``old``, the shim's ``__name__``):
    imports ``new``, warns that ``old`` is deprecated and puts the new module in its place in
    :data:`sys.modules`, so the import that ran the shim binds the new module itself."""
    module = importlib.import_module(new)
    # the importer: past the shim, the import machinery and any import hook's exec_module (a
    # hook's frame is not one warnings skips, so a fixed stacklevel would name the hook)
    frame = sys._getframe(1).f_back
    while frame is not None and (frame.f_code.co_name == "exec_module" or (
            "importlib" in frame.f_code.co_filename and "_bootstrap" in frame.f_code.co_filename)):
        frame = frame.f_back
    text = _message(old, f"import it from its new home, {new}")
    if frame is None:
        warnings.warn(text, DeprecationWarning, stacklevel=2)
    else:
        g = frame.f_globals
        warnings.warn_explicit(text, DeprecationWarning, frame.f_code.co_filename,
                               frame.f_lineno, module=g.get("__name__", "<string>"),
                               registry=g.setdefault("__warningregistry__", {}),
                               module_globals=g)
    sys.modules[old] = module
    return module
