"""The joints of the contact phase: their construction (detected shared edges or listed
pairs), their per-joint constants, and the bookkeeping of their breaks (modes, times, the
breaks a writer has not taken, restart history, floes).

:class:`JointBook` is the part of :class:`~siku_core.contact_model.ContactModel` that owns the
joint arrays (SoA: ``ji, jj, ends_i, ends_j, L0, width, intact, break_mode, break_time, hist,
jK, jmeff, jedge``, the rows the joint loop writes and the per-element index); the model
provides the attributes it reads (``state, radius, law, cfg, broad, where, label, skip, E,
minv, exclude_jointed, n_broken_total``, ``_admit``).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit

from .contact_frames import (
    ROW_SIZE,
    element_index,
    find_shared_edges,
    joint_constants,
)
from .contact_law import (
    BREAK_STRAIN,
    BreakMode,
)
from .errors import SceneError
from .geometry.face import joint_edges
from .geometry.quat import centers, east_north_row, from_tangent, xyz_to_latlon


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
        self.jK, self.jmeff = joint_constants(st.thickness, self.E, self.minv, self.ji, self.jj,
                                              self.ends_i, self.ends_j)
        #: per joint: the edges of ``ji`` and ``jj`` it is frozen along (``face.joint_edges``)
        self.jedge = joint_edges(st.vert_offsets, st.verts, self.ji, self.jj, self.ends_i,
                                 self.ends_j)
        self.joint_rows = np.zeros((len(pairs), ROW_SIZE))
        self.joint_active = np.zeros(len(pairs), dtype=np.int8)
        self.joff, self.jidx, self.jside = element_index(self.ji, self.jj, st.n)

    @property
    def n_joints(self) -> int:
        return len(self.ji)

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

    def joint_midpoints(self, k: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Latitude and longitude [deg] ``(len(k), 2)`` of the midpoints of joints ``k``."""
        from .geometry.quat import from_tangent, xyz_to_latlon

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

    def history(self) -> dict[str, np.ndarray]:
        return {"intact": self.intact.astype(np.int8), "hist": self.hist.copy(),
                "n_broken_total": np.array(self.n_broken_total),
                "break_mode": self.break_mode.astype(np.int8), "break_time": self.break_time.copy()}

    def set_history(self, d: dict[str, np.ndarray]) -> None:
        if d["intact"].shape != self.intact.shape:
            raise SceneError(
                f"{self.label}: restart holds {d['intact'].shape[0]} joints but the scene "
                f"builds {self.intact.shape[0]}"
            )
        self.intact[:] = d["intact"].astype(bool)
        self.hist[...] = d["hist"]
        self.n_broken_total = int(d["n_broken_total"])
        if "break_mode" in d:
            self.break_mode[:] = d["break_mode"]
            self.break_time[:] = d["break_time"]
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
