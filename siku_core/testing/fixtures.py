"""pytest plugin for siku users and plugin authors.

Loaded automatically through the ``pytest11`` entry point of the ``siku`` distribution, so
every test suite in an environment where siku is installed has these fixtures:

``siku_scene_factory``
    ``factory(elements=..., forcing=..., ..., file=False) -> Scene``: the arguments of
    :func:`siku_core.testing.scene_text`; with ``file=True`` (or a file name) the scene is written
    under ``tmp_path`` and loaded from there, so error messages name a real file.
``siku_simulation_factory``
    ``factory(scene=None, **scene_kwargs) -> Simulation`` with ``out=False, progress=False``;
    ``scene`` may be a Scene, a path, TOML text, or ``None`` to build one from ``scene_kwargs``.
``siku_module_simulation_factory``
    the same factory at module scope, so that a long run is shared by the tests of a module::

        @pytest.fixture(scope="module")
        def drifted(siku_module_simulation_factory):
            return siku_module_simulation_factory(elements=[(-150.0, 75.0)], duration=6 * 3600,
                                                  dt=600.0).run()

``siku_register``
    ``register(module)``: registers a plugin module (as an installed package would) for the
    duration of the test; the registry is rebuilt without it afterwards.
``siku_fake_install``
    ``install(name, version, entry_points, modules=..., paths=...) -> Registry``: makes a plugin
    package look installed (a ``.dist-info`` folder on ``sys.path``, see
    :func:`siku_core.testing.write_dist_info`) and rebuilds the registry, so the real
    entry-point path is exercised without ``pip``; everything is undone after the test.
``siku_dask_scheduler``
    the address of a local Dask cluster of two single-threaded worker processes, started once
    per test session, for ensemble runs on a Dask scheduler (``scheduler=...``).
"""
from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest

from .dists import write_dist_info
from .scenes import scene_text


def _scene_factory(folder: Callable[[], Path]) -> Callable[..., Any]:
    from ..scene.scene_file import load_scene, scene_from_text

    def factory(*args: Any, file: bool | str = False, **kwargs: Any):
        text = scene_text(*args, **kwargs)
        if file:
            path = folder() / (file if isinstance(file, str) else "scene.toml")
            path.write_text(text, encoding="utf-8")
            return load_scene(path)
        return scene_from_text(text, "<test scene>")

    return factory


def _simulation_factory(scenes: Callable[..., Any]) -> Callable[..., Any]:
    from ..scene.scene_file import Scene, load_scene, scene_from_text
    from ..run.simulation import Simulation

    def factory(scene: Any = None, **kwargs: Any):
        sim_kw = {k: kwargs.pop(k) for k in ("restart", "registry") if k in kwargs}
        if scene is None:
            scene = scenes(**kwargs)
        elif isinstance(scene, str) and "\n" in scene:
            scene = scene_from_text(scene, "<test scene>")
        elif not isinstance(scene, Scene):
            scene = load_scene(scene)
        return Simulation(scene, out=False, progress=False, **sim_kw)

    return factory


@pytest.fixture
def siku_scene_factory(tmp_path: Path) -> Callable[..., Any]:
    """Build small scenes (square elements, given forcing) from Python."""
    return _scene_factory(lambda: tmp_path)


@pytest.fixture
def siku_simulation_factory(siku_scene_factory: Callable[..., Any]) -> Callable[..., Any]:
    """Build a :class:`~siku_core.run.simulation.Simulation` that writes nothing and shows no
    bar."""
    return _simulation_factory(siku_scene_factory)


@pytest.fixture(scope="module")
def siku_module_simulation_factory(tmp_path_factory: pytest.TempPathFactory
                                   ) -> Callable[..., Any]:
    """:func:`siku_simulation_factory` for a module-scoped fixture: one run shared by every test
    of a module (scenes written with ``file=...`` go to a folder of the module)."""
    folder: list[Path] = []

    def where() -> Path:
        if not folder:
            folder.append(tmp_path_factory.mktemp("siku_module"))
        return folder[0]

    return _simulation_factory(_scene_factory(where))


@pytest.fixture
def siku_register() -> Iterator[Callable[[Any], Any]]:
    """Register plugin modules for one test; the registry is rebuilt without them afterwards."""
    from ..plugins import register_module, unregister_module

    added: list[Any] = []

    def register(module: Any):
        added.append(module)
        return register_module(module)

    yield register
    for mod in reversed(added):
        unregister_module(mod)


@pytest.fixture
def siku_fake_install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable]:
    """Install plugin packages for one test, without pip, through real entry points."""
    from ..plugins import get_registry

    tops: list[str] = []
    count = [0]

    def install(
        name: str,
        version: str,
        entry_points: Mapping[str, str],
        *,
        modules: Mapping[str, str] | None = None,
        paths: Iterable[str | Path] = (),
        top_level: Iterable[str] | None = None,
    ):
        """``modules``: ``{module name: source}`` written next to the ``.dist-info``;
        ``paths``: folders holding the package (also put on ``sys.path``)."""
        count[0] += 1
        site = tmp_path / f"site{count[0]}"  # a fresh folder: metadata caches key on folders
        site.mkdir()
        for mod, source in (modules or {}).items():
            (site / f"{mod}.py").write_text(source, encoding="utf-8")
        top = list(top_level) if top_level is not None else sorted(
            {v.split(":")[0].split(".")[0] for v in entry_points.values()})
        tops.extend(top)
        write_dist_info(site, name, version, entry_points, top)
        from ..plugins import canonical_dist, skipped_distributions

        if canonical_dist(name) in skipped_distributions():  # installed for this test: load it
            keep = sorted(skipped_distributions() - {canonical_dist(name)})
            monkeypatch.setenv("SIKU_SKIP_PLUGINS", ",".join(keep))
        for p in (*paths, site):
            monkeypatch.syspath_prepend(str(p))
        return get_registry(refresh=True)

    yield install
    monkeypatch.undo()
    for mod in list(sys.modules):
        if mod.split(".")[0] in tops:
            del sys.modules[mod]
    get_registry(refresh=True)


@pytest.fixture(scope="session")
def siku_dask_scheduler() -> Iterator[str]:
    """Address of a local Dask cluster (two worker processes, one task and one numba thread
    each), shared by the session's ensemble tests."""
    import logging

    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        silence_logs=logging.ERROR, env={"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
    try:
        yield cluster.scheduler_address
    finally:
        cluster.close()
