"""Interfaces (abstract base classes) for every kind of pluggable component.

A component class declares a ``name`` (what a scene writes), a ``params`` mapping of
:class:`~siku_core.params.Param` (defaults, units, ranges) and implements the methods of its
kind. The engine instantiates it with validated parameters: ``Comp(**params)`` is not used;
``Comp(params_dict)`` is, and the values are available as ``self.p``.

Kinds and their entry points:

==================  ================================================================
``integrator``      :class:`Integrator` — moves elements (only integrators move things)
``forcing``         :class:`ForcingSource` — adds force/torque per element
``field``           :class:`Field` — a velocity field (wind, current) sampled by forcing
``broad_phase``     :class:`BroadPhase` — candidate element pairs
``contact_law``     :class:`ContactLaw` — pair forces and joint history
``writer``          :class:`Writer` — output files and restart
``element_source``  :class:`ElementSource` — makes the ice elements of a scene
==================  ================================================================
"""
from __future__ import annotations

import inspect
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping

import numpy as np

from .params import Param

if TYPE_CHECKING:  # pragma: no cover
    from .simulation import Simulation
    from .state import ElementState

#: signature of the engine's force evaluation, passed to integrators:
#: ``forces(t, q, V, w, F, T)`` fills ``F (N,2)`` [N] and ``T (N,)`` [N m] for the given state.
ForceFunction = Callable[[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], None]


class Component(ABC):
    """Base of all components."""

    kind: ClassVar[str] = ""
    name: ClassVar[str] = ""
    params: ClassVar[Mapping[str, Param]] = {}
    #: per-kind reference methods checked at registration: {method: [parameter names]}
    required: ClassVar[Mapping[str, tuple[str, ...]]] = {}
    #: diagnostics this component reports, name -> unit: a component that declares some
    #: defines ``diagnostics(sim) -> {name: float}``, called on the diagnostics schedule; the
    #: values go to the output file's ``/diagnostics`` and to ensemble summaries
    diagnostic_units: ClassVar[Mapping[str, str]] = {}

    def __init__(self, params: Mapping[str, Any] | None = None):
        full = {k: p.default for k, p in self.params.items()}
        full.update(params or {})
        self.p: dict[str, Any] = full

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring."""
        doc = inspect.getdoc(cls) or ""
        return doc.splitlines()[0] if doc else ""

    def setup(self, sim: "Simulation") -> None:  # noqa: B027 - optional hook
        """Called once when the simulation is built (allocate arrays, cache references)."""

    def describe(self) -> dict[str, Any]:
        """Name and parameter values, recorded in output files."""
        return {"name": self.name, "params": dict(self.p)}


class Integrator(Component):
    """Advances ``q, V, w`` of free and steady elements by one step.

    ``order`` is the nominal global order of accuracy of free motion (no forces),
    ``order_with_forces`` the order when velocity-dependent forces act, ``force_evaluations`` how
    many times one step calls ``forces``.
    """

    kind = "integrator"
    order: ClassVar[int] = 0
    order_with_forces: ClassVar[int] = 0
    force_evaluations: ClassVar[int] = 1
    required = {"step": ("state", "t", "dt", "forces")}

    @abstractmethod
    def step(self, state: "ElementState", t: float, dt: float, forces: ForceFunction) -> None:
        """Advance ``state`` in place from time ``t`` [s] by ``dt`` [s]."""


class Field(Component):
    """A horizontal velocity field (wind or ocean current) on the sphere."""

    kind = "field"
    required = {"sample": ("t", "lat", "lon")}

    @abstractmethod
    def sample(self, t: float, lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eastward and northward velocity [m/s] at ``lat, lon`` [rad], ``t`` [s from start]."""

    def uniform(self, t: float) -> tuple[float, float] | None:
        """``(u, v)`` [m/s] if the field is the same everywhere at ``t`` (forcing then skips
        the per-element positions and sampling), else ``None`` (the default)."""
        return None

    def close(self) -> None:  # noqa: B027 - optional hook
        """Release files or caches."""


