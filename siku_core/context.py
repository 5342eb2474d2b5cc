"""What a component sees of the run: the narrow context passed to every plugin.

A component (integrator, forcing source, field, broad phase, contact law, writer) is handed a
:class:`Context` in ``setup(ctx)``, ``stability_limit(ctx)``, ``diagnostics(ctx)`` and, for
writers, ``open``/``write_state``/``write_diagnostics``/``close``/``read_restart``; it keeps
the reference if it needs it during the step. The context is the whole contract between a
component and the engine: nothing else of the run loop is reachable from it, so the loop can
change without breaking plugins. Drivers that own a run (the BMI, ensembles, the virtual ice
tests) hold the :class:`~siku_core.run.simulation.Simulation` itself, not a context.

What it offers, by purpose:

========================  =============================================================
state and planet          ``state`` (:class:`~siku_core.state.ElementState`, arrays in SI
                          units), ``radius`` [m], ``rotation_rate`` [rad/s]
clock                     ``dt`` [s], ``time`` [s since start], ``step_index``,
                          ``n_steps``, ``start`` (``datetime`` or ``None``),
                          ``datetime_at(t)``, ``committing`` (the first force
                          evaluation of a step: the one whose joint changes count)
scene                     ``scene`` (the loaded :class:`~siku_core.scene.scene_file.Scene`, read
                          only), ``seed``, ``where(table)`` (a message prefix naming the
                          file and table)
registry                  ``registry`` (look-ups by kind and name),
                          ``component(kind, name, params, table)`` (build a validated
                          component, e.g. a field a source makes itself),
                          ``forcing_field(k)`` (the field the run built for
                          ``[[forcing]]`` table ``k``: an evolving sea is shared)
joints and contacts       ``contacts``: a read-only view of the run's contacts
                          (:class:`~siku_core.contact.contacts_view.ContactsView`: the joint and
                          pair tables, ``break_joints``, ``create_joints``) or ``None``
diagnostics and fields    ``diagnostics()``, ``element_fields()``, ``timings``
                          (seconds per phase, :data:`~siku_core.run.simulation.PHASES`),
                          ``fields`` (the declared per-element fields by name, arrays
                          their owners change in place), ``field_catalogue()`` (units,
                          long name and grid reduction of every field a writer writes)
changing the ice          ``melt(elements)`` (processes: an element melted away),
                          ``categories``: the thickness categories (fraction and
                          thickness ``(n, K)``, changed in place) or ``None``
what writers record       ``run_record()``, ``history()``, ``component_descriptions()``,
                          ``plugin_versions()``, ``snapshot_every``, ``diagnostics_every``
                          (steps), ``restarted_from``, ``restart_path`` (where a restart
                          continued from), ``output_path`` (the run's first output
                          file), ``dt_requested``
========================  =============================================================
"""
from __future__ import annotations

import datetime as _dt
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from pathlib import Path

    import numpy as np

    from .categories import Categories
    from .scene.scene_file import Scene
    from .state import ElementState

#: the running :class:`~siku_core.run.simulation.Simulation` as the modules it drives and hands
#: itself to see it (the context, the guard, the ice book, restarts). Those modules sit below
#: the simulation in the engine's imports (the simulation imports them), so they name it by
#: this alias and reach it by its attributes, never by importing :mod:`siku_core.run.simulation`.
Run = Any


