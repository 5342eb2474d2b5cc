"""What a component sees of the contacts: a typed, read-only view of the contact model.

``ctx.contacts`` is a :class:`ContactsView` (``None`` in a scene without a ``[contact]``
table). It offers the two tables of the contact phase as read-only numpy views, the law's name
and parameters, a few reads computed from the current state, and the few actions a component
may take. Everything else of :class:`~siku_core.contact.contact_model.ContactModel` (the candidate
list's scratch, the loops' rows, rotation matrices, skins, hints) is the engine's, so that the
engine may change it (and, on many ranks, split it) without breaking a plugin.

==================  =====================================================================
joint table         ``n_joints``, ``n_intact``, ``joint_slots``; per joint ``ji``, ``jj``
                    (its elements), ``ends_i``, ``ends_j`` [m], ``width`` [m],
                    ``rest_distance`` [m], ``intact``, ``break_mode``, ``break_time`` [s],
                    ``joint_history`` (the law's rows, columns ``joint_history_names``),
                    ``joint_stiffness`` [Pa], ``joint_reduced_mass`` [kg]
pair table          ``n_pairs``, ``n_overlapping``; per candidate pair ``pairs``,
                    ``pair_active``, ``pair_capped``; per element ``pair_offsets``,
                    ``pair_index`` (its candidate pairs)
law and materials   ``law_name``, ``law_params``, ``law_uses_joints``; per element
                    ``youngs_modulus`` [Pa], ``poisson_ratio`` [1]
reads               ``joint_lines(q)``, ``joint_midpoints(k)``, ``joint_gaps(k)``,
                    ``joint_tension(k)``, ``floe_labels()``, ``contact_lines(ks)``
actions             ``break_joints(k, mode, t)``, ``refreeze_joints(k, t)``,
                    ``create_joints(pairs, ends_i)`` and ``n_reported(k)`` (processes),
                    ``keep_caps()`` (the law's cap flags, for ``pair_capped``),
                    ``take_breaks()`` (writers)
==================  =====================================================================

Every array is a view of the engine's current one, made read-only (``arr.flags.writeable`` is
False): read it again after the engine may have replaced it (the candidate list is rebuilt
during a step; creating joints lengthens the joint table). A component changes contacts only
through the actions. Reading an attribute of the model that is not a member here still works
for now, with a :class:`DeprecationWarning` naming the member to use.

On MPI ranks a component sees the view of its rank's engine
(:class:`siku_core.ranks.local.RankContactsView`): the joints and candidate pairs of the
elements that rank holds, in local indices; its actions count the joints the rank reports,
``create_joints`` creates them in the rank's engine (the engine numbers them in the run's
joint table as one rank does), and ``floe_labels`` labels the whole run's floes
(``docs/howto/processes.md``).
"""
from __future__ import annotations

import warnings
from collections.abc import Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import PluginError

if TYPE_CHECKING:  # pragma: no cover
    from ..contact_law import BreakMode
    from .contact_model import ContactModel


def _read_only(a: np.ndarray) -> np.ndarray:
    """A view of ``a`` that cannot be written through."""
    v = a.view()
    v.flags.writeable = False
    return v


#: model attributes a component read before the view, and what to read instead
RENAMED = {
    "E": "youngs_modulus", "nu": "poisson_ratio", "L0": "rest_distance",
    "hist": "joint_history", "jK": "joint_stiffness", "jmeff": "joint_reduced_mass",
    "poff": "pair_offsets", "pidx": "pair_index", "n_overlap": "n_overlapping",
    "law": "law_name, law_params or law_uses_joints", "radius": "ctx.radius",
}


