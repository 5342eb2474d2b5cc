"""numba's cache of siku's own functions is keyed by siku's sources, not by where they lie
(siku_core.numba_cache): a second copy of the same sources reads the functions the first
compiled; an edit of any module starts a fresh folder; functions outside siku's packages and a
user's ``NUMBA_CACHE_DIR`` keep numba's own rules."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numba
from numba.core import caching

from siku_core import numba_cache
from siku_core.geometry.quat import qmatrix
from siku_core.contact.kernel_cache import user_cache_dir

ROOT = Path(__file__).resolve().parents[1]


@numba.njit(cache=True)
def _outside(x):  # a function outside siku's packages
    return x + 1.0


def test_the_locator_serves_siku_functions_only_and_yields_to_numba_cache_dir(monkeypatch):
    assert numba_cache.SourcesKeyedLocator in caching.CacheImpl._locator_classes
    loc = numba_cache.SourcesKeyedLocator.from_function(qmatrix.py_func, qmatrix.py_func.__code__
                                                        .co_filename)
    want = user_cache_dir("numba") / numba_cache.sources_key() / "siku_core" / "geometry"
    assert Path(loc.get_cache_path()) == want
    assert numba_cache.SourcesKeyedLocator.from_function(_outside.py_func, __file__) is None
    monkeypatch.setattr(numba.config, "CACHE_DIR", "/somewhere")
    assert numba_cache.SourcesKeyedLocator.from_function(
        qmatrix.py_func, qmatrix.py_func.__code__.co_filename) is None


def test_the_key_follows_the_text_of_every_module_not_the_folder(tmp_path):
    for where in ("a", "b"):
        (tmp_path / where / "pk" / "sub").mkdir(parents=True)
        (tmp_path / where / "pk" / "__init__.py").write_text("")
        (tmp_path / where / "pk" / "sub" / "m.py").write_text("X = 1\n")
    key = numba_cache.sources_key(tmp_path / "a", ("pk",))
    assert numba_cache.sources_key(tmp_path / "b", ("pk",)) == key
    (tmp_path / "b" / "pk" / "sub" / "m.py").write_text("X = 2\n")
    assert numba_cache.sources_key(tmp_path / "b", ("pk",)) != key


_PROBE = """
import json, numpy as np
from siku_core.geometry.quat import qmatrix
qmatrix(np.array([1.0, 0.0, 0.0, 0.0]))
s = qmatrix.stats
print(json.dumps([qmatrix.py_func.__code__.co_filename, sum(s.cache_hits.values()),
                  sum(s.cache_misses.values())]))
"""


def _probe(tree: Path, cache: Path) -> list:
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "SIKU_NUMBA_CACHE", "SIKU_CACHE_DIR")}
    env.update(PYTHONPATH=str(tree), XDG_CACHE_HOME=str(cache), SIKU_DISABLE_PLUGIN_AUTOLOAD="1")
    r = subprocess.run([sys.executable, "-c", _PROBE], env=env, cwd=tree, capture_output=True,
                       text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.splitlines()[-1])


def test_a_second_copy_of_the_sources_reads_what_the_first_compiled(tmp_path):
    """Two copies of siku's packages in two folders (a fresh clone beside an old one): the
    first compiles ``qmatrix`` and caches it, the second loads it, compiling nothing; neither
    writes into its tree."""
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc", "*.nc", "*.npz", "*.h5")
    for copy in ("one", "two"):
        for pkg in numba_cache.PACKAGES:
            shutil.copytree(ROOT / pkg, tmp_path / copy / pkg, ignore=ignore)
    cache = tmp_path / "cache"
    first = _probe(tmp_path / "one", cache)
    assert first[0].startswith(str(tmp_path / "one")) and first[2] == 1  # compiled
    second = _probe(tmp_path / "two", cache)
    assert second[0].startswith(str(tmp_path / "two")) and second[1] == 1 and not second[2]
    assert not list((tmp_path / "one").rglob("*.nbi"))
    assert list((cache / "siku" / "numba").glob("*/siku_core/geometry/quat.qmatrix-*.nbi"))


def test_the_tree_cache_is_kept_when_asked(monkeypatch):
    monkeypatch.setattr(caching.CacheImpl, "_locator_classes",
                        [c for c in caching.CacheImpl._locator_classes
                         if c is not numba_cache.SourcesKeyedLocator])
    monkeypatch.setenv("SIKU_NUMBA_CACHE", "tree")
    assert numba_cache.install() is False
    assert numba_cache.SourcesKeyedLocator not in caching.CacheImpl._locator_classes
