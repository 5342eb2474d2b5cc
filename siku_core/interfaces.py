"""Interfaces (abstract base classes) for every kind of pluggable component.

A component class declares a ``name`` (what a scene writes), a ``params`` mapping of
:class:`~siku_core.params.Param` (defaults, units, ranges) and implements the methods of its
kind. The engine instantiates it with validated parameters: ``Comp(**params)`` is not used;
``Comp(params_dict)`` is, and the values are available as ``self.p``.

Components see the run through a :class:`~siku_core.context.Context` (``ctx``: state, clock
and ``dt``, scene, registry look-ups, joints, diagnostics), never the run loop itself. Every
optional capability is declared here with its default, so the engine calls it on every
component without looking for it: ``setup(ctx)``, ``stability_limit(ctx)`` (no limit),
``history()`` / ``set_history(arrays)`` (no history), ``diagnostics(ctx)`` (none declared in
``diagnostic_units``), ``scene_tables``, ``required_one_of``, ``owned_fields`` and
``optional_fields`` (none), ``integrates`` (nothing), ``runs_on_ranks`` and
``ranks_refusal``; per kind: a forcing source's ``field``, ``field_required`` and ``py_add``;
an element source's ``table_model``; a writer's ``path``, ``overwrite``, ``appends``,
``read_restart``, ``owns``, ``folder``, ``in_memory``, ``holds_snapshots``, ``target``,
``published`` and ``lock``; a process's ``conserves``, ``budget``, ``joints_to_create`` and
``couple_exchange``; a contact law's (:mod:`siku_core.contact_law`) evaluators, records,
history names and ``joint_energy``. The engine and siku's writers read them as attributes
(``tests/test_capabilities.py`` holds them to it).

Kinds and their entry points:

==================  ================================================================
``integrator``      :class:`Integrator` — moves elements (only integrators move things)
``forcing``         :class:`ForcingSource` — adds force/torque per element
``field``           :class:`Field` — a velocity field (wind, current) sampled by forcing
``broad_phase``     :class:`BroadPhase` — candidate element pairs
``contact_law``     :class:`ContactLaw` — pair forces and joint history
``writer``          :class:`Writer` — output files and restart
``element_source``  :class:`ElementSource` — makes the ice elements of a scene
``process``         :class:`Process` — changes the ice (thickness, fields, joints)
``attenuation_law`` :class:`AttenuationLaw` — the rate at which ice damps waves
==================  ================================================================
"""
from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping

import numpy as np

from .component import Component
from .params import Param  # noqa: F401 - re-exported, as before

if TYPE_CHECKING:  # pragma: no cover
    from .context import Context
    from .state import ElementState

#: signature of the engine's force evaluation, passed to integrators:
#: ``forces(t, q, V, w, F, T)`` fills ``F (N,2)`` [N] and ``T (N,)`` [N m] for the given state.
ForceFunction = Callable[[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], None]


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

    def on_rank(self, ctx: "Context", link: Any) -> "Field":
        """The field as the engine of an MPI rank evaluates it (``siku_core.ranks``): ``ctx``
        is the engine's context over the elements the rank holds, ``link``
        (``siku_core.ranks.local.RankLink``) the rank's place in the run. A field of place
        and time alone is the same on every rank: this instance, the run's (the default). A
        field that evolves from the elements (the ``spectral`` wave field) returns a view of
        the run's instance that gathers them from their owners through ``link`` (collective
        calls, every rank alike) and sets the fields of the rank's elements."""
        return self


class ForcingSource(Component):
    """Adds a driving force [N] and torque [N m] to every element."""

    kind = "forcing"
    required = {"add": ("t", "q", "V", "w", "F", "T")}
    #: whether the scene table may carry a ``field`` sub-table
    uses_field: ClassVar[bool] = False
    #: whether a source that uses a field needs one (``False``: it runs without, e.g. calm)
    field_required: ClassVar[bool] = True
    #: a pure-Python ``py_add(t, q, V, w, F, T)`` the conformance suite compares ``add`` with
    py_add: ClassVar[Callable[..., None] | None] = None
    #: the velocity or wave field the engine built from the table's ``field`` (or ``None``)
    field: "Field | None" = None

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


# the contact law's contract lives in its own module (which subclasses Component, so it is
# imported once Component exists); listed among the kinds here
from .contact_law import ContactLaw  # noqa: E402 (re-exported: every kind's base here)


