"""The catalogue of per-element fields: one value per element, with its name, units, meaning
and CF standard name, for every field the engine or a component writes.

The engine's own fields are declared here (:data:`ENGINE_FIELDS`): ``speed`` [m/s] of every
run; ``damage`` [1] and the mean stress ``stress_ee``, ``stress_nn``, ``stress_en`` [N/m] of a
run with contacts; the changing ``thickness`` [m], ``mass`` [kg] and ``flags`` of a run with
processes; the thickness categories ``category_fraction`` [1] and ``category_thickness`` [m]
(element x category). The centroid's position and velocity that every file carries per element
and snapshot (``lon``, ``lat``, ``u``, ``v``, ``spin``) are :data:`STATE_FIELDS`. A component
declares the fields it owns with the same record, :class:`ElementField`, in its
``owned_fields`` (and ``optional_fields``, those a parameter switches on).

Everything that names a per-element field reads it from here: the writers' ``units``,
``long_name`` and ``standard_name`` attributes (HDF5, Zarr, NetCDF, the run held in memory),
the CF conversion, the restart (which fields it carries: :attr:`ElementField.restart`), ``siku
plugins`` and the colour bar of a map (``siku plot``, :func:`catalogue` with the registered
components' declarations), so that no field is written or drawn without units.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from .errors import PluginError

#: how a grid reduces a declared field over the elements in a cell: ``mean`` (weighted by the
#: ice area in the cell: intensive quantities, e.g. a temperature), ``sum`` (weighted by the
#: share of each element in the cell: extensive quantities, e.g. a volume), ``none`` (not
#: gridded)
GRID_REDUCTIONS = ("mean", "sum", "none")

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class ElementField:
    """A per-element field: one of the engine's (:data:`ENGINE_FIELDS`) or one a component
    owns (``owned_fields``).

    ``name`` (a Python identifier, unique in a run), ``units`` (a UDUNITS string, ``"1"`` for
    none), ``long_name`` (what it is, for files and plots), ``dtype`` (numpy dtype name,
    ``float64`` by default), ``initial`` (value of every element at the start), ``grid`` (one of
    :data:`GRID_REDUCTIONS`), an optional CF ``standard_name``, and ``restart``: whether a
    restart carries it (a component's fields always are; of the engine's, those that are not
    computed from the state).
    """

    name: str
    units: str
    long_name: str
    dtype: str = "float64"
    initial: float = 0.0
    grid: str = "mean"
    standard_name: str = ""
    restart: bool = True

    def check(self, owner: str) -> None:
        """Refuse a declaration that cannot be written (:class:`PluginError`, one line)."""
        what = f"{owner}: declared field {self.name!r}"
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise PluginError(f"{what}: the name must be an identifier (letters, digits, _)")
        if self.name in RESERVED_FIELDS:
            raise PluginError(f"{what}: the name is siku's own; choose another")
        if not isinstance(self.units, str) or not self.units:
            raise PluginError(f"{what}: give its units (a UDUNITS string, '1' for none)")
        if not isinstance(self.long_name, str) or not self.long_name:
            raise PluginError(f"{what}: give a long_name saying what it is")
        if self.grid not in GRID_REDUCTIONS:
            raise PluginError(f"{what}: grid = {self.grid!r}; one of "
                              f"{', '.join(GRID_REDUCTIONS)}")
        try:
            dt = np.dtype(self.dtype)
        except TypeError:
            raise PluginError(f"{what}: unknown dtype {self.dtype!r}") from None
        if dt.kind not in "fiub":
            raise PluginError(f"{what}: dtype {self.dtype!r} is not numeric")


def _by_name(*fields: ElementField) -> dict[str, ElementField]:
    return {f.name: f for f in fields}


#: the element stress fields (``siku_core.contact.stress``), vertically integrated, tension positive
STRESS = _by_name(
    ElementField("stress_ee", "N m-1", "element mean stress, east-east component (tension "
                 "positive), vertically integrated", grid="none", restart=False),
    ElementField("stress_nn", "N m-1", "element mean stress, north-north component (tension "
                 "positive), vertically integrated", grid="none", restart=False),
    ElementField("stress_en", "N m-1", "element mean stress, east-north (shear) component, "
                 "vertically integrated", grid="none", restart=False),
)

#: the thickness categories (``siku_core.categories``): element x category arrays
CATEGORIES = _by_name(
    ElementField("category_fraction", "1", "area fraction of the element covered by ice of "
                 "each thickness category", grid="none"),
    ElementField("category_thickness", "m", "ice thickness of each thickness category",
                 grid="none"),
)

#: the fields the engine writes for a scene with processes (``siku_core.ice``)
CHANGING = _by_name(
    ElementField("thickness", "m", "ice thickness (changed by the scene's processes)",
                 grid="none", standard_name="sea_ice_thickness"),
    ElementField("mass", "kg", "element mass (follows its thickness)", grid="none",
                 restart=False),
    ElementField("flags", "1", "element kind (free, static, steady, melted)", dtype="int8",
                 grid="none"),
)

#: every per-element field the engine gives itself (``Simulation.element_fields``), by name
ENGINE_FIELDS: dict[str, ElementField] = {
    **_by_name(
        ElementField("speed", "m s-1", "speed of the element centroid", grid="none",
                     standard_name="sea_ice_speed", restart=False),
        ElementField("damage", "1", "share of the element's frozen joints that have broken",
                     grid="none", restart=False),
    ),
    **STRESS, **CHANGING, **CATEGORIES,
}

#: the centroid's position and motion every output carries per element and snapshot (the
#: NetCDF writer's and the xarray engine's variables; the HDF5 layout stores ``q``, ``V``,
#: ``w`` from which they follow)
STATE_FIELDS: dict[str, ElementField] = _by_name(
    ElementField("lon", "degrees_east", "longitude of the element centroid", grid="none",
                 standard_name="longitude", restart=False),
    ElementField("lat", "degrees_north", "latitude of the element centroid", grid="none",
                 standard_name="latitude", restart=False),
    ElementField("u", "m s-1", "eastward velocity of the element centroid", grid="none",
                 standard_name="eastward_sea_ice_velocity", restart=False),
    ElementField("v", "m s-1", "northward velocity of the element centroid", grid="none",
                 standard_name="northward_sea_ice_velocity", restart=False),
    ElementField("spin", "rad s-1", "spin about the local vertical (counter-clockwise "
                 "positive)", grid="none", restart=False),
)

#: per-element names the engine and its writers use themselves: no component may declare them
#: (the fields above, the state's arrays and the outputs' coordinates and geometry)
RESERVED_FIELDS = frozenset({
    *ENGINE_FIELDS, *STATE_FIELDS, "q", "V", "w", "area", "moment_of_inertia", "material",
    "floe", "bounding_radius", "time", "step", "element"})

#: CF standard names of the engine's own per-element fields (``thickness``: the elements'
#: fixed thickness, or the changing one under processes); a declared field's is its
#: :attr:`ElementField.standard_name`
STANDARD_NAMES: dict[str, str] = {
    n: f.standard_name for n, f in ENGINE_FIELDS.items() if f.standard_name}


def declarations(component: Any) -> tuple[ElementField, ...]:
    """Every field a component (class or instance) may own: its ``owned_fields`` and the
    ``optional_fields`` a parameter switches on."""
    return tuple(component.owned_fields) + tuple(
        f for f in component.optional_fields if f not in component.owned_fields)


def catalogue(components: Iterable[Any] = ()) -> dict[str, ElementField]:
    """``{name: ElementField}`` of the engine's fields (:data:`ENGINE_FIELDS`,
    :data:`STATE_FIELDS`) and every field the ``components`` (classes or instances, e.g. the
    registered plugins' classes) declare (:func:`declarations`); an engine name keeps the
    engine's entry, the first declaration of a name is kept."""
    out = {**STATE_FIELDS, **ENGINE_FIELDS}
    for comp in components:
        for f in declarations(comp):
            out.setdefault(f.name, f)
    return out


def units_label(name: str, units: str) -> str:
    """``"name [units]"``, the label of a colour bar or axis showing the field ``name``."""
    return f"{name} [{units}]"


def field_attrs(spec: ElementField) -> dict[str, str]:
    """The attributes a writer gives the field's variable: ``units``, ``long_name`` and, where
    it has one, ``standard_name``."""
    out = {"units": spec.units, "long_name": spec.long_name}
    if spec.standard_name:
        out["standard_name"] = spec.standard_name
    return out


__all__ = ["CATEGORIES", "CHANGING", "ENGINE_FIELDS", "GRID_REDUCTIONS", "RESERVED_FIELDS",
           "STANDARD_NAMES", "STATE_FIELDS", "STRESS", "ElementField", "catalogue",
           "declarations", "field_attrs", "units_label"]
