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
from ..contact.damping import contact_mobility
from ..ice import IceBook
from ..state import MELTED, ElementState

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
        #: the local joints that broke or refroze since the driver last took them, in the
        #: order they did (:meth:`take_changes`)
        self._broke: list[np.ndarray] = []
        self._refroze: list[np.ndarray] = []

    def _record_breaks(self, t: float) -> None:
        new = np.flatnonzero(~self.intact & np.isnan(self.break_time))
        super()._record_breaks(t)
        if len(new):
            self._broke.append(new)

    def refreeze_joints(self, k: np.ndarray, t: float) -> int:
        k = np.asarray(k, dtype=np.int64).reshape(-1)
        was = ~self.intact[k]
        n = super().refreeze_joints(k, t)
        done = np.unique(k[was & self.intact[k]])
        if len(done):
            self._refroze.append(done)
        return n

    def take_changes(self) -> tuple[np.ndarray, np.ndarray]:
        """The local joints that broke since the last call (each once, ascending) and those
        whose state changed (broke or refroze, ascending)."""
        broke = np.unique(np.concatenate(self._broke)) if self._broke else np.zeros(0, np.int64)
        both = self._broke + self._refroze
        changed = np.unique(np.concatenate(both)) if both else np.zeros(0, np.int64)
        self._broke, self._refroze = [], []
        return broke, changed

    def _build_joints(self) -> None:
        g = self._given
        nh = len(self.law.history_names)
        self._set_joints(g["pairs"], g["ends_i"], g["ends_j"], nh)
        for name in JOINT_STATE:
            getattr(self, name)[...] = g[name]

    def damping_mobility(self) -> np.ndarray:
        d = super().damping_mobility()
        if len(self.ghost_rows):
            d[self.ghost_rows] = self.ghost_dmob
        return d

    def own_mobility(self) -> np.ndarray:
        """``(n/m, n/I) / phi`` of every local element from the local joints (exact for an
        owned element: all its joints are here)."""
        return contact_mobility(self)


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
    each joint is counted once. Creating joints and labelling floes (which read the joints of
    every element) do not run on ranks."""

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

    def create_joints(self, pairs: np.ndarray, ends_i: np.ndarray) -> np.ndarray:
        raise PluginError("creating joints does not run on MPI ranks; run the scene on one "
                          "rank")

    def floe_labels(self) -> tuple[int, np.ndarray]:
        raise PluginError("floe labels read the joints of every element and do not run on MPI "
                          "ranks; run the scene on one rank")


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


def local_engine(glob, ids: np.ndarray, ghost_rows: np.ndarray) -> tuple[Any, np.ndarray]:
    """A shallow copy of the run ``glob`` (a ``Simulation``) whose state, contacts, ice book,
    forcing sources, integrator and processes hold the elements ``ids`` (ascending global
    indices); ``ghost_rows`` are the local rows of ghosts. Returns it and the run's indices
    of its joints."""
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
        joints = {"pairs": at.astype(np.int64), "ends_i": gc.ends_i[jg],
                  **{k: getattr(gc, k)[jg] for k in JOINT_STATE}}
        scene = glob.scene
        loc.contacts = RankContacts(
            scene.cfg.contact, loc.state, glob.radius, list(scene.cfg.materials.values()),
            law=gc.law, broad=gc.broad, time_step=lambda: glob.dt,
            where=scene.where("contact"), label=scene.label, timings=glob.timings,
            joints=joints, skin=gc.skin, nmax=gc.nmax, ghost_rows=ghost_rows)
        loc.contacts.n_broken_total = 0
        gone = loc.state.flags == MELTED
        if gone.any():  # melted elements touch nothing (as ``ContactModel.ice_changed``)
            loc.contacts.gone = gone
        loc.contacts.setup()
    loc.ice = local_ice(glob, loc, ids)
    for comp in [*loc.forcing, loc.integrator, *loc.processes]:
        comp.setup(loc.context)
    for name, values in glob.ice.values.items():  # the carried values, not a set-up's start
        loc.ice.values[name][...] = values[ids]
    return loc, jg


__all__ = ["JOINT_STATE", "RankContacts", "RankContactsView", "local_engine", "local_ice",
           "sub_state"]
