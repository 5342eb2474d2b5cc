"""The base of every component (:class:`Component`): what the engine asks of any plugin.

Here on its own so that the contracts built on it (:mod:`siku_core.interfaces`,
:mod:`siku_core.contact_law`) import it without importing each other; its public home is
:mod:`siku_core.interfaces`, which re-exports it.
"""
from __future__ import annotations

import inspect
from abc import ABC
from typing import TYPE_CHECKING, Any, ClassVar, Mapping

import numpy as np

from .params import Param

if TYPE_CHECKING:  # pragma: no cover
    from .context import Context
    from .fields import ElementField


class Component(ABC):
    """Base of all components."""

    kind: ClassVar[str] = ""
    name: ClassVar[str] = ""
    params: ClassVar[Mapping[str, Param]] = {}
    #: per-kind reference methods checked at registration: {method: [parameter names]}
    required: ClassVar[Mapping[str, tuple[str, ...]]] = {}
    #: diagnostics this component reports, name -> unit: a component that declares some
    #: defines ``diagnostics(ctx) -> {name: float}``, called on the diagnostics schedule; the
    #: values go to the output file's ``/diagnostics`` and to ensemble summaries
    diagnostic_units: ClassVar[Mapping[str, str]] = {}
    #: scene tables the component reads besides its parameters (e.g. ``"coupling.grid"``)
    scene_tables: ClassVar[tuple[str, ...]] = ()
    #: the scene table the engine built this component from (e.g. ``"forcing[0].field"``),
    #: for messages: ``ctx.where(self.table)``; empty for one built outside a scene table
    table: str = ""
    #: groups of parameters of which one must be given (e.g. ``(("file",), ("u_file",
    #: "v_file"))``); the conformance suite reads them
    required_one_of: ClassVar[tuple[tuple[str, ...], ...]] = ()
    #: per-element fields this component owns (:class:`~siku_core.fields.ElementField`: name,
    #: units, long name, dtype, initial value, grid reduction): the engine allocates them,
    #: hands them out as ``ctx.fields[name]`` and every writer, the xarray engine, ``siku grid``
    #: and restarts carry them
    owned_fields: ClassVar[tuple["ElementField", ...]] = ()
    #: per-element fields the component owns only when a parameter asks for them: it adds
    #: them to its instance's ``owned_fields`` (in ``__init__``); ``siku plugins`` lists them
    #: and the field catalogue (:func:`siku_core.fields.catalogue`) knows their units
    optional_fields: ClassVar[tuple["ElementField", ...]] = ()
    #: the plugin API versions the component works with (``"1.x"``: any 1.*; ``"1.2"``: 1.2 or
    #: a later 1.*; ``None``: any): one that this siku's ``siku_core.PLUGIN_API_VERSION`` does
    #: not satisfy is refused when it registers (:func:`siku_core.versions.api_mismatch`)
    requires_api: ClassVar[str | None] = None
    #: the per-element fields of :attr:`owned_fields` this component integrates in time (its
    #: degrees of freedom and their rates), each with the bound the engine's guard holds it
    #: to: ``"finite"`` (a number), or ``"speed"`` (a number of m/s at most ``[run]
    #: max_speed``). A value outside stops the run at the last good snapshot like a diverging
    #: velocity (:class:`siku_core.run.guard.Guard`): it is never written as a valid state
    integrates: ClassVar[Mapping[str, str]] = {}
    #: whether the component runs on MPI ranks (``siku_core.ranks``): each rank calls it on
    #: the elements it holds (its own and their ghosts), in ascending element index, with the
    #: ghosts' state current at every step. True for what acts on each element by itself
    #: (forcing sources, integrators, writers, which see the gathered run); a component that
    #: reads the contacts or the elements of the whole run sets it False (an instance may, in
    #: its ``setup``), and a scene using it on more than one rank is refused before the first
    #: step, in one line naming the component (``ranks_refusal`` may say why)
    runs_on_ranks: ClassVar[bool] = True
    #: why a component that does not run on ranks refuses them, one line for the refusal
    #: message (``""``: "it reads the contacts of every element")
    ranks_refusal: ClassVar[str] = ""
    #: a component that runs on ranks and reads other elements through ``ctx.contacts``
    #: (pairs, joints: the processes ``ridging``, ``refreeze``) says so: on ranks each rank
    #: applies it to the contacts of the elements it holds, the owners' ice then goes to the
    #: ghosts, and its joint actions are applied once to the run (``docs/howto/processes.md``)
    reads_contacts: ClassVar[bool] = False
    #: how each array of its ``history()`` is indexed (``{name: layout}``, layouts of
    #: ``siku_core.ranks.history``: ``"element"``, ``"joint"``, ``"pair_keys"``,
    #: ``"pair_rows"``, ``"pair_elements"``, ``"pair_count"``, ``"same"``, ``"total"``), so
    #: that ranks carry it; a component that keeps history without it is refused on ranks
    rank_history: ClassVar[Mapping[str, str]] = {}

    def __init__(self, params: Mapping[str, Any] | None = None):
        full = {k: p.default for k, p in self.params.items()}
        full.update(params or {})
        self.p: dict[str, Any] = full

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring."""
        doc = inspect.getdoc(cls) or ""
        return doc.splitlines()[0] if doc else ""

    def setup(self, ctx: "Context") -> None:  # noqa: B027 - optional hook
        """Called once when the run is built (allocate arrays, keep ``ctx`` if the step needs
        it)."""

    def setup_on_rank(self, ctx: "Context", run: "Component", link: Any) -> None:
        """Set up this copy of the component on a rank's engine (``siku_core.ranks``):
        ``ctx`` is the engine's context over the elements the rank holds (owned and ghosts,
        ascending global index), ``run`` the component's copy set up on the whole run, and
        ``link`` (``siku_core.ranks.local.RankLink``) the rank's place in the run: the
        elements' global indices, gathering the run's elements and sending owners' rows to
        ghosts. The default sets the copy up afresh on ``ctx``; a component whose set-up
        depends on the whole run (a sub-step from every element, indices of the run's
        elements, expensive coefficients) takes it from ``run`` instead."""
        self.setup(ctx)

    def stability_limit(self, ctx: "Context") -> tuple[float, str] | None:
        """``(dt_max [s], reason)``: the largest stable step this component allows, checked
        against the scene's ``dt`` before the run (``None``: no limit)."""
        return None

    def diagnostics(self, ctx: "Context") -> Mapping[str, float]:
        """Values of the diagnostics declared in :attr:`diagnostic_units`, by name."""
        return {}

    def history(self) -> dict[str, np.ndarray] | None:
        """Arrays the component needs to restart exactly (joint damage, contact lists...),
        written with every snapshot; ``None``: it keeps no history."""
        return None

    def set_history(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Restore what :meth:`history` returned (a restart)."""
        raise NotImplementedError(f"{self.kind} '{self.name}' keeps no history to restore")

    def describe(self) -> dict[str, Any]:
        """Name and parameter values, recorded in output files."""
        return {"name": self.name, "params": dict(self.p)}
