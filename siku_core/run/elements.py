"""Build the element state of a scene from its element sources.

Every element comes from an element source (a plugin kind, :class:`~siku_core.interfaces.
ElementSource`): the ``[[elements.polygon]]``, ``[[elements.pack]]`` and ``[elements.mesh]``
tables feed the built-in ``polygon``, ``pack`` and ``mesh`` sources, and each
``[[elements.source]]`` table names any registered source. The engine knows only the interface;
the sources live in the packages that own them and register through the hooks.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import ValidationError

from ..categories import Categories, categories_of, ice_per_area
from ..errors import SceneError
from ..geometry.batch import elements_from_lonlat
from ..geometry.quat import east_north_local
from ..interfaces import ElementSpec
from ..params import format_validation_error, validate_params
from ..scene.scene_file import Scene
from ..state import FLAG_NAMES, STATIC, ElementState

if TYPE_CHECKING:  # pragma: no cover
    from ..plugins import Registry

_COMMON = ("flag", "velocity", "spin", "thickness", "material")


def scene_sources(scene: Scene, registry: "Registry | None" = None) -> list[tuple[Any, Any, str]]:
    """``(source, table, where)`` for every element source of the scene, in build order:
    polygons, packs, the mesh, then ``[[elements.source]]`` tables in file order."""
    from ..plugins import get_registry

    reg = registry or get_registry()
    el = scene.cfg.elements
    out = []
    builtin = [("polygon", t, f"elements.polygon[{k}]") for k, t in enumerate(el.polygon)]
    builtin += [("pack", t, f"elements.pack[{k}]") for k, t in enumerate(el.pack)]
    if el.mesh is not None:
        builtin.append(("mesh", el.mesh, "elements.mesh"))
    for name, table, key in builtin:
        where = scene.where(key)
        cls = reg.get("element_source", name, where=f"{where}: ")
        out.append((cls(table.model_dump()), table, where))
    for k, table in enumerate(el.source):
        key = f"elements.source[{k}]"
        where = scene.where(key)
        cls = reg.get("element_source", table.name, where=f"{where}: ")
        pwhere = scene.where(key + ".params")
        model = cls.table_model
        if model is not None:  # a source whose keys are a scene table's ([[elements.pack]])
            try:
                full = model.model_validate(table.params).model_dump()
            except ValidationError as err:
                raise SceneError(format_validation_error(err, f"{pwhere} ({table.name})")) \
                    from None
        else:
            full = validate_params(table.name, cls.params, table.params, pwhere)
        out.append((cls(full), table, where))
    return out


def _seed(scene: Scene, src: Any) -> int:
    s = src.p.get("seed")
    return scene.cfg.run.seed if s is None or (isinstance(s, int) and s < 0) else int(s)


def collect_specs(scene: Scene, registry: "Registry | None" = None) -> list[ElementSpec]:
    """Every element of the scene as an :class:`ElementSpec`, defaults filled in."""
    el = scene.cfg.elements
    specs: list[ElementSpec] = []
    floes = 0
    for src, table, where in scene_sources(scene, registry):
        made = src.build(scene, _seed(scene, src), where)
        base = floes
        top = -1
        for s in made:
            for key in _COMMON:
                if getattr(s, key) is None:
                    setattr(s, key, getattr(table, key, None))
            if s.thickness is None:
                s.thickness = el.thickness
            if s.material is None:
                s.material = el.material
            if s.velocity is None:
                s.velocity = (0.0, 0.0)
            s.flag = s.flag or "free"
            s.spin = 0.0 if s.spin is None else s.spin
            s.label = f"{where} {s.label}".rstrip()
            if s.floe >= 0:  # a source numbers its floes from 0: make them unique in the scene
                top = max(top, s.floe)
                s.floe += base
            specs.append(s)
        floes = base + top + 1
        mats = scene.cfg.materials
        for s in made:
            if s.material not in mats:
                raise SceneError(f"{s.label}: unknown material '{s.material}'; defined: "
                                 f"{', '.join(sorted(mats))}")
            if s.flag not in FLAG_NAMES:
                raise SceneError(f"{s.label}: unknown flag '{s.flag}'; one of "
                                 f"{', '.join(FLAG_NAMES)}")
    return specs


def build_elements(scene: Scene, registry: "Registry | None" = None) -> ElementState:
    """The element state of a scene, in the order of :func:`scene_sources`."""
    return build_elements_and_categories(scene, registry)[0]


def build_elements_and_categories(scene: Scene, registry: "Registry | None" = None
                                  ) -> tuple[ElementState, Categories | None]:
    """The element state of a scene and its thickness categories (``None`` without:
    :mod:`siku_core.categories`); an element with categories has their mean thickness."""
    cfg = scene.cfg
    R = cfg.planet.radius
    mats = list(cfg.materials)
    specs = collect_specs(scene, registry)
    n = len(specs)
    q = np.empty((n, 4))
    V = np.zeros((n, 2))
    w = np.zeros(n)
    area = np.empty(n)
    J = np.empty(n)
    thick = np.empty(n)
    radius = np.empty(n)
    flags = np.empty(n, dtype=np.int8)
    material = np.empty(n, dtype=np.int32)
    floe = np.empty(n, dtype=np.int64)
    polys = []
    built = elements_from_lonlat([s.lonlat for s in specs], R, [s.label for s in specs])
    for i, s in enumerate(specs):
        qi, loc, a, j = built[i]
        q[i] = qi
        ex, ey, nx_, ny_ = east_north_local(qi)
        vel = s.velocity
        V[i, 0] = vel[0] * ex + vel[1] * nx_
        V[i, 1] = vel[0] * ey + vel[1] * ny_
        w[i] = s.spin
        area[i] = a
        J[i] = j
        thick[i] = s.thickness
        radius[i] = np.sqrt((loc**2).sum(axis=1)).max()
        flags[i] = FLAG_NAMES[s.flag]
        material[i] = mats.index(s.material)
        floe[i] = s.floe
        polys.append(loc)
    cats = categories_of([s.categories for s in specs], thick, [s.label for s in specs])
    rho = np.array([cfg.materials[mats[k]].density for k in material]) if n else np.zeros(0)
    v = ice_per_area(thick, cats)  # ice volume per area [m]: mass counts the concentration
    m = rho * v * area
    inertia = rho * v * J
    static = flags == STATIC
    V[static] = 0.0
    w[static] = 0.0
    offsets = np.zeros(n + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([len(p) for p in polys])
    verts = np.concatenate(polys) if polys else np.zeros((0, 2))
    return ElementState(
        q=q, V=V, w=w, m=m, I=inertia, area=area, thickness=thick, radius=radius, flags=flags,
        material=material, vert_offsets=offsets, verts=verts, floe=floe,
    ), cats