class ForcingSource(Component):
    """Adds a driving force [N] and torque [N m] to every element."""

    kind = "forcing"
    required = {"add": ("t", "q", "V", "w", "F", "T")}
    #: whether the scene table may carry a ``field`` sub-table
    uses_field: ClassVar[bool] = False

    @classmethod
    def accepts_field(cls, field_cls: type) -> bool:
        """Whether this source can use a field of class ``field_cls`` (a source that needs
        more than velocities, e.g. wave elevations, narrows it)."""
        return True

    def zero_field(self) -> "Field | None":
        """A field of a kind this source accepts that is zero everywhere (calm air or water),
        for the conformance suite's zero-stress check; ``None``: any zero velocity field."""
        return None

    @abstractmethod
    def add(
        self, t: float, q: np.ndarray, V: np.ndarray, w: np.ndarray, F: np.ndarray, T: np.ndarray
    ) -> None:
        """Add force ``F (N,2)`` in the local frames and torque ``T (N,)`` for state ``q, V, w``."""


class BroadPhase(Component):
    """Finds candidate element pairs whose bounding circles (plus a skin) overlap."""

    kind = "broad_phase"
    required = {"pairs": ("centers", "radii", "skip")}

    @abstractmethod
    def pairs(self, centers: np.ndarray, radii: np.ndarray, skip: np.ndarray) -> np.ndarray:
        """Candidate pairs ``(K, 2)`` int64, ``i < j``, lexicographically sorted."""


# the contact law's contract lives in its own module; listed among the kinds here
from .contact_law import ContactLaw


class Writer(Component):
    """Writes element states and diagnostics on a schedule; may read restarts."""

    kind = "writer"
    required = {"open": ("sim",), "write_state": ("sim",), "close": ("sim",)}

    @abstractmethod
    def open(self, sim: "Simulation") -> None:
        """Create or reopen the output."""

    @abstractmethod
    def write_state(self, sim: "Simulation") -> None:
        """Write one snapshot of the state (enough to restart)."""

    def write_diagnostics(self, sim: "Simulation", diag: Mapping[str, Any]) -> None:  # noqa: B027
        """Append one row of diagnostics."""

    @abstractmethod
    def close(self, sim: "Simulation") -> None:
        """Flush and close."""


@dataclass
class ElementSpec:
    """One element a source makes: a convex polygon on the sphere and how it starts.

    ``None`` means "as the scene table says": the source table's ``flag``, ``velocity``,
    ``spin``, ``thickness`` and ``material`` keys, else the ``[elements]`` defaults.
    """

    #: ``(k, 2)`` vertices ``[lon, lat]`` in degrees, counter-clockwise (clockwise is reversed)
    lonlat: np.ndarray
    #: ``"free"``, ``"static"`` or ``"steady"``
    flag: str | None = None
    #: initial ``(east, north)`` velocity [m/s]
    velocity: tuple[float, float] | None = None
    #: initial spin about the local vertical [rad/s], counter-clockwise positive
    spin: float | None = None
    #: ice thickness [m]
    thickness: float | None = None
    #: material name (a ``[materials.NAME]`` table)
    material: str | None = None
    #: what error messages call this element (e.g. ``"cell (i=3, j=0)"``)
    label: str = ""
    #: the floe (bonded group) the element belongs to, ``-1`` for none; written to outputs
    floe: int = -1


class ElementSource(Component):
    """Makes the ice elements of a scene (polygons, packs, meshes, bonded floes, ...).

    A scene names a source in an ``[[elements.source]]`` table (``name``, ``params`` and the
    common keys ``flag``, ``velocity``, ``spin``, ``thickness``, ``material``); the built-in
    ``polygon``, ``pack`` and ``mesh`` sources are also fed by the ``[[elements.polygon]]``,
    ``[[elements.pack]]`` and ``[elements.mesh]`` tables. ``build`` returns the elements in a
    fixed order; random choices must come from ``seed`` so that a scene always builds the same.
    """

    kind = "element_source"
    required = {"build": ("scene", "seed", "where")}
    #: a pydantic model that validates the source's parameters instead of ``params`` (the
    #: built-in sources whose keys are those of a scene table, e.g. ``[[elements.pack]]``)
    table_model: ClassVar[Any] = None

    @abstractmethod
    def build(self, scene: Any, seed: int, where: str) -> list[ElementSpec]:
        """The elements of this source; ``seed`` is the source's seed (its ``seed`` parameter or
        the scene's ``[run] seed``), ``where`` names the scene table for error messages."""


KINDS: dict[str, type[Component]] = {
    c.kind: c for c in (Integrator, Field, ForcingSource, BroadPhase, ContactLaw, Writer,
                        ElementSource)
}
