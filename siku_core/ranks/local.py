"""A rank's engine: the run's components over the elements it holds (owned and ghosts).

Local arrays keep the elements in ascending global index, and the joints in the order of the
run's joint table, so every element's contacts come in the same order as on one rank: the
engine sums an element's forcing, then its joints by ascending joint index, then its candidate
pairs by ascending pair key (``siku_core.contact.contact_forces.gather_forces``), and restricting
those lists
to a subset of elements keeps their order. An owned element has all its contacts here (its
partners are ghosts, ``siku_core.ranks.ghosts``), so its force is the one-rank force bit for
bit.

What is not a function of the local elements alone is taken from the run: the skin (a mean
over every element), the joints' rest lengths and state, and the dampers' bound of a ghost
(its count of intact joints, ``siku_core.contact.damping.mobility``), which its owner sends every
step.

The ice that processes change (thickness, mass, inertia, flags, thickness categories) and the
per-element fields components own come with the elements: a rank's engine has its own ice book
(``siku_core.ice.IceBook``) over its elements, whose rows are the run's, and its own copies of
the element-local processes, which change its owned elements and its ghosts alike (an element
changes by itself, so a ghost changes as on its owner, bit for bit).
"""
from __future__ import annotations

import copy
from dataclasses import fields
from typing import Any

import numpy as np

from ..categories import Categories
from ..contact.contact_model import ContactModel
from ..contact.contacts_view import ContactsView
from ..context import Context
from ..errors import PluginError
from ..ice import IceBook
from ..state import MELTED, ElementState

#: the pass of a step's breaks that come after every component's checks (the law's)
LAST_PASS = 1 << 30
#: the joint arrays a rank's engine takes from the run's joint table (the rest it derives);
#: a refrozen joint's rest state (``ends_j``, ``L0``) is where it refroze
JOINT_STATE = ("L0", "ends_j", "width", "intact", "break_mode", "break_time", "hist")


def sub_state(st: ElementState, ids: np.ndarray) -> ElementState:
    """The elements ``ids`` (ascending) of ``st``, with their polygons (copies)."""
    counts = np.diff(st.vert_offsets)[ids]
    off = np.zeros(len(ids) + 1, dtype=st.vert_offsets.dtype)
    np.cumsum(counts, out=off[1:])
    rows = np.repeat(st.vert_offsets[ids], counts) + (np.arange(off[-1]) - np.repeat(off[:-1],
                                                                                     counts))
    parts: dict[str, Any] = {}
    for f in fields(st):
        if f.name == "vert_offsets":
            parts[f.name] = off
        elif f.name == "verts":
            parts[f.name] = st.verts[rows]
        else:
            parts[f.name] = np.array(getattr(st, f.name)[ids])
    return ElementState(**parts)


