"""The element-source conformance suite: checks any element source
(``siku_core.interfaces.ElementSource``), built-in or third-party, must pass, found by its name
in the registry.

.. code-block:: python

    from siku_core.testing.element_source_checks import check_element_source

    def test_my_source_conforms():
        check_element_source("my_tiles", {"size": 500.0})

Each check builds a scene whose only elements are one ``[[elements.source]]`` table of the
source with ``params`` (nothing runs: no step is taken) and raises ``AssertionError`` saying what
failed:

* :func:`check_element_source_specs`: ``build`` returns a list of
  :class:`~siku_core.interfaces.ElementSpec`, at least one, each a finite polygon of at least 3
  vertices with latitudes in [-90, 90] deg, a known flag, a positive thickness, a finite
  velocity and spin, categories that are fractions in [0, 1] with positive thicknesses;
* :func:`check_element_source_reproducible`: the same scene builds the same elements, bit for
  bit (random choices come from the ``seed`` given), and building leaves the scene unchanged;
* :func:`check_element_source_engine`: the engine accepts every element (convex, not
  degenerate: positive finite area, mass and moment of inertia), in the source's order;
* :func:`check_element_source_bad_params`: an unknown parameter is refused in one line that
  names the scene table (``elements.source[0]``).

Cost: a few scene builds, well under a second for a source of some hundred elements (no
kernel is compiled).
"""
from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import SceneError
from ..interfaces import ElementSpec
from ..plugins import Registry, get_registry
from ..scene.scene_file import scene_from_text
from ..state import FLAG_NAMES
from .contact_cases import registry_with
from .scenes import toml_value

BASE = """title = "element source conformance"
[time]
dt = 1.0
duration = 1.0
[elements]
thickness = 1.0
"""


def source_scene_text(name: str, params: Mapping[str, Any] | None = None,
                      extra: str = "") -> str:
    """A scene whose only elements come from source ``name`` with ``params``."""
    table = f'[[elements.source]]\nname = "{name}"\n'
    if params:
        table += f"params = {toml_value(dict(params))}\n"
    return BASE + extra + table


def source_seed(scene: Any, src: Any) -> int:
    """The seed the engine gives ``src.build``: its ``seed`` parameter, or the scene's
    ``[run] seed`` when it has none (or a negative one)."""
    s = src.p.get("seed")
    return scene.cfg.run.seed if s is None or (isinstance(s, int) and s < 0) else int(s)


def _source_class(name: str, registry: Registry | None) -> type:
    return (registry or get_registry()).get("element_source", name)


def _scene(name: str, params: Mapping[str, Any] | None, extra: str = ""):
    return scene_from_text(source_scene_text(name, params, extra),
                           f"<element source conformance {name}>")


def _build(name: str, params: Mapping[str, Any] | None, registry: Registry | None,
           extra: str = "") -> tuple[list, Any]:
    from ..run.elements import scene_sources

    scene = _scene(name, params, extra)
    reg = registry or get_registry()
    (src, _table, where), = scene_sources(scene, reg)
    return src.build(scene, source_seed(scene, src), where), scene


def check_element_source_specs(name: str, params: Mapping[str, Any] | None = None,
                               registry: Registry | None = None) -> None:
    made, _scene_ = _build(name, params, registry)
    assert isinstance(made, list) and made, (
        f"element source '{name}': build returned {type(made).__name__} "
        f"{'(empty)' if not made else ''}, not a non-empty list of ElementSpec")
    for k, s in enumerate(made):
        what = f"element source '{name}': element {k} ({getattr(s, 'label', '')!r})"
        assert isinstance(s, ElementSpec), f"{what}: {type(s).__name__}, not an ElementSpec"
        ll = np.asarray(s.lonlat, dtype=float)
        assert ll.ndim == 2 and ll.shape[1] == 2 and ll.shape[0] >= 3, (
            f"{what}: vertices of shape {ll.shape}, not (k >= 3, 2) [lon, lat]")
        assert np.isfinite(ll).all(), f"{what}: vertices not finite"
        assert (np.abs(ll[:, 1]) <= 90.0).all(), f"{what}: a latitude outside [-90, 90] deg"
        assert s.flag is None or s.flag in FLAG_NAMES, f"{what}: unknown flag {s.flag!r}"
        assert s.thickness is None or (np.isfinite(s.thickness) and s.thickness > 0), (
            f"{what}: thickness {s.thickness!r} m")
        assert s.velocity is None or (len(s.velocity) == 2 and np.isfinite(s.velocity).all()), (
            f"{what}: velocity {s.velocity!r}")
        assert s.spin is None or np.isfinite(s.spin), f"{what}: spin {s.spin!r}"
        assert isinstance(s.floe, (int, np.integer)) and s.floe >= -1, f"{what}: floe {s.floe}"
        if s.categories is not None:
            a, h = (np.asarray(x, dtype=float) for x in s.categories)
            assert a.shape == h.shape and ((a >= 0) & (a <= 1)).all() and (h > 0).all(), (
                f"{what}: categories (a_k, h_k) not fractions and positive thicknesses")


