"""Cacheable specialisations of the engine's contact loops for one evaluator.

The engine writes each loop over contacts once (:mod:`siku_core.contacts`) and a contact law
supplies the evaluator of one contact. Numba cannot cache a function that receives another
jitted function as an argument, so every process would recompile the loops (seconds per law).
:func:`specialise` instead writes, once, a small module in the user's cache directory in which
the evaluator is a global and the loop's source is the engine's template; numba then caches it
like any other function. The file name carries a hash of the template, the evaluator's module
source, the sources of the template's module and of the ``siku_core`` modules whose compiled
functions it calls, and the siku version, so editing any of them produces a fresh module.

The evaluator itself is recompiled there too, from its own source, without numba's reference
counting where it allows that (:func:`_nrt_free`): a call then costs what its arithmetic costs.

The loop's chunk functions (the serial bodies the parallel loops call) are compiled without
reference counting too when the evaluator is (their views and calls then cost nothing extra);
an evaluator that allocates (``np.zeros``, array expressions) needs numba's reference counting,
so its loop keeps it: the evaluator works unchanged and its contacts cost more (measured in
``docs/howto/contact_laws.md``).

``SIKU_KERNEL_CACHE`` sets the directory (default ``$XDG_CACHE_HOME/siku/kernels`` or
``~/.cache/siku/kernels``); ``SIKU_KERNEL_CACHE=off`` writes the generated modules to a
temporary directory of the process instead (nothing is kept, every process compiles again).
Where a directory cannot be written, the temporary one is used as well.
"""
from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import re
import atexit
import shutil
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba

from . import __version__

_MEMO: dict[tuple, Callable] = {}


_TEMP: list[Path] = []


def cache_dir() -> Path | None:
    """The kernel cache directory; ``None`` when ``SIKU_KERNEL_CACHE=off``."""
    env = os.environ.get("SIKU_KERNEL_CACHE", "")
    if env.lower() in ("off", "0", "no", "false"):
        return None
    if env:
        return Path(env)
    return user_cache_dir("kernels")


def user_cache_dir(what: str) -> Path:
    """Folder ``what`` of siku's per-user cache: ``$SIKU_CACHE_DIR/what``, by default
    ``$XDG_CACHE_HOME/siku/what`` or ``~/.cache/siku/what`` (kernels, meshes of shipped
    scenes). Never a folder of the installed package."""
    base = os.environ.get("SIKU_CACHE_DIR")
    if base:
        return Path(base) / what
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "siku" / what


def temporary_dir() -> Path:
    """A directory for this process's generated modules, removed when it exits."""
    if not _TEMP:
        _TEMP.append(Path(tempfile.mkdtemp(prefix="siku-kernels-")))
        atexit.register(shutil.rmtree, _TEMP[0], True)
    return _TEMP[0]


def _source_hash(*texts: str) -> str:
    h = hashlib.sha1()
    for t in texts:
        h.update(t.encode())
    return h.hexdigest()[:12]


def _dependencies(template: Any) -> list[str]:
    """The template's module and the ``siku_core`` modules it imports compiled code from (the
    numba geometry kernels), whose source the cache key must include."""
    mod = sys.modules[template.py_func.__module__]
    out = {mod.__name__}
    for v in vars(mod).values():
        m = getattr(getattr(v, "py_func", None), "__module__", None)
        if m and m.startswith("siku_core"):
            out.add(m)
    return sorted(out)


def _njit_opts(fn: Any, nrt: bool = True) -> str:
    opts = ["cache=True"]
    if fn.targetoptions.get("parallel"):
        opts.append("parallel=True")
    if not nrt:
        opts.append("_nrt=False")
    return ", ".join(opts)