class Writer(Component):
    """Writes element states and diagnostics on a schedule; may read restarts."""

    kind = "writer"
    required = {"open": ("ctx",), "write_state": ("ctx",), "close": ("ctx",)}
    #: the file to write, set by the engine before :meth:`open` (``[output] file`` or
    #: ``--out``); the writer never chooses another path
    path: "Path | None" = None
    #: whether the user asked to replace an existing output (``--overwrite``,
    #: ``Simulation(overwrite=True)``), set by the engine before :meth:`open`; the engine has
    #: already checked that an existing file at :attr:`path` is this writer's own (``owns``)
    overwrite: bool = False
    #: whether :meth:`open` continues its own file on a restart (``ctx.restarted_from`` set):
    #: the engine then lets a restart write to an existing file of this writer
    appends: ClassVar[bool] = False
    #: whether the output is a folder (a Zarr store) rather than one file: the engine then
    #: treats an existing folder at :attr:`path` as the existing output (``owns`` decides)
    folder: ClassVar[bool] = False
    #: whether the writer keeps the snapshots in memory rather than in a file
    #: (``Simulation(scene, out="memory")``): it writes no file, the conformance suite's file
    #: checks pass it by, and ``Simulation.to_xarray`` reads its snapshots (``dataset``) once
    #: :meth:`holds_snapshots`
    in_memory: ClassVar[bool] = False
    #: the file the writer puts in place (a writer that writes to a partial file first and
    #: publishes it: ``siku_core.run.outputs.publish``), synced to the disk when it closes;
    #: ``None``:
    #: the writer writes :attr:`path` directly, nothing to sync
    target: "Path | None" = None
    #: whether the output is in place: ``False`` while a publishing writer has written no
    #: snapshot yet (the engine then says that nothing was written, and the writer's partial
    #: file is removed when it closes: ``siku_core.run.outputs.settle``)
    published: bool = True
    #: the lock the writer holds on its output while it writes (``siku_core.run.outputs.RunLock``),
    #: released when it closes; ``None``: it holds none
    lock: Any = None

    @abstractmethod
    def open(self, ctx: "Context") -> None:
        """Create the output at :attr:`path`, or reopen it to continue a restarted run."""

    @abstractmethod
    def write_state(self, ctx: "Context") -> None:
        """Write one snapshot of the state (enough to restart)."""

    def write_diagnostics(self, ctx: "Context", diag: Mapping[str, Any]) -> None:  # noqa: B027
        """Append one row of diagnostics."""

    @abstractmethod
    def close(self, ctx: "Context") -> None:
        """Flush and close."""

    def _discard(self) -> None:  # noqa: B027 - optional hook
        """Remove what a publishing writer wrote aside when it closes without having put its
        output in place (:attr:`published` still ``False``: the run stopped before its first
        snapshot), called by ``siku_core.run.outputs.settle``; the default has nothing to
        remove."""

    def holds_snapshots(self) -> bool:
        """Whether an :attr:`in_memory` writer keeps snapshots to read; ``False`` (the
        default) for a writer of files."""
        return False

    @classmethod
    def owns(cls, path: "Path") -> bool:
        """Whether the existing file ``path`` is an output of this writer, identified by the
        marks the writer writes inside it (never by its name), reading it without writing to
        it. ``--overwrite`` replaces only such a file; the default, ``False``, replaces
        nothing (``siku_core.run.outputs.check_target``)."""
        return False

    @classmethod
    def read_restart(cls, path: "Path", ctx: "Context") -> dict[str, Any]:
        """The last complete snapshot of ``path`` for a restart: ``step``, ``q``, ``V``,
        ``w`` (arrays of the state's shapes), ``history`` (``{component key: {name:
        array}}``, as :meth:`Context.history` gave when it was written), and, where the file
        has them, ``record`` (the run record it was written with) and ``n_steps``. The engine
        checks them against the scene and puts them into the run. The default refuses: a
        writer whose files cannot be restarted says so."""
        from .errors import DataError

        raise DataError(f"{path}: outputs of the '{cls.name}' writer cannot be restarted; "
                        "restart from an HDF5 output ([output] writer = \"hdf5\")")


