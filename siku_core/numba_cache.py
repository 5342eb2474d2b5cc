"""Numba's on-disk cache of siku's own compiled functions, keyed by siku's sources.

numba caches a ``cache=True`` function beside its module (``__pycache__``) or, with
``NUMBA_CACHE_DIR``, in a folder named after the module's directory: a fresh clone or a second
checkout of the same sources compiles everything again, and a cache written before an edit of
a module that a function *calls* is read after it (numba checks only the function's own file).
Here the functions of siku's packages (``siku_core`` and the ``siku_*`` packages beside it) are
cached instead in ``$XDG_CACHE_HOME/siku/numba/<key>/<package path>`` (see
:func:`siku_core.contact.kernel_cache.user_cache_dir`), where ``key`` is a hash of the text of every
module of those packages: the same sources, wherever they lie, read the same compiled code;
any edit of any of them starts a fresh folder, so no compiled function outlives a change of a
function it calls. (The contact loops generated for a law's evaluator are cached by
:mod:`siku_core.contact.kernel_cache` with a key of the same kind.) Everything else numba caches
(plugins outside siku, the user's own functions) is cached as numba does by default.

``NUMBA_CACHE_DIR`` (or numba's ``NUMBA_CACHE_LOCATOR_CLASSES``), when set, is obeyed for siku's
functions too; ``SIKU_NUMBA_CACHE=tree`` keeps numba's default (beside the modules). The
folders are safe to delete; one is added per edited state of the sources.
"""
from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

from numba.core import caching, config

from .contact.kernel_cache import user_cache_dir

#: the folder holding the packages (an install's ``site-packages``, a source tree's root)
ROOT = Path(__file__).resolve().parents[1]
#: the packages whose compiled functions are cached by the hash of their sources: the engine
#: and siku's packages beside it (``siku_*`` folders with an ``__init__.py``)
PACKAGES = tuple(sorted(p.name for p in ROOT.glob("siku_*") if (p / "__init__.py").is_file()))
#: the sources' hash, computed at the first compiled function that asks for it
_KEY: list[str] = []


def sources_key(root: Path = ROOT, packages: tuple[str, ...] = PACKAGES) -> str:
    """A hash of the path (relative to ``root``) and text of every ``.py`` module of
    ``packages`` under ``root``."""
    h = hashlib.sha1()
    for pkg in packages:
        for path in sorted((root / pkg).rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode() + b"\0")
            h.update(path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=None)
def _file_hash(path: str, mtime_ns: int, size: int) -> str:
    """The hash of the text of ``path`` (memoised while its time and size stay)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _relative(py_file: str) -> Path | None:
    """``py_file``'s path relative to :data:`ROOT` where it is a module of :data:`PACKAGES`."""
    try:
        rel = Path(py_file).resolve().relative_to(ROOT)
    except (OSError, ValueError):
        return None
    return rel if rel.parts and rel.parts[0] in PACKAGES else None


class SourcesKeyedLocator(caching.UserProvidedCacheLocator):
    """numba's cache locator for the functions of siku's packages: the folder
    ``user_cache_dir("numba") / key / <the module's folder relative to the packages' root>``.
    The index of each function is checked against a hash of its file's text (not the file's
    time, which a fresh clone changes)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        if not _KEY:
            _KEY.append(sources_key())
        rel = _relative(py_file)
        self._cache_path = str(user_cache_dir("numba") / _KEY[0] / rel.parent)

    def get_source_stamp(self):
        st = os.stat(self._py_file)
        return _file_hash(self._py_file, st.st_mtime_ns, st.st_size)

    @classmethod
    def from_function(cls, py_func, py_file):
        if config.CACHE_DIR or _relative(py_file) is None:
            return None
        # numba's file-backed locators make the instance and check that the folder is writable
        return super(caching.UserProvidedCacheLocator, cls).from_function(py_func, py_file)


def install() -> bool:
    """Put :class:`SourcesKeyedLocator` first among numba's locators (once); ``False`` where
    the user chose otherwise (``SIKU_NUMBA_CACHE=tree``, ``NUMBA_CACHE_LOCATOR_CLASSES``) or
    this numba keeps its locators elsewhere."""
    if os.environ.get("SIKU_NUMBA_CACHE", "").lower() == "tree":
        return False
    if getattr(config, "CACHE_LOCATOR_CLASSES", None):
        return False
    classes = getattr(caching.CacheImpl, "_locator_classes", None)
    if not isinstance(classes, list):
        return False
    if SourcesKeyedLocator not in classes:
        classes.insert(0, SourcesKeyedLocator)
    return True
