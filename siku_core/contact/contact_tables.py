"""The records the contact loops take (:mod:`siku_core.records`): the elements, the joint
table, the pair table and the element-to-contact index, declared once here, and their
producer, :class:`ContactTables`.

The loops (:mod:`siku_core.contact.contact_loops`, entry points
:func:`~siku_core.contact.contact_forces.joint_forces`,
:func:`~siku_core.contact.contact_forces.collision_forces` and
:func:`~siku_core.contact.contact_forces.gather_forces`)
take one record of each and a few scalars; a field the loops need is added to its declaration
below and to its producer's method, and to nothing in between. Each record holds the model's
own arrays (no copy): the loops write the rows, flags, histories and hints in place. A producer
builds a record at each evaluation, so a record is never stale when the model has replaced an
array (a joint created, the candidate list rebuilt).
"""
from __future__ import annotations

import numpy as np

from ..geometry.face import edge_table
from ..records import record_type

ContactElements = record_type("ContactElements", __name__, [
    ("rm", "f", 3, "rotation matrix R(q) of each element [1] "
                   "(contact_frames.rotation_matrices)"),
    ("V", "f", 2, "velocity in the element's own plane [m/s]"),
    ("w", "f", 1, "angular velocity [1/s]"),
    ("h", "f", 1, "thickness [m]"),
    ("E", "f", 1, "Young's modulus [Pa]"),
    ("nu", "f", 1, "Poisson's ratio [1]"),
    ("minv", "f", 1, "inverse mass [1/kg], 0 for a static or steady element"),
    ("area", "f", 1, "area [m^2]"),
    ("offsets", "i", 1, "vertex offsets [1]: element e's vertices are rows "
                        "offsets[e]:offsets[e+1] of verts"),
    ("verts", "f", 2, "vertices in each element's own plane [m]"),
    ("margin", "f", 1, "margin of the separating-axis test [m] (zeros: none)"),
    ("scale", "f", 1, "largest absolute vertex coordinate [m]"),
    ("edges", "f", 2, "per vertex row, the constants of its edge [1, 1, m] "
                      "(geometry.face.edge_table)"),
    ("dmob", "f", 2, "per element n/m [1/kg] and n/I [1/(kg m^2)], the dampers' bound "
                     "(siku_core.contact.damping; no rows: unbounded)"),
], "The per-element data the contact loops read.")

JointTable = record_type("JointTable", __name__, [
    ("ji", "i", 1, "first element of each joint"),
    ("jj", "i", 1, "second element"),
    ("ends_i", "f", 3, "the joint's two ends in i's plane [m], shape (K, 2, 2)"),
    ("ends_j", "f", 3, "the same ends in j's plane [m]"),
    ("L0", "f", 1, "rest length [m]"),
    ("width", "f", 1, "width [m]"),
    ("K", "f", 1, "eq. 9 stiffness [Pa]"),
    ("meff", "f", 1, "reduced mass [kg]"),
    ("intact", "b", 1, "whether the joint holds (cleared where it breaks, on commit)"),
    ("break_mode", "i", 1, "break mode code (siku_core.contact_law.BreakMode)"),
    ("hist", "f", 2, "the law's history row of each joint (history_names columns, their "
                     "units the law's)"),
    ("rows", "f", 2, "the loop's result row of each joint (ROW_*: force [N] and torque "
                     "[N m] on i and on j)"),
    ("active", "i", 1, "1 where the joint carries force"),
    ("fresh", "f", 1, "per element h E [Pa m], then per element the inverse mass a joint "
                      "counts [1/kg], from which K, meff are first computed (empty: they are "
                      "current)"),
    ("ri", "f", 1, "lever arm of the joint in i [m] (eq. 9; empty where fresh is)"),
    ("rj", "f", 1, "lever arm of the joint in j [m]"),
], "The joint table the joint loop reads and writes.")

PairTable = record_type("PairTable", __name__, [
    ("pairs", "i", 2, "the candidate pairs (i, j)"),
    ("rows", "f", 2, "the loop's result row of each pair (ROW_*: force [N] and torque [N m] "
                     "on i and on j)"),
    ("active", "i", 1, "1 overlapping, 2 touching and dropped, 0 apart"),
    ("hint", "i", 1, "the edge that separated the pair last, tried first"),
    ("face", "i", 2, "the edges of i and j a jointed pair is jointed along (-1: none)"),
    ("chist", "f", 2, "per-contact history rows (contact_history_names, their units the "
                      "law's; no columns: none)"),
    ("caps", "i", 1, "1 where the law capped the normal force (empty: not kept)"),
    ("chint", "i", 1, "crossing edges of the coherent clip (empty: the clip in full)"),
], "The candidate pairs the collision loop reads and writes.")

