"""The joints of the contact phase: their construction (detected shared edges or listed
pairs), their per-joint constants, and the bookkeeping of their breaks (modes, times, the
breaks a writer has not taken, restart history, floes).

:class:`JointBook` is the part of :class:`~siku_core.contact.contact_model.ContactModel` that owns
the
joint arrays (SoA: ``ji, jj, ends_i, ends_j, L0, width, intact, break_mode, break_time, hist,
jK, jmeff, jedge``, the rows the joint loop writes and the per-element index); the model
provides the attributes it reads (``state, radius, law, cfg, broad, where, label, skip, E,
minv, exclude_jointed, n_broken_total``, ``_admit``). Processes that create joints get slots
reserved at set-up (:meth:`JointBook.reserve_joints`): the joint arrays are then views of the
first ``n_joints`` rows of full-length ones, and :meth:`JointBook.create_joints` fills the next.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit

from .contact_frames import (
    ROW_FIX,
    ROW_FIY,
    ROW_SIZE,
    element_index,
    find_shared_edges,
    frame_point,
    joint_arms,
    joint_constants,
)
from ..contact_law import BREAK_MELT, BREAK_STRAIN, BreakMode
from ..errors import SceneError
from .ice_follow import joints_from
from ..state import MELTED
from ..geometry.face import joint_edges
from ..geometry.quat import centers, east_north_row, from_tangent, xyz_to_latlon


class JointBook:
    """Joints of one run and their breaks (mixed into ``ContactModel``)."""

    def _build_joints(self) -> None:
        st, R, cfg = self.state, self.radius, self.cfg
        nh = len(self.law.history_names)
        if not self.law.uses_joints or cfg.joints == "none":
            if cfg.joints == "pairs":
                raise SceneError(
                    f"{self.where}: law '{self.law.name}' has no joints; "
                    "remove 'pairs' or choose a joint law (distributed_spring, mohr_coulomb)"
                )
            self._set_joints(np.zeros((0, 2), np.int64), np.zeros((0, 2, 2)), np.zeros((0, 2, 2)),
                             nh)
            return
        if cfg.joints == "pairs":
            cand = np.array([sorted(p) for p in cfg.pairs], dtype=np.int64)
            bad = cand[(cand[:, 0] < 0) | (cand[:, 1] >= st.n) | (cand[:, 0] == cand[:, 1])]
            if len(bad):
                raise SceneError(
                    f"{self.where}: pair {bad[0].tolist()} does not name two "
                    f"distinct elements among 0..{st.n - 1}"
                )
            tol = cfg.tolerance if cfg.tolerance is not None else 0.01
        else:
            c = centers(st.q)
            cand = self.broad.pairs(c, st.radius / R * 1.1, np.zeros(st.n, dtype=bool))
            tol = cfg.tolerance if cfg.tolerance is not None else 0.10
        found, ends_i, ends_j = find_shared_edges(st.q, st.vert_offsets, st.verts, cand, tol, R)
        # static elements never need joints among themselves
        both_fixed = self.skip[cand[:, 0]] & self.skip[cand[:, 1]] if len(cand) else found
        keep = found & ~both_fixed
        if cfg.joints == "pairs" and not found.all():
            self.rejected = [tuple(map(int, p)) for p in cand[~found]]
            warnings.warn(
                f"{self.where}: {len(self.rejected)} listed pair(s) share no "
                f"edge within tolerance {tol:g} and were not jointed: "
                + ", ".join(str(list(p)) for p in self.rejected[:10])
                + (" ..." if len(self.rejected) > 10 else ""),
                stacklevel=2,
            )
        self._set_joints(cand[keep], ends_i[keep], ends_j[keep], nh)

    def _set_joints(self, pairs, ends_i, ends_j, nh) -> None:
        st, R = self.state, self.radius
        self.ji = np.ascontiguousarray(pairs[:, 0])
        self.jj = np.ascontiguousarray(pairs[:, 1])
        self.ends_i = np.ascontiguousarray(ends_i)
        self.ends_j = np.ascontiguousarray(ends_j)
        self.width = np.hypot(*(ends_i[:, 1] - ends_i[:, 0]).T) if len(pairs) else np.zeros(0)
        c = centers(st.q)
        if len(pairs):
            ang = np.arctan2(np.linalg.norm(np.cross(c[self.ji], c[self.jj]), axis=1),
                             np.sum(c[self.ji] * c[self.jj], axis=1))
            self.L0 = R * ang
        else:
            self.L0 = np.zeros(0)
        self.intact = np.ones(len(pairs), dtype=np.bool_)
        #: per joint: break mode (int8 code of ``contact_law.BreakMode``; 0 while intact) and
        #: the model time of the break [s] (NaN while intact)
        self.break_mode = np.zeros(len(pairs), dtype=np.int8)
        self.break_time = np.full(len(pairs), np.nan)
        #: breaks not yet taken by a writer (:meth:`take_breaks`)
        self._pending: list[int] = []
        self.hist = np.zeros((len(pairs), max(nh, 1)))
        #: per joint: the lever arms of eq. 9 [m] (``joint_arms``), kept until a line changes
        self.arms = joint_arms(self.ends_i, self.ends_j)
        self.jK, self.jmeff = joint_constants(st.thickness, self.E, self.minv, self.ji, self.jj,
                                              *self.arms)
        #: per joint: the edges of ``ji`` and ``jj`` it is frozen along (``face.joint_edges``)
        self.jedge = joint_edges(st.vert_offsets, st.verts, self.ji, self.jj, self.ends_i,
                                 self.ends_j)
        self.joint_rows = np.zeros((len(pairs), ROW_SIZE))
        self.joint_active = np.zeros(len(pairs), dtype=np.int8)
        self.joff, self.jidx, self.jside = element_index(self.ji, self.jj, st.n)

    @property
    def n_joints(self) -> int:
        return len(self.ji)

    #: whether the joints' constants wait for the next joint loop to follow a change of the
    #: ice (``ContactModel.ice_changed``: from ``_jscratch``); reading ``jK`` or ``jmeff``
    #: computes them first
    _joints_stale = False

    @property
    def jK(self) -> np.ndarray:
        """Per joint: eq. 9 stiffness [Pa]
        (:func:`~siku_core.contact.contact_frames.eq9_stiffness`)."""
        if self._joints_stale:
            self._follow_joints()
        return self._jK

    @jK.setter
    def jK(self, value: np.ndarray) -> None:
        self._jK = value
        self._joints_stale = False

    @property
    def jmeff(self) -> np.ndarray:
        """Per joint: reduced mass ``1 / (1/m_i + 1/m_j)`` [kg]."""
        if self._joints_stale:
            self._follow_joints()
        return self._jmeff

    @jmeff.setter
    def jmeff(self, value: np.ndarray) -> None:
        self._jmeff = value
        self._joints_stale = False

    def _follow_joints(self) -> None:
        """The joints' constants that wait for the joint loop, computed now (the same values)."""
        self._joints_stale = False
        joints_from(0, len(self.ji), self._jscratch, self.ji, self.jj, *self.arms, self._jK,
                    self._jmeff)

    #: per-joint arrays that live in the reserved slots (:meth:`reserve_joints`); the joint
    #: constants ``jK, jmeff`` and the per-element index are recomputed from them
    _SLOTTED = ("ji", "jj", "ends_i", "ends_j", "width", "L0", "intact", "break_mode",
                "break_time", "hist", "jedge", "joint_rows", "joint_active")
    #: the reserved slots (full-length arrays whose first ``n_joints`` rows are the joints);
    #: ``None`` while no process may create joints
    _slots: dict[str, np.ndarray] | None = None

    @property
    def joint_slots(self) -> int:
        """Joints the run can hold: those built at set-up plus the slots reserved for joints
        that processes create (:meth:`reserve_joints`)."""
        return len(self._slots["ji"]) if self._slots is not None else self.n_joints

    def reserve_joints(self, spare: int) -> None:
        """Reserve ``spare`` slots for joints created during the run (:meth:`create_joints`),
        before any component's set-up: every per-joint array becomes the first ``n_joints``
        rows of a full-length one, so creating a joint never moves the others and the compiled
        loops see arrays of the same types. Without a call nothing changes."""
        if spare <= 0 or self._slots is not None:
            return
        m = self.n_joints
        self._slots = {}
        for name in self._SLOTTED:
            a = getattr(self, name)
            s = np.zeros((m + spare, *a.shape[1:]), dtype=a.dtype)
            s[:m] = a
            self._slots[name] = s
        self._slots["ji"][m:] = -1
        self._slots["jj"][m:] = -1
        self._slots["jedge"][m:] = -1
        self._slots["break_time"][m:] = np.nan
        #: the joints built at set-up (the slots after them hold created ones)
        self._built = m
        self._use(m)

    def _use(self, m: int) -> None:
        """The first ``m`` slots are the joints: the arrays, their constants and index."""
        for name, s in self._slots.items():
            setattr(self, name, s[:m])
        self.joff, self.jidx, self.jside = element_index(self.ji, self.jj, self.state.n)
        self.refresh_joint_constants()

    def create_joints(self, pairs: np.ndarray, ends_i: np.ndarray) -> np.ndarray:
        """New intact joints between the element pairs ``pairs`` ``(K, 2)`` along the lines
        ``ends_i`` ``(K, 2, 2)`` [m] (in the first element's frame, running counter-clockwise
        round it): at rest where the two elements are now (the ends on the second element are
        the same points, the rest distance is the current one, the law's history starts from
        zero), with the joints' eq. 9 stiffness, carrying force from the next evaluation. They
        fill reserved slots (:meth:`reserve_joints`); returns their indices."""
        st, R = self.state, self.radius
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        m, k = self.n_joints, len(pairs)
        if m + k > self.joint_slots:
            raise ValueError(f"{k} new joints do not fit in the {self.joint_slots - m} free "
                             "joint slots")
        if not k:
            return np.zeros(0, np.int64)
        new = np.arange(m, m + k)
        s = self._slots
        s["ji"][new], s["jj"][new] = pairs[:, 0], pairs[:, 1]
        s["ends_i"][new] = ends_i
        c = centers(st.q)
        for a, kk in enumerate(new):
            i, j = pairs[a]
            for e in range(2):
                s["ends_j"][kk, e] = frame_point(st.q[i], st.q[j], ends_i[a, e, 0],
                                                 ends_i[a, e, 1], R)
            s["L0"][kk] = R * math.atan2(float(np.linalg.norm(np.cross(c[i], c[j]))),
                                         float(np.dot(c[i], c[j])))
        d = ends_i[:, 1] - ends_i[:, 0]
        s["width"][new] = np.hypot(d[:, 0], d[:, 1])
        s["intact"][new] = True
        s["break_mode"][new] = 0
        s["break_time"][new] = np.nan
        s["hist"][new] = 0.0
        s["jedge"][new] = -1  # not along an edge: the collision loop's general clip
        s["joint_rows"][new] = 0.0
        s["joint_active"][new] = 0
        self._use(m + k)
        self._joints_changed()
        return new

    def _joints_changed(self) -> None:
        """The candidate list follows a change of the joints: rebuilt at the next evaluation
        under ``jointed = "exclude"``, else its joint edges (``_faces``) are renewed."""
        if self.exclude_jointed:
            self._ref_centers = None
        elif len(self.pairs):
            self.pface = self._faces(self.pairs)

    @property
    def n_intact(self) -> int:
        return int(self.intact.sum())


    def _record_breaks(self, t: float) -> None:
        """Stamp joints that broke in this evaluation (state at model time ``t`` [s])."""
        new = np.flatnonzero(~self.intact & np.isnan(self.break_time))
        self.break_time[new] = t
        # a break without a mode: "strain"
        self.break_mode[new[self.break_mode[new] == 0]] = BREAK_STRAIN
        self._pending.extend(new.tolist())
        self._admit(new)

    def break_joints(self, k: np.ndarray, mode: BreakMode | int, t: float) -> int:
        """Break intact joints ``k`` from outside the law (a forcing source, a coupled model):
        they carry no force from the next evaluation on and are recorded with ``mode``
        (a :class:`~siku_core.contact_law.BreakMode`, or its int code) at model time ``t``
        [s]. Returns how many broke."""
        k = np.asarray(k, dtype=np.int64)
        k = k[self.intact[k]]
        self.intact[k] = False
        self.break_mode[k] = int(mode)
        self.n_broken_total += len(k)
        self._record_breaks(t)
        return len(k)

    def remove_elements(self, k: np.ndarray, t: float) -> int:
        """Elements ``k`` melted away (``siku_core.ice``): their intact joints break with mode
        ``MELT`` at model time ``t`` [s]. Returns how many joints broke."""
        if not self.n_joints:
            return 0
        gone = np.zeros(self.state.n, dtype=bool)
        gone[np.asarray(k, dtype=np.int64)] = True
        hit = np.flatnonzero(gone[self.ji] | gone[self.jj])
        return self.break_joints(hit, BREAK_MELT, t)

    def refreeze_joints(self, k: np.ndarray, t: float) -> int:
        """Broken joints ``k`` freeze again where their two sides are now: intact from the
        next evaluation, at rest in the current configuration (the ends of ``j`` are put on
        those of ``i``, the rest distance is the current one, the law's history starts from
        zero) with the joints' eq. 9 stiffness. ``t`` [s] is the model time (for messages).
        Returns how many joints refroze."""
        st, R = self.state, self.radius
        k = np.asarray(k, dtype=np.int64).reshape(-1)
        k = k[~self.intact[k]]
        gone = st.flags == MELTED  # (melted earlier in this step too)
        k = k[~(gone[self.ji[k]] | gone[self.jj[k]])]
        if not len(k):
            return 0
        c = centers(st.q)
        for kk in k:
            i, j = self.ji[kk], self.jj[kk]
            for e in range(2):
                x, y = frame_point(st.q[i], st.q[j], self.ends_i[kk, e, 0], self.ends_i[kk, e, 1],
                                   R)
                self.ends_j[kk, e, 0] = x
                self.ends_j[kk, e, 1] = y
            ci, cj = c[i], c[j]
            self.L0[kk] = R * math.atan2(float(np.linalg.norm(np.cross(ci, cj))),
                                         float(np.dot(ci, cj)))
        self.intact[k] = True
        self.break_mode[k] = 0
        self.break_time[k] = np.nan
        self.hist[k] = 0.0
        self.refresh_joint_constants()
        if self.exclude_jointed:
            self._ref_centers = None  # the refrozen pairs leave the candidate list
        return len(k)

    def refresh_joint_constants(self, lines: bool = True) -> None:
        """Every joint's eq. 9 stiffness and reduced mass from the current thickness, rest
        state and masses (after a process changed them). A joint of an element that melted
        away is broken; it gets a finite reduced mass all the same (its element's own mass
        stands in for the zero inverse mass of an element that no longer moves). ``lines =
        False``: no joint's line changed since the last refresh (only the ice did), so the lever
        arms are kept."""
        st = self.state
        arms = getattr(self, "arms", None)
        if lines or arms is None or len(arms[0]) != len(self.ji):
            self.arms = joint_arms(self.ends_i, self.ends_j)
        minv = np.where(st.flags == MELTED, 1.0 / st.m, self.minv)
        self.jK, self.jmeff = joint_constants(st.thickness, self.E, minv, self.ji, self.jj,
                                              *self.arms)

    def joint_gaps(self, k: np.ndarray) -> np.ndarray:
        """How far apart the two sides of joints ``k`` are now [m]: the larger distance
        between an end of the joint on ``i`` and the same end on ``j`` (0 where they are where
        the joint was frozen, in ``i``'s tangent plane)."""
        k = np.ascontiguousarray(k, dtype=np.int64)
        return _joint_gaps(self.state.q, self.ji, self.jj, self.ends_i, self.ends_j,
                           self.radius, k)

    def joint_tension(self, k: np.ndarray) -> np.ndarray:
        """Normal traction of intact joints ``k`` in the last force evaluation [Pa], tension
        (a joint pulling its sides together) positive: the force on ``i`` along the joint's
        outward normal from ``i`` (towards ``j``), over the joint's length and the thinner
        side's thickness."""
        k = np.asarray(k, dtype=np.int64)
        st = self.state
        d = self.ends_i[k, 1] - self.ends_i[k, 0]
        w = np.hypot(d[:, 0], d[:, 1])
        safe = np.where(w > 0, w, 1.0)
        nx, ny = d[:, 1] / safe, -d[:, 0] / safe  # a -> b runs counter-clockwise round i
        # the generalised force on i is the force on i in its frame (its contact point lies a
        # joint's length from i's centre: the difference is of order (length / R)²)
        fx, fy = self.joint_rows[k, ROW_FIX], self.joint_rows[k, ROW_FIY]
        h = np.minimum(st.thickness[self.ji[k]], st.thickness[self.jj[k]])
        return np.where(w > 0, (fx * nx + fy * ny) / (safe * h), 0.0)

    def joint_midpoints(self, k: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Latitude and longitude [deg] ``(len(k), 2)`` of the midpoints of joints ``k``."""
        from ..geometry.quat import from_tangent, xyz_to_latlon

        st = self.state
        q = st.q if q is None else q
        out = np.empty((len(k), 2))
        for a, kk in enumerate(np.asarray(k, dtype=np.int64)):
            m = 0.5 * (self.ends_i[kk, 0] + self.ends_i[kk, 1])
            lat, lon = xyz_to_latlon(from_tangent(q[self.ji[kk]], m[0], m[1], self.radius))
            out[a] = np.degrees(lat), np.degrees(lon)
        return out

    def joint_lines(self, q: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """Where every joint is for state ``q`` (default: the current one): midpoint latitude
        and longitude [rad], and the unit direction of the joint edge ``(east, north)`` at the
        midpoint, as five arrays of ``n_joints``. For components that act on joints (forcing
        that breaks them, coupled models) without reading a law's arrays."""
        st = self.state
        return _joint_lines(st.q if q is None else q, self.ji, self.ends_i, self.radius)

    def floe_labels(self) -> tuple[int, np.ndarray]:
        """Floes as the connected groups of elements over intact joints: ``(count, label)``,
        ``label[element]`` in ``0..count-1`` (an element without intact joints is a floe)."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        n = self.state.n
        k = self.intact
        g = coo_matrix((np.ones(int(k.sum())), (self.ji[k], self.jj[k])), shape=(n, n))
        count, label = connected_components(g, directed=False)
        return int(count), label

    def take_breaks(self) -> dict[str, np.ndarray]:
        """Breaks since the last call, in the order they happened: ``time`` [s], ``joint``,
        ``i``, ``j`` (element indices), ``lat``, ``lon`` [deg] of the joint midpoint at the
        time of writing, ``mode`` (code of ``contact_law.BREAK_MODES``)."""
        k = np.array(self._pending, dtype=np.int64)
        self._pending = []
        k = k[np.argsort(self.break_time[k], kind="stable")]
        ll = self.joint_midpoints(k) if len(k) else np.zeros((0, 2))
        return {"time": self.break_time[k], "joint": k, "i": self.ji[k], "j": self.jj[k],
                "lat": ll[:, 0], "lon": ll[:, 1], "mode": self.break_mode[k].astype(np.int8)}

    #: whether the joints' rest state (``ends_j``, ``L0``) is history: set by the engine for a
    #: scene with processes, which may refreeze joints where they are
    rest_state_is_history = False

    def history(self) -> dict[str, np.ndarray]:
        """The joints' breaks, the law's history and (with processes) their rest state; with
        reserved slots every array has a row per slot, and ``joints`` (how many hold joints),
        ``pairs`` (their elements, -1 beyond) and ``ends_i`` say which joints were created."""
        a = self._slots if self._slots is not None else vars(self)
        out = {"intact": a["intact"].astype(np.int8), "hist": a["hist"].copy(),
               "n_broken_total": np.array(self.n_broken_total),
               "break_mode": a["break_mode"].astype(np.int8),
               "break_time": a["break_time"].copy()}
        if self.rest_state_is_history:
            out.update(ends_j=a["ends_j"].copy(), L0=a["L0"].copy())
        if self._slots is not None:
            out.update(joints=np.array(self.n_joints, dtype=np.int64),
                       pairs=np.stack([a["ji"], a["jj"]], axis=1), ends_i=a["ends_i"].copy())
        return out

    def set_history(self, d: dict[str, np.ndarray]) -> None:
        slots = self.joint_slots
        if d["intact"].shape != (slots,) or ("joints" in d) != (self._slots is not None):
            raise SceneError(
                f"{self.label}: restart holds {d['intact'].shape[0]} joints but the scene "
                f"builds {slots}"
            )
        s = self._slots
        if s is not None:  # the joints created before: their elements and lines
            m = int(d["joints"])
            s["ji"][:], s["jj"][:] = np.asarray(d["pairs"], dtype=np.int64).T
            s["ends_i"][...] = d["ends_i"]
            b = s["ends_i"][:, 1] - s["ends_i"][:, 0]
            s["width"][self._built:] = np.hypot(b[self._built:, 0], b[self._built:, 1])
            s["jedge"][self._built:] = -1
            s["joint_rows"][self._built:] = 0.0
            s["joint_active"][self._built:] = 0
            self._use(m)
            self._joints_changed()
        a = s if s is not None else vars(self)  # (every slot: the joints are a view of them)
        a["intact"][:] = d["intact"].astype(bool)
        a["hist"][...] = d["hist"]
        self.n_broken_total = int(d["n_broken_total"])
        if "ends_j" in d and self.rest_state_is_history:
            a["ends_j"][...] = d["ends_j"]
            a["L0"][...] = d["L0"]
            self.refresh_joint_constants()
        if "break_mode" in d:
            a["break_mode"][:] = d["break_mode"]
            a["break_time"][:] = d["break_time"]
        else:  # a file from before break modes were recorded
            self.break_mode[:] = np.where(self.intact, 0, BREAK_STRAIN)
            self.break_time[:] = np.where(self.intact, np.nan, -np.inf)
        self._pending = []
        if self.exclude_jointed:  # the candidates follow the joints restored: rebuild them
            self._ref_centers = None


@njit(cache=True)
def _joint_lines(q, ji, ends_i, R):
    n = ji.shape[0]
    lat = np.empty(n)
    lon = np.empty(n)
    de = np.empty(n)
    dn = np.empty(n)
    for k in range(n):
        i = ji[k]
        a0, a1 = ends_i[k, 0, 0], ends_i[k, 0, 1]
        b0, b1 = ends_i[k, 1, 0], ends_i[k, 1, 1]
        p = from_tangent(q[i], 0.5 * (a0 + b0), 0.5 * (a1 + b1), R)
        lat[k], lon[k] = xyz_to_latlon(p)
        # the edge direction: a tangent vector of element i's frame, taken to the midpoint's
        # east/north (the frames differ by the element's size over R: negligible)
        ex, ey, nx, ny = east_north_row(q, i)
        tx, ty = b0 - a0, b1 - a1
        el = math.sqrt(tx * tx + ty * ty)
        if el == 0.0:
            de[k] = 1.0
            dn[k] = 0.0
            continue
        # local (tx, ty) -> east/north: east = (ex, ey), north = (nx, ny) are orthonormal
        de[k] = (tx * ex + ty * ey) / el
        dn[k] = (tx * nx + ty * ny) / el
    return lat, lon, de, dn


@njit(cache=True)
def _joint_gaps(q, ji, jj, ends_i, ends_j, R, ks):
    out = np.empty(ks.shape[0])
    for a in range(ks.shape[0]):
        k = ks[a]
        g = 0.0
        for e in range(2):
            x, y = frame_point(q[jj[k]], q[ji[k]], ends_j[k, e, 0], ends_j[k, e, 1], R)
            g = max(g, math.hypot(x - ends_i[k, e, 0], y - ends_i[k, e, 1]))
        out[a] = g
    return out