class Process(Component):
    """Physics that changes the ice itself: thickness (mass and inertia follow), the fields it
    declares in ``owned_fields``, joints (break, refreeze), elements that melt away.

    A scene chooses processes in ``[[process]]`` tables (``name``, ``params``, ``every``). The
    engine calls :meth:`apply` after the integrator has committed a step, every ``every``
    seconds of model time (default: every step), in the order of the tables; ``dt`` is the
    model time since the process last ran [s] and ``ctx.time`` the end of that interval. A
    process changes ``ctx.state.thickness`` and its own ``ctx.fields[name]`` in place, melts
    elements with ``ctx.melt(k)`` and changes joints through ``ctx.contacts``
    (``break_joints``, ``refreeze_joints``, ``create_joints`` within the slots that
    :meth:`joints_to_create` reserves). Afterwards the engine recomputes mass, inertia,
    joint stiffness and the stable step (``siku_core.ice``). It never moves elements (only the
    integrator does) and never writes files (writers do).

    ``conserves`` names what the process keeps constant (``"volume"``: the total ice volume
    ``sum(area h)``, ``sum(area sum_k a_k h_k)`` with thickness categories:
    ``siku_core.categories.element_volume``); ``budget(ctx)`` returns the volume it added
    since the start [m³] (growth minus melt) for the conformance suite's volume budget.
    """

    kind = "process"
    #: a process runs on MPI ranks when it changes each element by itself, from that
    #: element's state and fields alone (``thermodynamics``): it sets ``runs_on_ranks =
    #: True``, and each rank applies it to the elements it holds (``siku_core.ranks``)
    runs_on_ranks = False
    ranks_refusal = ("it is not declared element-local; a process that changes each element "
                     "by itself declares runs_on_ranks = True")
    required = {"apply": ("ctx", "dt")}
    #: quantities the process conserves (checked by the conformance suite)
    conserves: ClassVar[tuple[str, ...]] = ()
    #: whether the process needs an ice concentration per element (``ctx.categories``): a
    #: scene whose element sources give no thickness categories then gets one per element,
    #: all of it ice (``siku_core.categories.one_category``; ``ridging``, which opens water)
    needs_categories: ClassVar[bool] = False

    @abstractmethod
    def apply(self, ctx: "Context", dt: float) -> None:
        """Change the ice over the last ``dt`` [s] of model time, ending at ``ctx.time``."""

    def joints_to_create(self, n_elements: int) -> int:
        """How many joints the process may create in a run of ``n_elements`` elements
        (``ctx.contacts.create_joints``): the engine reserves that many joint slots before any
        set-up. 0 (the default): none, and nothing is reserved."""
        return 0

    def budget(self, ctx: "Context") -> float:
        """Ice volume this process added since the start of the run [m³] (negative: removed);
        a process that conserves volume returns 0 (the default)."""
        return 0.0

    def close(self) -> None:  # noqa: B027 - optional hook
        """Release files (called when the run ends)."""

    def couple_exchange(self, exchange: Any) -> None:  # noqa: B027 - optional hook
        """Take what a coupled model hands over (a run driven through the BMI):
        ``exchange`` is the run's exchange forcing source, whose grid
        fields (e.g. the waves a floating process follows) the process may read from now on.
        The default takes nothing."""


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
    #: thickness categories ``(a_k [1], h_k [m])`` (``siku_core.categories``); the element's
    #: thickness is then their mean ``sum a_k h_k / sum a_k``
    categories: tuple[np.ndarray, np.ndarray] | None = None


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


# --------------------------------------------------------------------- attenuation laws
class AttenuationLaw(Component):
    """The rate at which sea ice damps surface waves: the spatial decay rate of the wave
    amplitude ``k_i`` [1/m] under a complete ice cover, ``a(x) = a0 exp(-k_i x)``; the energy
    decays at ``2 k_i``. A wave model that uses it (a spectral wave field) applies the
    source term ``S_ice = -2 c_g k_i C E`` with the ice concentration ``C`` of each cell, as
    WAVEWATCH III does with its ice source terms."""

    kind = "attenuation_law"
    required = {"rate": ("frequency", "thickness", "depth")}

    @abstractmethod
    def rate(self, frequency: np.ndarray, thickness: np.ndarray,
             depth: float) -> np.ndarray:
        """Amplitude attenuation rate ``k_i`` [1/m] of waves of ``frequency`` [Hz] under ice of
        ``thickness`` [m] in water of ``depth`` [m] (``inf``: deep); the arguments broadcast."""


KINDS: dict[str, type[Component]] = {
    c.kind: c for c in (Integrator, Field, ForcingSource, BroadPhase, ContactLaw, Writer,
                        ElementSource, Process, AttenuationLaw)
}


#: the base classes of the kinds a plugin provides (docs/reference/api.md)
__all__ = [
    "Component", "Integrator", "Field", "ForcingSource", "BroadPhase", "Writer", "Process",
    "ElementSpec", "ElementSource", "AttenuationLaw", "KINDS",
]
