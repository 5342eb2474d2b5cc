"""Ice that changes: per-element fields declared by components, and what follows a change of
thickness (mass, inertia, joint stiffness, the stable step).

A component declares the per-element fields it owns in ``owned_fields`` (a tuple of
:class:`~siku_core.fields.ElementField`: name, units, long name, dtype, initial value, how a grid
reduces it; the catalogue of every per-element field is :mod:`siku_core.fields`).
The engine allocates them once (:class:`IceBook`), hands them out by name
(``ctx.fields[name]``, a numpy array of one value per element that the owner changes in place)
and writes, restarts and grids them without further code: every writer writes them with their
units, the xarray engine reads them, ``siku grid`` puts them on grids (the cell mean weighted by
ice area, or the sum, as declared), ``siku plugins`` lists them.

A scene with processes (``[[process]]`` tables, :class:`~siku_core.interfaces.Process`) has a
time-dependent ``thickness`` [m], ``mass`` [kg] and ``flags`` in its outputs; after the processes of
a step have run, :meth:`IceBook.after_processes` recomputes what depends on the thickness: mass
``m = rho v A`` and polar moment ``I = rho v J`` (``J`` the polygon's polar second moment of area,
``v`` the ice volume per area, :func:`~siku_core.categories.ice_per_area`: ``h``, or ``sum a_k h_k``
with thickness categories), the contact model's inverse masses and the joints' reduced masses and
eq. 9 stiffnesses (from ``E h``), and the stable step (again once some element's thickness, or its
ice volume per area, has changed by more than :data:`RECHECK` since the last check), which stops the
run with one line naming the element if ``dt`` is no longer safe. Without categories it does so in
compiled passes (:mod:`siku_core.contact.ice_follow`) for the elements whose thickness or flag
changed and
their joints only, or for all of them when a quarter or more changed (the joints' constants then in
the next joint loop); mass from thickness is :func:`~siku_core.contact.ice_follow.element_mass`.
With
categories every element's mass follows ``v`` in one NumPy pass. A scene with neither declared
fields nor processes allocates nothing here and runs as before.

Thickness categories (:mod:`siku_core.categories`, a scene whose element sources give them, or
one per element when a process ``needs_categories``):
``ctx.categories`` holds the fraction ``a_k`` and thickness ``h_k`` of every element's categories,
which processes change in place. After each process the engine makes the element thickness their
mean again, ``h = sum a_k h_k / sum a_k``: an element whose categories the process changed gets
that mean (the process may set it itself with the same formula, :func:`category_mean`); an
element whose thickness alone changed (a process that knows no categories) has
every ``h_k`` scaled by the ratio of its new to its old thickness, its fractions unchanged.
Categories that stop being a distribution (a fraction or thickness negative, fractions summing
above 1) stop the run with one line naming the process and the element. They are written as
``category_fraction`` and ``category_thickness`` (dimensions element × category) and restarted.

An element that melts away (a process calls ``ctx.melt(elements)``) is flagged ``melted``
(flag code 3 in the outputs), stops moving, leaves the contact phase (its joints break with
mode ``MELT`` and it is never a collision candidate again) and keeps its last thickness so that
its mass stays positive.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable

import numpy as np

from .categories import Categories, category_mean, category_problem, ice_per_area
from .errors import SceneError, StabilityError
from .deprecation import moved_names
from .fields import ENGINE_FIELDS
from .fields import STANDARD_NAMES as ENGINE_STANDARD_NAMES
from .contact.ice_follow import few, follow_elements, scan_ice
from .state import MELTED

if TYPE_CHECKING:  # pragma: no cover
    from .context import Run
    from .fields import ElementField

#: relative change of an element's thickness since the last stable-step check that triggers the
#: next one (the limits scale with the thickness at most linearly, so between checks the
#: critical step moves by less than this share: well inside the safety factor ``dt_safety``)
RECHECK = 0.01


def declared_fields(components: Iterable[Any]) -> dict[str, tuple[str, ElementField]]:
    """``{name: (owner, field)}`` of every field the components declare; a name declared twice
    is a :class:`SceneError` naming both owners."""
    out: dict[str, tuple[str, ElementField]] = {}
    for comp in components:
        owner = f"{comp.kind} '{comp.name}'"
        if comp.table:
            owner += f" ([{comp.table}])"
        for f in comp.owned_fields:
            f.check(owner)
            if f.name in out:
                raise SceneError(f"per-element field '{f.name}' is declared by both "
                                 f"{out[f.name][0]} and {owner}; a field has one owner")
            out[f.name] = (owner, f)
    return out


class IceBook:
    """The declared per-element fields of a run and the changing thickness (module
    docstring). ``history()`` holds them for snapshots, the NaN guard and restarts."""

    kind = "engine"
    name = "elements"

    def __init__(self, sim: "Run", processes: bool,
                 categories: Categories | None = None):
        self._sim = sim
        #: the elements' thickness categories, ``None`` for a scene without
        self.categories = categories
        st = sim.state
        self.specs = declared_fields(sim.components())
        self.values: dict[str, np.ndarray] = {
            name: np.full(st.n, f.initial, dtype=np.dtype(f.dtype))
            for name, (_, f) in self.specs.items()}
        #: whether the scene's processes may change thickness, flags and joints
        self.processes = processes
        self.active = processes or bool(self.specs) or categories is not None
        if processes:
            mats = list(sim.scene.cfg.materials.values())
            self.rho = np.array([mats[k].density for k in st.material], dtype=float)
            with np.errstate(divide="ignore", invalid="ignore"):
                #: polar second moment of area of each polygon [m^4], I / (rho v)
                self.J = st.I / (self.rho * ice_per_area(st.thickness, categories))
            self._h_seen = st.thickness.copy()
            self._flags_seen = st.flags.copy()
            #: whether a process changed some element's categories since the last refresh
            self._cats_changed = False
            #: thickness and ice volume per area at the last stable-step check
            self._h_checked = st.thickness.copy()
            self._v_checked = ice_per_area(st.thickness, categories).copy()
            #: the elements whose thickness or flag changed (first ones; ``scan_ice``)
            self._changed = np.empty(st.n, dtype=np.int64)
            #: whether every element's mass, inertia and contact constants follow its thickness
            #: by ``element_mass`` (after the first refresh; before it, the set-up's values)
            self._followed = False

    # ------------------------------------------------------------------ fields
    def element_fields(self) -> dict[str, np.ndarray]:
        """The declared fields and, with processes, ``thickness``, ``mass`` and ``flags``."""
        out = dict(self.values)
        out.update(self._engine_arrays())
        return out

    def _engine_arrays(self) -> dict[str, np.ndarray]:
        """The engine's own fields of this run held here (names of
        :data:`~siku_core.fields.ENGINE_FIELDS`): with processes the changing thickness, mass
        and flags, with categories their fractions and thicknesses."""
        out: dict[str, np.ndarray] = {}
        if self.processes:
            st = self._sim.state
            out.update(thickness=st.thickness, mass=st.m, flags=st.flags)
        out.update(self._category_arrays())
        return out

    def _category_arrays(self) -> dict[str, np.ndarray]:
        c = self.categories
        if c is None:
            return {}
        return {"category_fraction": c.fraction, "category_thickness": c.thickness}

    def field_specs(self) -> dict[str, ElementField]:
        """``{name: ElementField}`` of every field :meth:`element_fields` gives: the declared
        ones and the engine's (:data:`~siku_core.fields.ENGINE_FIELDS`)."""
        out = {n: f for n, (_, f) in self.specs.items()}
        out.update({n: ENGINE_FIELDS[n] for n in self._engine_arrays()})
        return out

    def catalogue(self) -> dict[str, tuple[str, str, str]]:
        """``{name: (units, long_name, grid)}`` of every field :meth:`element_fields` gives."""
        return {n: (f.units, f.long_name, f.grid) for n, f in self.field_specs().items()}

    def standard_names(self) -> dict[str, str]:
        """``{name: CF standard_name}`` of the per-element fields that have one: the engine's
        own (:data:`~siku_core.fields.STANDARD_NAMES`) and every declared field's
        ``standard_name``."""
        out = dict(ENGINE_STANDARD_NAMES)
        out.update({n: f.standard_name for n, (_, f) in self.specs.items() if f.standard_name})
        return out

    # ------------------------------------------------------------------ history (restart)
    def _restarted(self) -> dict[str, np.ndarray]:
        """The arrays a restart carries, by name: every declared field and the engine's fields
        held here that are not computed from the state
        (:attr:`~siku_core.fields.ElementField.restart`)."""
        out = dict(self.values)
        out.update({k: v for k, v in self._engine_arrays().items() if ENGINE_FIELDS[k].restart})
        return out

    def history(self) -> dict[str, np.ndarray] | None:
        if not self.active:
            return None
        return {k: v.copy() for k, v in self._restarted().items()}

    def set_history(self, arrays: dict[str, np.ndarray]) -> None:
        held = self._restarted()
        for name, arr in arrays.items():
            if name not in held:
                raise SceneError(f"restart holds per-element '{name}', which this scene does "
                                 "not declare; restart with the scene that wrote the file")
            arr = np.asarray(arr)
            want = held[name].shape
            if arr.shape != want:
                raise SceneError(f"restart holds per-element '{name}' of shape {arr.shape}; "
                                 f"the scene builds {want}")
            held[name][:] = arr
        if self.processes:
            self.refresh(check=False)

    # ------------------------------------------------------------------ changes
    def before_process(self) -> tuple[np.ndarray, ...] | None:
        """What :meth:`after_process` compares with (categories and thickness), or ``None``
        for a scene without categories."""
        c = self.categories
        if c is None:
            return None
        return c.fraction.copy(), c.thickness.copy(), self._sim.state.thickness.copy()

    def after_process(self, before: tuple[np.ndarray, ...] | None, who: str) -> None:
        """Make each element's thickness the mean of its categories again after one process
        (module docstring); ``before`` from :meth:`before_process`."""
        if before is None:
            return
        c, st = self.categories, self._sim.state
        a0, h0, t0 = before
        cat = (c.fraction != a0).any(axis=1) | (c.thickness != h0).any(axis=1)
        alone = ~cat & (st.thickness != t0)
        if not (cat.any() or alone.any()):
            return
        rows = np.flatnonzero(cat)
        self._cats_changed |= bool(len(rows))
        found = category_problem(c.fraction[rows], c.thickness[rows])
        if found is not None:
            i, what = found
            raise StabilityError(f"{who} left the thickness categories of element {rows[i]} "
                                 f"at t = {self._sim.time:g} s: {what}")
        k = np.flatnonzero(alone & np.isfinite(st.thickness) & (st.thickness > 0))
        c.thickness[k] *= (st.thickness[k] / t0[k])[:, None]
        rows = np.flatnonzero(cat | alone)
        rows = rows[np.isfinite(st.thickness[rows]) & (st.thickness[rows] > 0) | cat[rows]]
        st.thickness[rows] = category_mean(c.fraction[rows], c.thickness[rows])

    def after_processes(self, who: str) -> None:
        """After processes ran: if a thickness or flag changed, recompute what depends on it
        and check the step (``who`` names the processes for the message). One compiled pass
        finds the changed elements (:func:`~siku_core.contact.ice_follow.scan_ice`); only they and
        their joints are recomputed."""
        st = self._sim.state
        nc, h_changed, f_changed, bad, drift = scan_ice(
            st.thickness, st.flags, self._h_seen, self._flags_seen, self._h_checked, RECHECK,
            self._changed)
        cats = self.categories is not None
        if cats and self._cats_changed:  # fractions alone may have changed: every element
            h_changed = True
            nc = st.n
        if not nc:
            return
        if bad >= 0:
            raise StabilityError(
                f"{who} set the thickness of element {bad} to {st.thickness[bad]!r} m at t = "
                f"{self._sim.time:g} s; a thickness must stay finite and positive (melt an "
                "element with ctx.melt instead)")
        # the stable step moves with the thickness (mass, stiffness): checked again once some
        # element's thickness has changed by more than RECHECK since the last check
        if cats:  # the mass also moves with the concentration
            v = ice_per_area(st.thickness, self.categories)
            drift = drift or bool((np.abs(v - self._v_checked) > RECHECK * self._v_checked).any())
        self.refresh(check=h_changed and drift, who=who,
                     elements=self._changed[:nc] if not cats and few(nc, st.n) else None,
                     flags=f_changed)

    def refresh(self, check: bool = True, who: str = "", elements: np.ndarray | None = None,
                flags: bool = True) -> None:
        """Mass, inertia and the contact model's constants from the thickness and flags; then
        (``check``) the stable step. ``elements``: only these changed (``None``: any may
        have); ``flags``: whether a flag may have changed."""
        sim = self._sim
        st = sim.state
        # every element at the first refresh (before it, the values are the set-up's) and in a
        # scene with categories (the mass follows the ice volume per area, module docstring)
        full = elements is None or not self._followed or self.categories is not None
        self._followed = True
        if full:
            elements = self._changed[:0]
        if self.categories is None:
            follow_elements(elements, len(elements), full, st.thickness, st.flags, self.rho,
                            st.area, self.J, st.m, st.I, self._h_seen, self._flags_seen)
        else:
            v = ice_per_area(st.thickness, self.categories)  # [m], the concentration counted
            np.multiply(self.rho * v, st.area, out=st.m)
            np.multiply(self.rho * v, self.J, out=st.I)
            self._h_seen[:] = st.thickness
            self._flags_seen[:] = st.flags
        self._cats_changed = False
        if sim.contacts is not None:
            sim.contacts.ice_changed(None if full else elements, flags)
        if check:
            sim.check_time_step(after=f"{who} changed the ice")
            self._h_checked[:] = st.thickness
            self._v_checked[:] = ice_per_area(st.thickness, self.categories)

    def melt(self, elements: np.ndarray) -> int:
        """Flag ``elements`` as melted (module docstring); returns how many were not already."""
        sim = self._sim
        st = sim.state
        k = np.asarray(elements, dtype=np.int64).reshape(-1)
        k = k[st.flags[k] != MELTED]
        if not len(k):
            return 0
        st.flags[k] = MELTED
        st.V[k] = 0.0
        st.w[k] = 0.0
        if sim.contacts is not None:
            sim.contacts.remove_elements(k, sim.time)
        return len(k)