def _flat(made: list) -> list:
    return [(np.asarray(s.lonlat, dtype=float).tobytes(), s.flag, s.velocity, s.spin,
             s.thickness, s.material, s.floe, s.label,
             None if s.categories is None else tuple(np.asarray(x).tobytes()
                                                     for x in s.categories)) for s in made]


def check_element_source_reproducible(name: str, params: Mapping[str, Any] | None = None,
                                      registry: Registry | None = None) -> None:
    from ..run.elements import scene_sources

    scene = _scene(name, params)
    reg = registry or get_registry()
    before = copy.deepcopy(scene.cfg.model_dump())
    (src, _t, where), = scene_sources(scene, reg)
    a = _flat(src.build(scene, source_seed(scene, src), where))
    assert scene.cfg.model_dump() == before, f"element source '{name}': build changed the scene"
    (src, _t, where), = scene_sources(scene, reg)
    b = _flat(src.build(scene, source_seed(scene, src), where))
    assert a == b, (f"element source '{name}': two builds of one scene differ (random choices "
                    "must come from the seed build is given)")


def check_element_source_engine(name: str, params: Mapping[str, Any] | None = None,
                                registry: Registry | None = None) -> None:
    from ..run.elements import build_elements

    made, scene = _build(name, params, registry)
    try:
        st = build_elements(scene, registry)
    except SceneError as exc:
        raise AssertionError(f"element source '{name}': the engine refuses its elements: "
                             f"{exc}") from None
    assert st.n == len(made), f"element source '{name}': {len(made)} built, {st.n} in the run"
    for k in ("area", "m", "I"):
        v = np.asarray(getattr(st, k))
        assert np.isfinite(v).all() and (v > 0).all(), (
            f"element source '{name}': element {int(np.argmin(v))} has {k} = {v.min()!r}")


def check_element_source_bad_params(name: str, params: Mapping[str, Any] | None = None,
                                    registry: Registry | None = None) -> None:
    bad = {**dict(params or {}), "no_such_parameter_of_this_source": 1}
    try:
        _build(name, bad, registry)
    except SceneError as exc:
        msg = str(exc)
        assert "\n" not in msg.strip() and "elements.source[0]" in msg, (
            f"element source '{name}': an unknown parameter is refused without naming the "
            f"table in one line: {msg!r}")
        return
    raise AssertionError(f"element source '{name}': an unknown parameter was accepted")


def check_element_source(name: str, params: Mapping[str, Any] | None = None,
                         registry: Registry | None = None) -> None:
    """Every check of the suite for the element source registered as ``name``."""
    check_element_source_specs(name, params, registry)
    check_element_source_reproducible(name, params, registry)
    check_element_source_engine(name, params, registry)
    check_element_source_bad_params(name, params, registry)


def source_registry(cls: type, registry: Registry | None = None) -> Registry:
    """A registry holding element source ``cls`` (under its ``name``) next to the components
    of ``registry`` (default: the process-wide one)."""
    return registry_with("element_source", cls, registry)


__all__ = ["check_element_source", "check_element_source_bad_params",
           "check_element_source_engine", "check_element_source_reproducible",
           "check_element_source_specs", "source_registry", "source_scene_text"]