class RankContacts(ContactModel):
    """The contact model of a rank: its joints given (a subset of the run's, in the run's
    order), the run's skin, and the ghosts' damper bounds set from outside."""

    def __init__(self, *args, joints: dict[str, np.ndarray], skin: float, nmax: int,
                 ghost_rows: np.ndarray, **kwargs):
        self._given = joints
        super().__init__(*args, **kwargs)
        self.skin = skin
        self.radii = self.state.radius / self.radius + 0.5 * skin
        self.nmax = nmax
        #: local rows of the ghosts, and their ``(n/m, n/I) / phi`` from their owners
        self.ghost_rows = ghost_rows
        self.ghost_dmob = np.zeros((len(ghost_rows), 2))
        #: per local joint: whether this rank reports it (owns its first element)
        self.reports = np.ones(self.n_joints, dtype=bool)
        #: the rank's place in the run (:class:`RankLink`), set by :func:`local_engine`
        self.link: RankLink | None = None
        #: the pass of a step's checks in which joints break now (:class:`WholeJoints` sets
        #: 1, 2, ...; :data:`LAST_PASS` otherwise): one rank logs a step's breaks pass by
        #: pass, in joint order within each, and the ranks' logs are merged by the same keys
        self.break_pass = LAST_PASS
        #: the local joints that broke or refroze since the driver last took them, in the
        #: order they did (:meth:`take_changes`), the breaks with their pass
        self._broke: list[tuple[int, np.ndarray]] = []
        #: the pairs and their flags of the step's committing evaluation, kept once a later
        #: evaluation of the same step begins (:meth:`add`); ``None``: those of now
        self._committed_pairs: tuple[np.ndarray, np.ndarray] | None = None
        self._refroze: list[np.ndarray] = []
        #: the batch of the joints created now (the driver sets the index of the process it
        #: applies): one rank numbers created joints batch after batch, by pair key within one
        self.create_batch = 0
        #: per local joint created since the rank's engine was built: its batch
        self.created_batch = np.zeros(0, np.int64)

    def add(self, t, q, V, w, F, T, commit: bool) -> None:
        # a later evaluation of the step (a multi-stage integrator) rewrites the pairs' contact
        # flags: the committing evaluation's are kept first, the ones one rank counts in its
        # diagnostics (``ContactModel.n_overlap``)
        if commit:
            self._committed_pairs = None
        elif self._committed_pairs is None:
            self._committed_pairs = (self.pairs, self.pair_active.copy())
        super().add(t, q, V, w, F, T, commit)

    def committed_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """The candidate pairs and their contact flags (``pair_active``) as the step's
        committing evaluation left them."""
        return self._committed_pairs or (self.pairs, self.pair_active)

    def _record_breaks(self, t: float) -> None:
        new = np.flatnonzero(~self.intact & np.isnan(self.break_time))
        super()._record_breaks(t)
        if len(new):
            self._broke.append((self.break_pass, new))

    def refreeze_joints(self, k: np.ndarray, t: float) -> int:
        k = np.asarray(k, dtype=np.int64).reshape(-1)
        was = ~self.intact[k]
        n = super().refreeze_joints(k, t)
        done = np.unique(k[was & self.intact[k]])
        if len(done):
            self._refroze.append(done)
        return n

    def create_joints(self, pairs: np.ndarray, ends_i: np.ndarray) -> np.ndarray:
        """New joints as on one rank (:meth:`JointBook.create_joints`), at the end of the
        rank's joint table; this rank reports those whose first element it owns, and notes
        their batch (:attr:`create_batch`) for the driver to number them in the run's."""
        new = super().create_joints(pairs, ends_i)
        if len(new):
            own = np.ones(self.state.n, dtype=bool)
            own[self.ghost_rows] = False
            self.reports = np.concatenate([self.reports, own[self.ji[new]]])
            self.created_batch = np.concatenate(
                [self.created_batch, np.full(len(new), self.create_batch, np.int64)])
        return new

    def take_changes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The local joints that broke since the last call (each once, ascending), the pass
        in which each broke (:attr:`break_pass`) and the joints whose state changed (broke or
        refroze, ascending)."""
        z = np.zeros(0, np.int64)
        joints = np.concatenate([b for _, b in self._broke]) if self._broke else z
        passes = np.concatenate([np.full(len(b), p, np.int64) for p, b in self._broke]) \
            if self._broke else z
        broke, first = np.unique(joints, return_index=True)
        both = [b for _, b in self._broke] + self._refroze
        changed = np.unique(np.concatenate(both)) if both else z
        self._broke, self._refroze = [], []
        return broke, passes[first], changed

    def _build_joints(self) -> None:
        g = self._given
        nh = len(self.law.history_names)
        self._set_joints(g["pairs"], g["ends_i"], g["ends_j"], nh)
        for name in JOINT_STATE:
            getattr(self, name)[...] = g[name]
        self.jedge[...] = g["jedge"]  # (a created joint's is -1, not found from its ends)

    def damping_mobility(self) -> np.ndarray:
        d = super().damping_mobility()
        if len(self.ghost_rows):
            d[self.ghost_rows] = self.ghost_dmob
        return d

    def own_mobility(self) -> np.ndarray:
        """``(n/m, n/I) / phi`` from the local joints, exact in the rows of owned elements (all
        their joints are here): the engine's array, kept until the joints or the ice change
        (:meth:`ContactModel.damping_mobility`; a ghost's row may hold its owner's bound)."""
        return super().damping_mobility()


class RankContactsView(ContactsView):
    """The contacts a component sees on a rank
    (:class:`~siku_core.contact.contacts_view.ContactsView`
    of the rank's engine): its joints and candidate pairs are those of the elements the rank
    holds, in local indices (ascending global ones). A joint or pair with an element the rank
    owns is there with every contact of that element, as on one rank.

    The actions act on the rank's joints, each rank alike on the joints it shares (decided
    from the same inputs), and the engine applies them once to the run's joint table, in
    joint order. ``break_joints`` and ``refreeze_joints`` return how many of the joints they
    acted on this rank *reports* (those whose first element it owns): summed over the ranks,
    each joint is counted once (:meth:`n_reported` counts the joints a process created).
    Floe labels are the whole run's (:meth:`floe_labels`). :meth:`create_joints` creates the
    joints in the rank's engine, as every rank holding both elements of a pair does alike
    (deciding from the same inputs), and the driver numbers them in the run's joint table as
    one rank numbers them: after the joints there, batch by batch (the processes in their
    order), by pair key within a batch; a process that creates joints on ranks gives them in
    ascending pair key (``min(i, j) n + max(i, j)``, the order of the candidate pairs) in one
    call per step."""

    __slots__ = ()

    def _reported(self, k: np.ndarray, before: np.ndarray, after: np.ndarray) -> int:
        done = np.unique(k[before != after])
        return int(np.count_nonzero(self._model.reports[done]))

    def break_joints(self, k: np.ndarray, mode, t: float) -> int:
        k = np.asarray(k, dtype=np.int64).reshape(-1)
        before = self._model.intact[k].copy()
        self._model.break_joints(k, mode, t)
        return self._reported(k, before, self._model.intact[k])

    def refreeze_joints(self, k: np.ndarray, t: float) -> int:
        k = np.asarray(k, dtype=np.int64).reshape(-1)
        before = self._model.intact[k].copy()
        self._model.refreeze_joints(k, t)
        return self._reported(k, before, self._model.intact[k])

    def n_reported(self, k: np.ndarray) -> int:
        k = np.unique(np.asarray(k, dtype=np.int64).reshape(-1))
        return int(np.count_nonzero(self._model.reports[k]))

    def floe_labels(self) -> tuple[int, np.ndarray]:
        """The floes of the whole run (:class:`WholeJoints`: the run's joint table, with the
        state of the joints this rank holds as it is now): ``(count, label)`` over the run's
        floes, ``label`` of the elements this rank holds, so that a floe over several ranks
        has one label on each, numbered by global identities as on one rank."""
        model = self._model
        link = model.link
        whole = WholeJoints(link)
        whole.intact[link.jg] = model.intact[:len(link.jg)]
        count, label = whole.floe_labels()
        return count, label[link.ids]


class RankLink:
    """A rank's place in the run, for the components of its engine
    (``siku_core.component.Component.setup_on_rank``): the run's context (``run``, set up
    over every element), the global indices of the elements the rank holds (``ids``,
    ascending) and of its joints (``jg``), which of its rows it owns (``own_rows``), and the
    two collective exchanges a component may make within its step: :meth:`whole` (every
    element's rows from their owners) and :meth:`to_ghosts` (owners' rows to the ranks
    holding them as ghosts). Every rank calls them alike, in the same order.

    Without ``comm`` (a check in one process, ``siku_core.testing.process_checks``) the
    link holds no other rank: :meth:`whole` needs every element held, :meth:`to_ghosts` no
    ghost."""

    def __init__(self, glob, ids: np.ndarray, own_rows: np.ndarray, comm=None,
                 send_rows: list[np.ndarray] | None = None,
                 recv_rows: list[np.ndarray] | None = None):
        #: the run's context, and its contact model (the whole joint table)
        self.run = glob.context
        self.run_contacts = glob.contacts
        #: the contact model of the rank's engine (set by :func:`local_engine`)
        self.contacts: RankContacts | None = None
        self.n = glob.state.n
        self.ids = ids
        self.own_rows = own_rows
        self.ghost_rows = np.setdiff1d(np.arange(len(ids)), own_rows)
        self.jg = np.zeros(0, dtype=np.int64)
        self.comm = comm
        self.send_rows, self.recv_rows = send_rows or [], recv_rows or []

    @property
    def rank(self) -> int:
        return 0 if self.comm is None else self.comm.rank

    def whole(self, *arrays: np.ndarray) -> list[np.ndarray]:
        """Each of ``arrays`` (first axis: the elements the rank holds) as the run's (first
        axis: every element), each row from its element's owner. Collective."""
        own = self.own_rows
        mine = (self.ids[own], [np.asarray(a)[own] for a in arrays])
        if self.comm is None:
            if len(own) != self.n:
                raise PluginError("gathering every element needs the ranks of a run")
            got = [mine]
        else:
            got = self.comm.allgather(mine)
        out = []
        for k, a in enumerate(arrays):
            a = np.asarray(a)
            w = np.empty((self.n,) + a.shape[1:], dtype=a.dtype)
            for ids, rows in got:
                w[ids] = rows[k]
            out.append(w)
        return out

    def to_ghosts(self, *arrays: np.ndarray) -> None:
        """The owners' rows of each of ``arrays`` (first axis: the elements the rank holds)
        to the ranks holding them as ghosts, in place. Collective."""
        if self.comm is None:
            if len(self.ghost_rows):
                raise PluginError("exchanging ghosts' rows needs the ranks of a run")
            return
        out = []
        for s, rows in enumerate(self.send_rows):
            out.append(None if s == self.comm.rank or not len(rows)
                       else [np.asarray(a)[rows] for a in arrays])
        got = self.comm.alltoall(out)
        for s, rows in enumerate(self.recv_rows):
            if got[s] is None or not len(rows):
                continue
            for a, v in zip(arrays, got[s]):
                a[rows] = v