class Context:
    """The run as a component sees it (see the module docstring for the members)."""

    __slots__ = ("_sim", "_contacts", "_view")

    def __init__(self, sim: Run, contacts_view: Any = None):
        """``sim``: the run; ``contacts_view``: the class of the contacts view
        (:class:`~siku_core.contact.contacts_view.ContactsView`, given by the simulation, which
        stands above both) that :attr:`contacts` builds on the run's contact model."""
        self._sim = sim
        self._view = contacts_view
        self._contacts: Any = None

    def __repr__(self) -> str:
        s = self._sim
        return (f"<siku Context: {s.state.n} elements, step {s.step_index} of {s.n_steps}, "
                f"dt = {s.dt:g} s>")

    # ------------------------------------------------------------------ state and planet
    @property
    def state(self) -> "ElementState":
        """The element state (arrays are updated in place by the integrator)."""
        return self._sim.state

    @property
    def radius(self) -> float:
        """Planet radius [m]."""
        return self._sim.radius

    @property
    def rotation_rate(self) -> float:
        """Planet rotation rate [rad/s]."""
        return self._sim.rotation_rate

    # ------------------------------------------------------------------ clock
    @property
    def dt(self) -> float:
        """The time step [s] (as fitted to the output times)."""
        return self._sim.dt

    @property
    def time(self) -> float:
        """Model time since the start [s]."""
        return self._sim.time

    @property
    def step_index(self) -> int:
        """Steps taken since the start of the run (a restart continues the count)."""
        return self._sim.step_index

    @property
    def n_steps(self) -> int:
        """Steps of the whole run."""
        return self._sim.n_steps

    @property
    def start(self) -> _dt.datetime | None:
        """The scene's start date (UTC), ``None`` for a run in model time only."""
        return self._sim.start

    def datetime_at(self, t: float) -> _dt.datetime | None:
        """The date at model time ``t`` [s], ``None`` without a start date."""
        return self._sim.datetime_at(t)

    @property
    def committing(self) -> bool:
        """True during the first force evaluation of a step, the one whose joint history and
        breaks count (a component that changes joints acts only then)."""
        return self._sim.committing

    # ------------------------------------------------------------------ scene
    @property
    def scene(self) -> "Scene":
        """The scene of the run (validated configuration ``scene.cfg``, text, path)."""
        return self._sim.scene

    @property
    def seed(self) -> int:
        """The run's seed (``[run] seed``)."""
        return self._sim.seed

    def where(self, table: str) -> str:
        """``"FILE [table]"``: the prefix of a message about a scene table."""
        return self._sim.scene.where(table)

    # ------------------------------------------------------------------ registry
    @property
    def registry(self) -> Any:
        """The component registry of the run (:class:`~siku_core.plugins.Registry`)."""
        return self._sim.registry

    def component(self, kind: str, name: str, params: dict, table: str) -> Any:
        """A component (:class:`~siku_core.component.Component`) of ``kind`` registered as
        ``name`` (or ``package.module:Class``), with ``params`` validated as for the scene
        table ``table`` (messages name it)."""
        return self._sim._component(kind, name, params, table)

    def forcing_field(self, k: int) -> Any:
        """The field the run built for ``[[forcing]]`` table ``k`` (``None`` if it has none):
        the instance the forcing source evaluates, so a component that needs the same evolving
        sea (a ``spectral`` wave field's local spectrum) reads it rather than a copy."""
        return self._sim.forcing[k].field

    # ------------------------------------------------------------------ joints and contacts
    @property
    def contacts(self) -> Any:
        """The run's contacts as a component sees them, ``None`` without a ``[contact]`` table:
        a :class:`~siku_core.contact.contacts_view.ContactsView` (read-only joint and pair tables,
        the
        law's parameters, and the actions a component may take: break, refreeze and create
        joints, keep the law's cap flags, take the breaks)."""
        model = self._sim.contacts
        if model is None:
            return None
        if self._contacts is None or not self._contacts.views(model):
            self._contacts = self._view(model)
        return self._contacts

    # ------------------------------------------------------------------ diagnostics, fields
    def diagnostics(self) -> dict[str, Any]:
        """The diagnostics of the current state (``siku_core.diagnostics.DIAGNOSTICS``)."""
        return self._sim.diagnostics()

    def element_fields(self) -> dict[str, "np.ndarray"]:
        """Per-element fields for maps and outputs (speed, damage, stress)."""
        return self._sim.element_fields()

    @property
    def fields(self) -> dict[str, "np.ndarray"]:
        """The per-element fields components declared (``owned_fields``), by name: one value
        per element, in the declared dtype and units; the owner changes them in place."""
        return self._sim.ice.values

    def field_catalogue(self) -> dict[str, tuple[str, str, str]]:
        """``{name: (units, long_name, grid)}`` of the declared fields and, with processes, of
        the changing ``thickness``, ``mass`` and ``flags`` (what writers label them with;
        ``grid``: ``mean``, ``sum`` or ``none``, how ``siku grid`` reduces them per cell)."""
        return self._sim.ice.catalogue()

    def standard_names(self) -> dict[str, str]:
        """``{name: CF standard_name}`` of the per-element fields that have one: the engine's
        own (``siku_core.fields.STANDARD_NAMES``: ``speed``, ``thickness``) and every declared
        field's :attr:`~siku_core.fields.ElementField.standard_name`; writers label the fields with
        them."""
        return self._sim.ice.standard_names()

    @property
    def categories(self) -> "Categories | None":
        """The elements' thickness categories (:class:`~siku_core.categories.Categories`:
        ``fraction`` ``a_k`` [1] and ``thickness`` ``h_k`` [m], ``(n, K)`` arrays a process
        changes in place; the engine then makes each element's thickness their mean), or
        ``None`` for a scene without categories."""
        return self._sim.ice.categories

    def melt(self, elements) -> int:
        """Flag ``elements`` (indices) as melted away: they stop, leave the contact phase and
        their joints break (``siku_core.ice``). Returns how many were not already melted."""
        return self._sim.ice.melt(elements)

    @property
    def timings(self) -> dict[str, float]:
        """Wall time [s] spent in each phase of the step since the last reset."""
        return self._sim.timings

    # ------------------------------------------------------------------ what writers record
    def run_record(self) -> dict[str, Any]:
        """What the results depend on: effective scene, components, versions, seed, dt."""
        return self._sim.run_record()

    def history(self) -> dict[str, dict[str, "np.ndarray"]]:
        """Every component's history needed to restart exactly, by component key."""
        return self._sim.history_arrays()

    def component_descriptions(self) -> list[dict[str, Any]]:
        """Kind, name and parameters of every component of the run, in step order."""
        return [dict(kind=c.kind, **c.describe()) for c in self._sim.components()]

    def plugin_versions(self) -> dict[str, str]:
        """Packages that provided the run's components, with versions."""
        return self._sim.plugin_versions()

    @property
    def snapshot_every(self) -> int:
        """Steps between state snapshots."""
        return self._sim.state_schedule.every

    @property
    def diagnostics_every(self) -> int:
        """Steps between rows of diagnostics."""
        return self._sim.diag_schedule.every

    @property
    def restarted_from(self) -> int | None:
        """The step a restarted run continued from, ``None`` for a fresh run."""
        return self._sim.restarted_from

    @property
    def restart_path(self) -> "Path | None":
        """The file a restarted run continued from, ``None`` for a fresh run."""
        return self._sim.restart_path

    @property
    def output_path(self) -> "Path | None":
        """The run's first output file (``[output] file`` or ``--out``; the one a restart
        reads), ``None`` when the run writes none."""
        return self._sim.output_path

    @property
    def dt_requested(self) -> float:
        """The scene's ``dt`` [s] before it was fitted to the output times (:attr:`dt`)."""
        return self._sim.dt_requested