ContactIndex = record_type("ContactIndex", __name__, [
    ("joff", "i", 1, "element e's joints are jidx[joff[e]:joff[e+1]]"),
    ("jidx", "i", 1, "joint of each entry, ascending per element"),
    ("jside", "i", 1, "0 where the element is the joint's i, 1 where it is its j"),
    ("poff", "i", 1, "element e's candidate pairs are pidx[poff[e]:poff[e+1]]"),
    ("pidx", "i", 1, "pair of each entry, ascending per element"),
    ("pside", "i", 1, "0 where the element is the pair's i, 1 where it is its j"),
], "The element-to-contact index the gather reads (contact_frames.element_index).")

#: what a record gets for a field that is off: no fresh constants, no damper bound, no
#: per-contact history, no cap flags, no coherent clip
NO_FRESH = np.zeros(0)
NO_DMOB = np.zeros((0, 2))
NO_HISTORY = np.zeros((0, 0))
NO_CAPS = np.zeros(0, dtype=np.int8)
NO_HINTS = np.zeros(0, dtype=np.int32)


def element_table(rm, V, w, h, E, nu, minv, area, offsets, verts, margin=None, scale=None,
                  edges=None, dmob=None) -> ContactElements:
    """A :data:`ContactElements` record, with defaults: no margin, ``scale`` zero, ``edges``
    computed from ``offsets, verts``, the dampers unbounded."""
    n = offsets.shape[0] - 1
    return ContactElements(
        rm=rm, V=V, w=w, h=h, E=E, nu=nu, minv=minv, area=area, offsets=offsets, verts=verts,
        margin=np.zeros(n) if margin is None else margin,
        scale=np.zeros(n) if scale is None else scale,
        edges=edge_table(offsets, verts) if edges is None else edges,
        dmob=NO_DMOB if dmob is None else dmob)


def pair_table(pairs, rows, active, hint=None, face=None, chist=None, caps=None,
               chint=None) -> PairTable:
    """A :data:`PairTable` record, with defaults: no hints, no joint faces, no per-contact
    history, no cap flags, the clip in full."""
    k = pairs.shape[0]
    return PairTable(
        pairs=pairs, rows=rows, active=active,
        hint=np.zeros(k, dtype=np.int16) if hint is None else hint,
        face=np.full((k, 2), -1, dtype=np.int16) if face is None else face,
        chist=NO_HISTORY if chist is None else chist,
        caps=NO_CAPS if caps is None else caps,
        chint=NO_HINTS if chint is None else chint)


class ContactTables:
    """The producer of the contact loops' records, a base of
    :class:`~siku_core.contact.contact_model.ContactModel` (whose arrays they hold)."""

    def element_table(self, V: np.ndarray, w: np.ndarray) -> ContactElements:
        """The elements at velocities ``V`` [m/s], ``w`` [1/s] (the rotations ``rm`` are
        those of the last evaluation's state)."""
        st = self.state
        return ContactElements(
            rm=self.rm, V=V, w=w, h=st.thickness, E=self.E, nu=self.nu, minv=self.minv,
            area=st.area, offsets=st.vert_offsets, verts=st.verts, margin=self.margin,
            scale=self.scale, edges=self.edges, dmob=self.damping_mobility())

    def joint_table(self, fresh: bool | None = None) -> JointTable:
        """The joints; with the constants ``K``, ``meff`` to be computed first from the
        per-element ``fresh`` values where ``fresh`` (default: where the ice changed since the
        last joint loop, ``ice_changed``)."""
        if fresh is None:
            fresh = self._joints_stale
        scratch, (ri, rj) = ((self._jscratch, self.arms) if fresh
                             else (NO_FRESH, (NO_FRESH, NO_FRESH)))
        return JointTable(
            ji=self.ji, jj=self.jj, ends_i=self.ends_i, ends_j=self.ends_j, L0=self.L0,
            width=self.width, K=self._jK, meff=self._jmeff, intact=self.intact,
            break_mode=self.break_mode, hist=self.hist, rows=self.joint_rows,
            active=self.joint_active, fresh=scratch, ri=ri, rj=rj)

    def pair_table(self, pairs: np.ndarray) -> PairTable:
        """The candidate pairs ``pairs`` (the list of this evaluation) and their rows."""
        return PairTable(
            pairs=pairs, rows=self.pair_rows, active=self.pair_active,
            hint=self.separating_hint, face=self.pface,
            chist=self.chist if self.n_contact_hist else NO_HISTORY,
            caps=self.pair_capped if self.caps_kept else NO_CAPS,
            chint=self.clip_hint if len(self.clip_hint) else NO_HINTS)

    def contact_index(self) -> ContactIndex:
        """Each element's joints and candidate pairs (the gather's order)."""
        return ContactIndex(joff=self.joff, jidx=self.jidx, jside=self.jside, poff=self.poff,
                            pidx=self.pidx, pside=self.pside)