class WholeJoints:
    """The run's joints as a component on a rank reads them whole (a floe spans ranks): the
    run's joint table (``ji``, ``jj``, ``intact`` (a copy), ``youngs_modulus``,
    ``joint_lines``, ``floe_labels``) over every element. :meth:`break_joints` breaks the
    joints here and, through ``link``, the rank's copies of those it holds (its engine records
    and reports them as it does the law's breaks). The run's table is current as of the end
    of the last step on every rank alike, so every rank labels the same floes, by global
    identities."""

    def __init__(self, link: RankLink):
        run = link.run_contacts
        self._run, self._link = run, link
        self.state = run.state
        self.ji, self.jj = run.ji, run.jj
        self.intact = np.array(run.intact, copy=True)
        self.n_joints, self.joint_slots = run.n_joints, run.joint_slots
        self.youngs_modulus = link.run.contacts.youngs_modulus  # [Pa] (the run's view)
        #: how many times joints were broken here (the passes of a check)
        self.passes = 0

    def joint_lines(self, q: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        return self._run.joint_lines(q)

    def floe_labels(self) -> tuple[int, np.ndarray]:
        return type(self._run).floe_labels(self)  # (of these flags)

    def break_joints(self, k: np.ndarray, mode, t: float) -> int:
        k = np.asarray(k, dtype=np.int64).reshape(-1)
        k = k[self.intact[k]]
        self.intact[k] = False
        jg = self._link.jg
        at = np.minimum(np.searchsorted(jg, k), max(len(jg) - 1, 0))
        held = at[jg[at] == k] if len(jg) else at[:0]
        self.passes += 1
        if len(held):
            lc = self._link.contacts
            lc.break_pass = self.passes
            try:
                lc.break_joints(held, mode, t)
            finally:
                lc.break_pass = LAST_PASS
        return len(k)


def local_ice(glob, loc, ids: np.ndarray) -> IceBook:
    """The ice book of the rank's engine ``loc``: the rows ``ids`` of the run's declared
    fields, thickness categories and polygons' polar moments (taken, not recomputed from the
    masses: the same bits as the run's)."""
    gi = glob.ice
    cats = gi.categories
    sub = None if cats is None else Categories(fraction=cats.fraction[ids].copy(),
                                               thickness=cats.thickness[ids].copy())
    ice = IceBook(loc, processes=gi.processes, categories=sub)
    for name, values in gi.values.items():
        ice.values[name][...] = values[ids]
    if gi.processes:
        ice.J = gi.J[ids].copy()
        ice._h_checked = gi._h_checked[ids].copy()
        ice._v_checked = gi._v_checked[ids].copy()
    return ice


def local_engine(glob, ids: np.ndarray, ghost_rows: np.ndarray,
                 link: RankLink | None = None) -> tuple[Any, np.ndarray]:
    """A shallow copy of the run ``glob`` (a ``Simulation``) whose state, contacts, ice book,
    forcing sources, integrator and processes hold the elements ``ids`` (ascending global
    indices); ``ghost_rows`` are the local rows of ghosts; ``link`` the rank's place in the
    run (default: one without other ranks). Each forcing's field is the run's as the rank
    evaluates it (``Field.on_rank``), and each component is set up by its ``setup_on_rank``
    from the run's copy. Returns it and the run's indices of its joints."""
    if link is None:
        link = RankLink(glob, ids, np.setdiff1d(np.arange(len(ids)), ghost_rows))
    loc = copy.copy(glob)
    loc.state = sub_state(glob.state, ids)
    loc.context = Context(loc, RankContactsView)
    loc.writers = []
    loc.pm = None
    loc.forcing = [copy.copy(f) for f in glob.forcing]
    loc.integrator = copy.copy(glob.integrator)
    loc.processes = [copy.copy(p) for p in glob.processes]
    jg = np.zeros(0, dtype=np.int64)
    gc = glob.contacts
    if gc is not None:
        held = np.zeros(glob.state.n, dtype=bool)
        held[ids] = True
        jg = np.flatnonzero(held[gc.ji] & held[gc.jj])
        at = np.searchsorted(ids, np.stack([gc.ji[jg], gc.jj[jg]], axis=1))
        joints = {"pairs": at.astype(np.int64), "ends_i": gc.ends_i[jg], "jedge": gc.jedge[jg],
                  **{k: getattr(gc, k)[jg] for k in JOINT_STATE}}
        scene = glob.scene
        loc.contacts = RankContacts(
            scene.cfg.contact, loc.state, glob.radius, list(scene.cfg.materials.values()),
            law=gc.law, broad=gc.broad, time_step=lambda: glob.dt,
            where=scene.where("contact"), label=scene.label, timings=glob.timings,
            joints=joints, skin=gc.skin, nmax=gc.nmax, ghost_rows=ghost_rows)
        loc.contacts.n_broken_total = 0
        # room for the joints processes may create, as many as the run has left
        loc.contacts.reserve_joints(gc.joint_slots - gc.n_joints)
        gone = loc.state.flags == MELTED
        if gone.any():  # melted elements touch nothing (as ``ContactModel.ice_changed``)
            loc.contacts.gone = gone
        loc.contacts.setup()
    link.jg = jg
    link.contacts = loc.contacts
    if loc.contacts is not None:
        loc.contacts.link = link
    loc.ice = local_ice(glob, loc, ids)
    for f, run in zip(loc.forcing, glob.forcing):  # the run's fields as the rank evaluates them
        if run.field is not None:
            f.field = run.field.on_rank(loc.context, link)
    for comp, run in zip([*loc.forcing, loc.integrator, *loc.processes],
                         [*glob.forcing, glob.integrator, *glob.processes]):
        comp.setup_on_rank(loc.context, run, link)
    for name, values in glob.ice.values.items():  # the carried values, not a set-up's start
        loc.ice.values[name][...] = values[ids]
    return loc, jg


__all__ = ["JOINT_STATE", "RankContacts", "RankContactsView", "RankLink", "WholeJoints",
           "local_engine", "local_ice", "sub_state"]