def _load(where: Path, name: str, text: str) -> Any:
    """Write ``text`` to ``where/name.py`` (once, atomically) and import it as ``name``."""
    path = where / f"{name}.py"
    where.mkdir(parents=True, exist_ok=True)
    if not path.exists():
        fd, tmp = tempfile.mkstemp(dir=where, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    sys.modules[name] = module
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def _nrt_free(evaluator: Any, esrc: str, where: Path) -> str | None:
    """Name of a generated module holding ``evaluator`` compiled without numba's reference
    counting (``_nrt=False``), or ``None`` where that cannot be done.

    An evaluator receives its arrays from the loop and returns nothing, so it needs no
    reference counting unless it allocates; with it, each call costs a pair of atomic
    operations per array argument, which numba's pruning leaves in place in a function with
    more than one way out (about half the cost of a typical joint evaluation). The copy is the
    evaluator's own source, run among its module's globals, and is compiled here for the
    loop's argument types (1-D C-contiguous float64 arrays); an evaluator that allocates (or
    whose source cannot be read) is used as it is.
    """
    try:
        src = inspect.getsource(evaluator.py_func)
    except (OSError, TypeError):
        return None
    body, n = re.subn(r"^@njit[^\n]*\n", "", src, count=1, flags=re.MULTILINE)
    fname = evaluator.__name__
    if n != 1 or body.lstrip().startswith("@") or not re.match(rf"def {fname}\(", body):
        return None
    emod = evaluator.py_func.__module__
    text = (
        "# Generated by siku (siku_core.kernel_cache): a contact law's evaluator compiled\n"
        "# without reference counting. Safe to delete.\n"
        "from numba import njit\n\n"
        f"import {emod} as _law\n"
        "globals().update({k: v for k, v in vars(_law).items() if not k.startswith('__')})\n\n\n"
        "@njit(cache=True, _nrt=False)\n" + body
    )
    name = f"siku_eval_{fname}_{_source_hash(text, esrc, __version__)}"
    try:
        module = _load(where, name, text)
        disp = getattr(module, fname)
        nargs = evaluator.py_func.__code__.co_argcount
        disp.compile((numba.types.float64[::1],) * nargs)
    except Exception:  # noqa: BLE001 - any failure: use the evaluator as it is
        sys.modules.pop(name, None)
        return None
    return name


def _without_evaluate(fn: Any, names: list[str], nrt: bool = True) -> str | None:
    """Source of the ``@njit`` function ``fn`` with its leading ``evaluate`` parameter removed,
    and ``evaluate`` dropped from its calls of the functions ``names``, compiled with numba's
    reference counting or without (``nrt``); ``None`` if the source is not what the module
    says (e.g. the file changed since it was imported)."""
    src = inspect.getsource(fn.py_func)
    body = re.sub(r"^@njit[^\n]*\n", "", src, flags=re.MULTILINE)
    body, n = re.subn(rf"^def {fn.__name__}\(evaluate,\s*", f"def {fn.__name__}(", body,
                      count=1, flags=re.MULTILINE)
    if n != 1:
        return None
    for name in names:
        body = re.sub(rf"\b{name}\(evaluate,\s*", f"{name}(", body)
    return f"@njit({_njit_opts(fn, nrt)})\n" + body


def specialise(template: Any, evaluator: Any, helpers: tuple = ()) -> Callable | None:
    """The loop ``template`` (an ``@njit`` function whose first parameter is ``evaluate``)
    compiled with ``evaluator`` fixed, cached on disk; ``None`` if that cannot be done (then the
    caller uses the generic loop). ``helpers``: ``@njit`` functions the template calls with
    ``evaluate`` as their first argument, specialised alongside it (so that a parallel loop can
    stay small and call a serially compiled body); they are compiled without reference counting
    when the evaluator can be, with it otherwise (an evaluator that allocates)."""
    key = (template.py_func.__module__, template.__name__, evaluator.py_func.__module__,
           evaluator.__name__, tuple(h.__name__ for h in helpers))
    if key in _MEMO:
        return _MEMO[key]
    where = cache_dir()
    if where is None:
        where = temporary_dir()
    try:
        where.mkdir(parents=True, exist_ok=True)
        if not os.access(where, os.W_OK):
            raise PermissionError(where)
    except OSError:
        where = temporary_dir()
    names = [h.__name__ for h in helpers]
    try:
        esrc = inspect.getsource(sys.modules[evaluator.py_func.__module__])
        # numba's cache does not see changes in the functions a loop calls: hash them too
        dsrc = "".join(inspect.getsource(sys.modules[m]) for m in _dependencies(template))
    except (OSError, TypeError, KeyError):
        return None
    tmod = template.py_func.__module__
    emod = evaluator.py_func.__module__
    try:
        free = _nrt_free(evaluator, esrc, where)
    except OSError:
        return None
    if free is not None:
        emod = free
    try:
        parts = [_without_evaluate(h, names, nrt=free is None) for h in helpers]
        main = _without_evaluate(template, names)
    except (OSError, TypeError):
        return None
    if main is None or any(p is None for p in parts):
        return None
    main = main.replace(f"def {template.__name__}(", "def loop(", 1)
    text = (
        "# Generated by siku (siku_core.kernel_cache): a contact loop specialised for one\n"
        "# evaluator. Safe to delete.\n"
        "import math\n\nimport numpy as np\nfrom numba import njit, prange\n\n"
        f"import {tmod} as _template\n"
        "globals().update({k: v for k, v in vars(_template).items()\n"
        "                  if not k.startswith('__') and k not in ('loop', 'evaluate')})\n"
        f"from {emod} import {evaluator.__name__} as evaluate  # noqa: E402\n\n\n"
        + "\n\n".join([*parts, main])
    )
    digest = _source_hash(text, esrc, dsrc, __version__)
    name = f"siku_{template.__name__.strip('_')}_{evaluator.__name__}_{digest}"
    try:
        module = _load(where, name, text)
    except OSError:
        return None
    _MEMO[key] = module.loop
    return module.loop