def apply_processes(sim: "Run") -> None:
    """The processes due at this step, in scene order, then what their changes imply
    (:meth:`IceBook.after_processes`)."""
    ran = []
    for proc, every in zip(sim.processes, sim._process_every):
        if sim.step_index % every == 0:
            before = sim.ice.before_process()
            proc.apply(sim.context, every * sim.dt)
            sim.ice.after_process(before, f"process '{proc.name}'")
            ran.append(f"process '{proc.name}'")
    if ran:
        sim.ice.after_processes(" and ".join(ran))


def process_schedule(every: float | None, dt: float, where: str) -> int:
    """Steps between two applications of a process that runs ``every`` [s] (``None``: every
    step); ``every`` must be a whole number of steps (to 1e-9)."""
    if every is None:
        return 1
    k = every / dt
    n = int(round(k))
    if n < 1 or abs(k - n) > 1e-9 * max(1.0, k):
        raise SceneError(f"{where}: every = {every:g} s is not a whole number of steps of "
                         f"dt = {dt:g} s; give a multiple of dt")
    return n


#: the per-element field declarations lived here before the catalogue (siku_core.fields)
__getattr__ = moved_names(__name__, dict.fromkeys(
    ("ElementField", "GRID_REDUCTIONS", "RESERVED_FIELDS", "STANDARD_NAMES"), "siku_core.fields"))