class ContactsView:
    """The contacts of a run as a component sees them (module docstring): read-only tables of
    joints and candidate pairs, and the actions a component may take."""

    __slots__ = ("_model",)

    def __init__(self, model: "ContactModel"):
        self._model = model

    def __repr__(self) -> str:
        m = self._model
        return (f"<siku ContactsView: law '{m.law.name}', {m.n_intact} of {m.n_joints} joints "
                f"intact, {len(m.pairs)} candidate pairs>")

    def views(self, model: "ContactModel") -> bool:
        """Whether this is the view of ``model``."""
        return self._model is model

    # ------------------------------------------------------------------ law and materials
    @property
    def law_name(self) -> str:
        """The name of the scene's contact law."""
        return self._model.law.name

    @property
    def law_params(self) -> Mapping[str, Any]:
        """The contact law's parameters (read-only mapping, units as the law declares them)."""
        return MappingProxyType(self._model.law.p)

    @property
    def law_uses_joints(self) -> bool:
        """Whether the contact law has joints (a process may then create some)."""
        return bool(self._model.law.uses_joints)

    @property
    def joint_history_names(self) -> tuple[str, ...]:
        """The columns of :attr:`joint_history`, as the law names them."""
        return tuple(self._model.law.history_names)

    @property
    def youngs_modulus(self) -> np.ndarray:
        """Per element: Young's modulus of its material [Pa]."""
        return _read_only(self._model.E)

    @property
    def poisson_ratio(self) -> np.ndarray:
        """Per element: Poisson's ratio of its material [1]."""
        return _read_only(self._model.nu)

    # ------------------------------------------------------------------ joint table
    @property
    def n_joints(self) -> int:
        """Joints of the run now (built at set-up and created since)."""
        return self._model.n_joints

    @property
    def n_intact(self) -> int:
        """Joints intact now."""
        return self._model.n_intact

    @property
    def joint_slots(self) -> int:
        """The most joints the run can hold: those built at set-up plus the slots reserved for
        the joints processes create (``Process.joints_to_create``); size per-joint arrays by
        it."""
        return self._model.joint_slots

    @property
    def ji(self) -> np.ndarray:
        """Per joint: its first element (int64 index)."""
        return _read_only(self._model.ji)

    @property
    def jj(self) -> np.ndarray:
        """Per joint: its second element (int64 index)."""
        return _read_only(self._model.jj)

    @property
    def ends_i(self) -> np.ndarray:
        """Per joint: its two ends in the tangent frame of ``ji`` [m] ``(n_joints, 2, 2)``,
        running counter-clockwise round ``ji``."""
        return _read_only(self._model.ends_i)

    @property
    def ends_j(self) -> np.ndarray:
        """Per joint: the same two ends in the tangent frame of ``jj`` [m], where they were when
        the joint froze ``(n_joints, 2, 2)``."""
        return _read_only(self._model.ends_j)

    @property
    def width(self) -> np.ndarray:
        """Per joint: its length along the shared edge [m]."""
        return _read_only(self._model.width)

    @property
    def rest_distance(self) -> np.ndarray:
        """Per joint: the distance of the two element centres at rest [m] (along the sphere)."""
        return _read_only(self._model.L0)

    @property
    def intact(self) -> np.ndarray:
        """Per joint: whether it holds (bool)."""
        return _read_only(self._model.intact)

    @property
    def break_mode(self) -> np.ndarray:
        """Per joint: how it broke, the int8 code of
        :class:`~siku_core.contact_law.BreakMode` (0 while intact)."""
        return _read_only(self._model.break_mode)

    @property
    def break_time(self) -> np.ndarray:
        """Per joint: the model time of its break [s] (NaN while intact)."""
        return _read_only(self._model.break_time)

    @property
    def joint_history(self) -> np.ndarray:
        """Per joint: the law's history row ``(n_joints, H)``, columns
        :attr:`joint_history_names` (units as the law declares them)."""
        return _read_only(self._model.hist)

    def set_joint_history(self, name: str, values) -> None:
        """Set the column ``name`` (one of :attr:`joint_history_names`) of every joint's
        history row to ``values`` (one per joint): a process giving the joints their own
        properties at set-up (``joint_strength``: each joint's log strength factor)."""
        names = self.joint_history_names
        if name not in names:
            raise PluginError(f"contact law '{self._model.law.name}' has no joint history "
                              f"column {name!r} (it has {', '.join(names) or 'none'})")
        n = self._model.n_joints
        self._model.hist[:n, names.index(name)] = np.asarray(values, float)

    @property
    def joint_stiffness(self) -> np.ndarray:
        """Per joint: the eq. 9 stiffness ``K`` [Pa] (force per joint length per opening,
        :func:`~siku_core.contact.contact_frames.eq9_stiffness`), of the current thickness."""
        return _read_only(self._model.jK)

    @property
    def joint_reduced_mass(self) -> np.ndarray:
        """Per joint: the reduced mass ``1 / (1/m_i + 1/m_j)`` of its elements [kg]."""
        return _read_only(self._model.jmeff)

    # ------------------------------------------------------------------ pair table
    @property
    def n_pairs(self) -> int:
        """Candidate pairs now (the broad phase's list, reused within its skin)."""
        return len(self._model.pairs)

    @property
    def n_overlapping(self) -> int:
        """Candidate pairs that overlapped at the last committed force evaluation."""
        return int(self._model.n_overlap)

    @property
    def pairs(self) -> np.ndarray:
        """The candidate pairs: element indices, int64 ``(n_pairs, 2)``."""
        return _read_only(self._model.pairs)

    @property
    def pair_active(self) -> np.ndarray:
        """Per candidate pair (int8): 1 where it overlapped and carried force at the last
        force evaluation, 2 where it touched without force (``touching = "ignore"``), else 0."""
        return _read_only(self._model.pair_active)

    @property
    def pair_capped(self) -> np.ndarray:
        """Per candidate pair (int8): 1 where the law capped its normal force when it last
        overlapped (the law's ``out[3]``), else 0; empty until :meth:`keep_caps`."""
        return _read_only(self._model.pair_capped)

    @property
    def pair_offsets(self) -> np.ndarray:
        """Per element ``e`` (``n + 1``, int64): its candidate pairs are
        ``pair_index[pair_offsets[e]:pair_offsets[e + 1]]``."""
        return _read_only(self._model.poff)

    @property
    def pair_index(self) -> np.ndarray:
        """The candidate pairs of each element, in the order :attr:`pair_offsets` gives
        (indices into :attr:`pairs`, int64)."""
        return _read_only(self._model.pidx)

    # ------------------------------------------------------------------ reads
    def joint_lines(self, q: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """Where every joint is for state ``q`` (default: the current one): midpoint latitude
        and longitude [rad] and the unit direction of its edge ``(east, north)`` [1], five
        arrays of ``n_joints`` (a new array each)."""
        return self._model.joint_lines(q)

    def joint_midpoints(self, k: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Latitude and longitude [deg] ``(len(k), 2)`` of the midpoints of joints ``k``."""
        return self._model.joint_midpoints(k, q)

    def joint_gaps(self, k: np.ndarray) -> np.ndarray:
        """How far apart the two sides of joints ``k`` are now [m] (0 where they are where the
        joint froze)."""
        return self._model.joint_gaps(k)

    def joint_tension(self, k: np.ndarray) -> np.ndarray:
        """Normal traction of intact joints ``k`` at the last force evaluation [Pa], tension
        positive (force over the joint's length and the thinner side's thickness)."""
        return self._model.joint_tension(k)

    def floe_labels(self) -> tuple[int, np.ndarray]:
        """Floes as the connected groups of elements over intact joints: ``(count, label)``,
        ``label[element]`` in ``0..count-1``."""
        return self._model.floe_labels()

    def contact_lines(self, ks: np.ndarray) -> np.ndarray:
        """The lines ``(len(ks), 2, 2)`` [m] along which the outlines of candidate pairs ``ks``
        cross in the current state, in the first element's frame, running counter-clockwise
        round it (:func:`~siku_core.contact.contact_overlaps.contact_lines`): the ``ends_i`` of
        :meth:`create_joints`."""
        from .contact_overlaps import contact_lines

        return contact_lines(self._model, ks)

    # ------------------------------------------------------------------ actions
    def break_joints(self, k: np.ndarray, mode: "BreakMode | int", t: float) -> int:
        """Break intact joints ``k`` with ``mode`` (a :class:`~siku_core.contact_law.BreakMode`
        or its code) at model time ``t`` [s]: they carry no force from the next evaluation on.
        Returns how many broke."""
        return self._model.break_joints(k, mode, t)

    def refreeze_joints(self, k: np.ndarray, t: float) -> int:
        """Broken joints ``k`` freeze again, at rest where their sides are now (model time
        ``t`` [s]). Returns how many refroze."""
        return self._model.refreeze_joints(k, t)

    def create_joints(self, pairs: np.ndarray, ends_i: np.ndarray) -> np.ndarray:
        """New intact joints between element pairs ``pairs`` ``(K, 2)`` along the lines
        ``ends_i`` ``(K, 2, 2)`` [m] (first element's frame, counter-clockwise round it), at
        rest where the elements are now, in the slots a process reserved
        (``joints_to_create``). Returns their indices."""
        return self._model.create_joints(pairs, ends_i)

    def n_reported(self, k: np.ndarray) -> int:
        """How many of joints ``k`` (distinct indices) this view reports: every one on one
        rank; on MPI ranks those whose first element the rank owns, so that a count summed
        over the ranks counts each joint once (what a process adds to a count it keeps for
        the joints it creates)."""
        return int(np.asarray(k).size)

    def keep_caps(self) -> None:
        """From now on keep, per candidate pair, whether the law capped its normal force
        (:attr:`pair_capped`)."""
        self._model.keep_caps()

    def take_breaks(self) -> dict[str, np.ndarray]:
        """The breaks since the last call, in the order they happened (for a writer: each
        break is taken once): ``time`` [s], ``joint``, ``i``, ``j``, ``lat``, ``lon`` [deg] of
        the joint's midpoint, ``mode`` (int8 code)."""
        return self._model.take_breaks()

    # ------------------------------------------------------------------ deprecated reads
    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        model = self._model
        if not hasattr(model, name):
            raise AttributeError(f"the contacts view has no member '{name}' (see "
                                 "siku_core.contact.contacts_view.ContactsView)")
        use = RENAMED.get(name)
        hint = (f"use ctx.contacts.{use}" if use and not use.startswith("ctx.")
                else f"use {use}" if use else
                "the contacts view (siku_core.contact.contacts_view.ContactsView) has no member "
                "for it")
        warnings.warn(f"ctx.contacts.{name} reads the contact model's internals and is "
                      f"deprecated: {hint}", DeprecationWarning, stacklevel=2)
        return getattr(model, name)


#: the members of the view (what a component may read and do)
MEMBERS = frozenset(n for n in vars(ContactsView) if not n.startswith("_"))


__all__ = ["MEMBERS", "RENAMED", "ContactsView"]
