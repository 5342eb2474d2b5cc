"""The engine's contact phase: broad phase, narrow phase, joints and the chosen law.

The joints' construction and break bookkeeping are
:class:`~siku_core.contact.contact_joints.JointBook`,
which :class:`ContactModel` extends.
"""
from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .contact_frames import (
    ROW_SIZE,
    element_index,
    joint_arms,
    rotation_matrices,
    rotations_within,
)
from .contact_joints import JointBook
from .contact_tables import ContactTables
from ..contact_law import (
    BREAK_MODES, ContactLaw, compile_evaluators, evaluator_of, parameter_vector,
)
from .contact_forces import collision_forces, gather_forces, joint_forces
from .damping import contact_mobility
from ..errors import SceneError
from ..geometry.clip import REL_TOL
from ..geometry.coherent import NO_HINT
from ..geometry.face import edge_table
from ..geometry.quat import centers
from .ice_follow import follow_contacts
from ..interfaces import BroadPhase
from ..parallel import GATHER_NS, ROTATION_NS, alone, chunks
from ..plugins import package_of
from ..run.progress import clock
from ..state import FREE, MELTED, ElementState
from ..testing import switches


class ContactModel(ContactTables, JointBook):
    """Contacts of one run: joints (SoA), candidate pairs (reused within a skin), the law.

    Arrays are allocated here only, so a scene without a ``[contact]`` table has none. Per
    force evaluation (:meth:`add`): rotation matrices of all elements, the joint loop, the
    candidate list (rebuilt by the broad phase only when an element moved more than half the
    skin), the collision loop, and the per-element sum of the contacts' contributions; each
    phase's time goes to ``timings``.

    Built from what it needs: ``cfg`` the scene's ``[contact]`` table, ``state`` the elements,
    ``radius`` the planet radius [m], ``materials`` the scene's materials in the order of
    ``state.material``, ``law`` and ``broad`` the built components, ``time_step`` a callable
    giving the run's time step [s] (read at every evaluation), ``where`` how messages name the
    ``[contact]`` table, ``label`` how they name the scene, ``timings`` the run's dict of phase
    times [s] (added to).
    """

    kind = "contacts"

    def __init__(self, cfg: Any, state: ElementState, radius: float,
                 materials: Sequence[Any], law: ContactLaw, broad: BroadPhase,
                 time_step: Callable[[], float], where: str = "[contact]", label: str = "",
                 timings: dict[str, float] | None = None):
        self.cfg = cfg
        self.state = state
        self.radius = radius
        self.law = law
        self.broad = broad
        #: columns of the law's per-contact history (``contact_history_names``); without any,
        #: no array of the per-contact history has a nonzero size
        self.n_contact_hist = len(law.contact_history_names)
        #: restored per-contact history waiting for the next rebuild: ``(keys, rows)``
        self._chist_pending: tuple[np.ndarray, np.ndarray] | None = None
        self.time_step = time_step
        self.where = where
        self.label = label
        self.timings = timings if timings is not None else {}
        for k in ("joints", "broad_phase", "collisions", "contact_sum"):
            self.timings.setdefault(k, 0.0)
        self.name = self.law.name
        st = state
        R = radius
        mats = list(materials)
        self.E = np.array([mats[k].youngs_modulus for k in st.material], dtype=float)
        self.nu = np.array([mats[k].poisson_ratio for k in st.material], dtype=float)
        self.minv = np.where(st.flags == FREE, 1.0 / st.m, 0.0)
        self.skip = st.flags != FREE  # static and steady elements never interact with each other
        #: elements melted away by a process (``siku_core.ice``), ``None`` while there are none
        self.gone: np.ndarray | None = None
        skin = cfg.skin if cfg.skin is not None else 0.1 * float(np.mean(st.radius))
        self.skin = skin / R
        self.radii = st.radius / R + 0.5 * self.skin
        self.pairs = np.zeros((0, 2), dtype=np.int64)
        self._no_elements = np.zeros(0, dtype=np.int64)
        self._jscratch = np.zeros(0)  # (ice_changed)
        self.caps_kept = False  # the loop keeps whether the law capped each pair (keep_caps)
        self._set_pair_index()
        self._ref_centers: np.ndarray | None = None
        self.rm = np.empty((st.n, 3, 3))
        self._rm_scratch: np.ndarray | None = None
        self.nmax = int(np.max(np.diff(st.vert_offsets))) if st.n else 3
        # contact.touching = "ignore": overlaps within the clip's tolerance carry no force, and
        # the separating-axis test gets the margin that settles them (clip.apart_within)
        self.drop_touching = cfg.touching == "ignore"
        self.margin = np.zeros(st.n)
        #: per element: its largest absolute vertex coordinate in its own plane [m]
        self.scale = (np.maximum.reduceat(np.abs(st.verts).max(axis=1), st.vert_offsets[:-1])
                      if st.n else np.zeros(0))
        if self.drop_touching and st.n:
            self.margin = self.scale * (REL_TOL / 3.0)
        #: per vertex row: the constants of the element's edge from it (geometry.face)
        self.edges = edge_table(st.vert_offsets, st.verts)
        # contact.jointed = "exclude": pairs with an intact joint are not collision candidates
        # (filtered out at every rebuild of the list; a pair joins it when its joint breaks)
        self.exclude_jointed = cfg.jointed == "exclude"
        self.rebuilds = 0
        self.n_overlap = 0
        self.n_broken_total = 0
        self.rejected: list[tuple[int, int]] = []
        #: per element ``(n/m, n/I)``, the bound of the dampers (``siku_core.contact.damping``);
        #: ``None``: stale, computed at the next evaluation
        self._dmob: np.ndarray | None = None
        self._dmob_key: tuple | None = None
        self._build_joints()

    # ------------------------------------------------------------------ step
    def _set_pair_index(self) -> None:
        n = self.state.n
        p = self.pairs
        self.pair_rows = np.zeros((len(p), ROW_SIZE))
        self.pair_active = np.zeros(len(p), dtype=np.int8)
        self.separating_hint = np.zeros(len(p), dtype=np.int16)
        #: per candidate pair: the edges its overlap's boundaries crossed at last (the coherent
        #: clip, ``geometry.coherent``; empty while ``switches.coherent_clip`` is off)
        self.clip_hint = np.full(len(p) if switches.coherent_clip else 0, NO_HINT, np.int32)
        self.poff, self.pidx, self.pside = element_index(
            np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]), n)
        self.pface = self._faces(p)
        #: per candidate pair: 1 if the law capped its normal force when last found overlapping
        self.pair_capped = np.zeros(len(p) if self.caps_kept else 0, dtype=np.int8)
        #: per candidate pair: its per-contact history row (zero unless in contact), and
        #: whether it was in contact at the last committed evaluation; ``(0, 0)`` and ``(0,)``
        #: under a law without per-contact history
        nh = self.n_contact_hist
        self.chist = np.zeros((len(p), nh) if nh else (0, 0))
        self.pair_contact = np.zeros(len(p) if nh else 0, dtype=bool)

    def _carry_contact_history(self, keys: np.ndarray, rows: np.ndarray) -> None:
        """Give the current candidates in contact the history ``rows`` of the pairs with keys
        ``keys`` (:meth:`_keys`, those in contact before a rebuild, or restored): a pair keeps
        its row while it stays a candidate, whatever its place in the list."""
        hit, src = self._match(keys, self._keys(self.pairs[:, 0], self.pairs[:, 1]))
        self.chist[hit] = rows[src]
        self.pair_contact[hit] = True

    @staticmethod
    def _match(keys: np.ndarray, pk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which of the keys ``pk`` are among ``keys`` (mask), and where (indices into it)."""
        if not len(keys) or not len(pk):
            return np.zeros(len(pk), bool), np.zeros(0, np.int64)
        order = np.argsort(keys, kind="stable")
        sk = keys[order]
        at = np.minimum(np.searchsorted(sk, pk), len(sk) - 1)
        hit = sk[at] == pk
        return hit, order[at[hit]]

    def _carry_hints(self, pairs: np.ndarray, hints: np.ndarray) -> None:
        """The coherent clip's ``hints`` of ordered ``pairs`` to the same pairs in the new list
        (only a guess that the clip checks: one lost costs a full clip)."""
        if len(self.clip_hint):
            n = self.state.n
            hit, src = self._match(pairs[:, 0] * n + pairs[:, 1],
                                   self.pairs[:, 0] * n + self.pairs[:, 1])
            self.clip_hint[hit] = hints[src]

    def _contact_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Keys and history rows of the candidates in contact (copies)."""
        on = self.pair_contact
        return self._keys(self.pairs[on, 0], self.pairs[on, 1]), self.chist[on].copy()

    def _faces(self, p: np.ndarray) -> np.ndarray:
        """Per candidate pair ``(i, j)``: the edges of ``i`` and of ``j`` along which the two
        are (or were) jointed, ``-1`` for a pair without a joint; int16 ``(len(p), 2)``. The
        contact loop finds a touching overlap of such a pair from these edges
        (``geometry.face``)."""
        face = np.full((len(p), 2), -1, dtype=np.int16)
        nj = len(getattr(self, "ji", ()))
        if not switches.face_path or not nj or not len(p):
            return face
        jk = self._keys(self.ji, self.jj)
        order = np.argsort(jk, kind="stable")
        pk = self._keys(p[:, 0], p[:, 1])
        at = np.minimum(np.searchsorted(jk[order], pk), nj - 1)
        hit = jk[order][at] == pk
        n = order[at[hit]]
        same = self.ji[n] == p[hit, 0]
        face[hit, 0] = np.where(same, self.jedge[n, 0], self.jedge[n, 1])
        face[hit, 1] = np.where(same, self.jedge[n, 1], self.jedge[n, 0])
        return face

    def _rotations(self, q) -> bool:
        """``self.rm`` for state ``q``, and whether every element is still within half the
        skin of where it was at the last rebuild of the candidate list (one pass for both)."""
        nch = chunks(q.shape[0], ROTATION_NS)
        with alone(nch):
            if self._ref_centers is None:
                rotation_matrices(q, self.rm, nch)
                return False
            return bool(rotations_within(q, self.rm, nch, self._ref_centers,
                                         (0.5 * self.skin) ** 2))

    def _candidates(self, q, within: bool) -> np.ndarray:
        """The candidate pairs for state ``q``: the list of the last rebuild while every element
        is ``within`` half the skin of where it was then (chord ~ angle here), else a new one."""
        if self._ref_centers is not None and within:
            return self.pairs
        c = centers(q)
        if self.n_contact_hist:
            kept = self._chist_pending or self._contact_rows()
            self._chist_pending = None
        hinted = self.pairs[self.clip_hint >= 0], self.clip_hint[self.clip_hint >= 0]
        pairs = np.asarray(self.broad.pairs(c, self.radii, self.skip), dtype=np.int64)
        if self.gone is not None and len(pairs):  # melted elements touch nothing
            pairs = pairs[~(self.gone[pairs[:, 0]] | self.gone[pairs[:, 1]])]
        if self.exclude_jointed and self.n_joints and len(pairs):
            jk = self._keys(self.ji[self.intact], self.jj[self.intact])
            pairs = pairs[~np.isin(self._keys(pairs[:, 0], pairs[:, 1]), jk)]
        self.pairs = np.ascontiguousarray(pairs)
        self._set_pair_index()
        if self.n_contact_hist:
            self._carry_contact_history(*kept)
        self._carry_hints(*hinted)
        self._ref_centers = c
        self.rebuilds += 1
        return self.pairs

    def _keys(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """One integer per unordered element pair ``(a[k], b[k])``."""
        n = self.state.n
        return np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)

    def _admit(self, k: np.ndarray) -> None:
        """``contact.jointed = "exclude"``: the pairs of joints ``k``, which just broke, join
        the candidate list now (in order of their pair key, as the broad phases sort; every
        other candidate keeps its state). The next rebuild keeps them by itself."""
        if not self.exclude_jointed or self._ref_centers is None or not len(k):
            return
        keys = self._keys(self.pairs[:, 0], self.pairs[:, 1])
        nk = self._keys(self.ji[k], self.jj[k])
        fresh = ~np.isin(nk, keys)
        if not fresh.any():
            return
        n = self.state.n
        every = np.concatenate([self.pairs, np.stack([nk[fresh] // n, nk[fresh] % n], axis=1)])
        order = np.argsort(np.concatenate([keys, nk[fresh]]), kind="stable")
        where = np.empty(len(order), dtype=np.int64)
        where[order] = np.arange(len(order))
        old = where[:len(keys)]
        rows, active, hint = self.pair_rows, self.pair_active, self.separating_hint
        chint = self.clip_hint
        chist, contact, caps = self.chist, self.pair_contact, self.pair_capped
        self.pairs = np.ascontiguousarray(every[order])
        self._set_pair_index()
        self.pair_rows[old] = rows
        self.pair_active[old] = active
        self.separating_hint[old] = hint
        if self.caps_kept:
            self.pair_capped[old] = caps
        if len(self.clip_hint):
            self.clip_hint[old] = chint
        if self.n_contact_hist:
            self.chist[old] = chist
            self.pair_contact[old] = contact

    def add(self, t, q, V, w, F, T, commit: bool) -> None:
        """Add contact forces for state ``q, V, w``; joint history changes only if ``commit``."""
        st, R = self.state, self.radius
        law = self.law
        tm = self.timings
        t0 = clock()
        within = self._rotations(q)
        t1 = clock()
        joints = self.n_joints and law.uses_joints
        el = self.element_table(V, w)
        dt = self.time_step()
        if joints:
            broke = joint_forces(self._jev, self._jpars, el, self.joint_table(), R, dt, commit,
                                 chunks(self.n_joints))
            self._joints_stale = False
            if commit and broke:
                self.n_broken_total += broke
                self._record_breaks(t)
        t2 = clock()
        pairs = self._candidates(q, within)
        t3 = clock()
        if len(pairs):
            n = collision_forces(self._cev, self._cpars, el, self.pair_table(pairs), R,
                                 self.nmax, switches.pretest, chunks(len(pairs)),
                                 self.drop_touching, commit, dt)
            if commit:
                self.n_overlap = n
                if self.n_contact_hist:  # a pair out of contact forgets its history
                    on = self.pair_active == 1
                    self.chist[~on] = 0.0
                    self.pair_contact[:] = on
        else:
            n = 0
            if commit:
                self.n_overlap = 0
        t4 = clock()
        if joints or n:
            nch = chunks(st.n, GATHER_NS)
            with alone(nch):
                gather_forces(F, T, self.contact_index(), self.joint_rows, self.joint_active,
                              self.pair_rows, self.pair_active, nch)
        t5 = clock()
        tm["joints"] += t2 - t1
        tm["broad_phase"] += t3 - t2
        tm["collisions"] += t4 - t3
        tm["contact_sum"] += (t1 - t0) + (t5 - t4)

    def damping_mobility(self) -> np.ndarray:
        """Per element ``(n/m, n/I) / phi``, the bound of every damper
        (:func:`siku_core.contact.damping.contact_mobility`), kept until the joints or the ice
        change."""
        key = (self.n_joints, hash(self.intact.tobytes())) if self.n_joints else None
        if self._dmob is None or key != self._dmob_key:
            self._dmob, self._dmob_key = contact_mobility(self), key
        return self._dmob

    def setup(self) -> None:
        """The law's parameter vectors, and its evaluators compiled once for the engine's
        argument types (before step 1): a fault is a one-line :class:`PluginError`."""
        package = package_of(type(self.law))[0]
        self._cpars = parameter_vector(self.law, "collision", package)
        self._jpars = parameter_vector(self.law, "joint", package)
        compile_evaluators(self.law, package)
        self._jev = evaluator_of(self.law, "joint_evaluator") if self.law.uses_joints else None
        self._cev = evaluator_of(self.law, "collision_evaluator")

    def keep_caps(self) -> None:
        """From now on the collision loop keeps in ``pair_capped`` whether the law capped each
        overlapping pair's normal force (its ``out[3]``; for the ``ridging`` process)."""
        if not self.caps_kept:
            self.caps_kept = True
            self.pair_capped = np.zeros(len(self.pairs), dtype=np.int8)

    def ice_changed(self, elements: np.ndarray | None = None, flags: bool = True) -> None:
        """After a process changed thickness or flags (``siku_core.ice``): inverse masses, the
        joints' eq. 9 stiffness and reduced masses (after a change of every element, in the
        next joint loop's chunks; ``jK``, ``jmeff`` read before compute them); melted elements
        leave the candidate list. ``elements``: only these changed (``None``: all), ``flags``:
        a flag may have (:func:`~siku_core.contact.ice_follow.follow_contacts`)."""
        st = self.state
        self._dmob = None
        full = elements is None
        if full:
            elements = self._no_elements
        if len(self.arms[0]) != len(self.ji):
            self.arms = joint_arms(self.ends_i, self.ends_j)
        if len(self._jscratch) != 2 * st.n:
            self._jscratch = np.empty(2 * st.n)
        jK, jmeff = (self._jK, self._jmeff) if full else (self.jK, self.jmeff)
        jt = self.joint_table(fresh=True)._replace(K=jK, meff=jmeff)
        follow_contacts(elements, len(elements), full, False, st.thickness, self.E, st.m,
                        st.flags, self.minv, jt, self.contact_index())
        if full:
            self._joints_stale = True
        if not flags:
            return
        gone = st.flags == MELTED
        if gone.any() and (self.gone is None or not np.array_equal(gone, self.gone)):
            self.gone = gone
            self.skip = st.flags != FREE
            self._ref_centers = None  # rebuilt at the next evaluation, without them

    # ------------------------------------------------------------------ per-contact history
    def history(self) -> dict[str, np.ndarray]:
        """The joints' history (:class:`~siku_core.contact.contact_joints.JointBook`) and, under a
        law
        with ``contact_history_names``, the pairs in contact at the last committed evaluation:
        ``contact_pairs`` (int64 ``(m, 2)``, ``i < j``), ``contact_hist`` (``(m, C)``, their
        rows) and ``contact_count`` (``m``; files pad the two arrays to their longest)."""
        out = super().history()
        if self.n_contact_hist:
            keys, rows = self._chist_pending or self._contact_rows()
            n = self.state.n
            out["contact_pairs"] = np.stack([keys // n, keys % n], axis=1).astype(np.int64)
            out["contact_hist"] = rows
            out["contact_count"] = np.array(len(keys), dtype=np.int64)
        return out

    def set_history(self, d: dict[str, np.ndarray]) -> None:
        """Put :meth:`history` back; the per-contact rows go to their pairs at the rebuild of
        the candidate list that the next evaluation makes."""
        super().set_history(d)
        if not self.n_contact_hist:
            return
        if "contact_count" not in d:
            raise SceneError(f"{self.label}: restart holds no per-contact history, which law "
                             f"'{self.law.name}' keeps; restart with the scene that wrote it")
        m = int(d["contact_count"])
        pairs = np.asarray(d["contact_pairs"])[:m].astype(np.int64)
        rows = np.array(d["contact_hist"], dtype=float)[:m].reshape(m, self.n_contact_hist)
        self._chist_pending = (self._keys(pairs[:, 0], pairs[:, 1]), rows)
        self._ref_centers = None

    # ------------------------------------------------------------------ stability, history
    def stiffness_bound(self) -> tuple[float, int]:
        """Largest ``omega`` [rad/s] and its element, by a Gershgorin bound over each element's
        contacts (:func:`siku_core.contact.stable_step.gershgorin_bound`)."""
        from .stable_step import gershgorin_bound

        return gershgorin_bound(self)

    def stability_limit(self, ctx) -> tuple[float, str] | None:
        """The smaller of ``2 / omega`` of :meth:`stiffness_bound` (undamped, element by
        element) and the stable step of the contacts' stiffness *and damping* at rest
        (:func:`siku_core.contact.stable_step.critical_step`; bounded dampers:
        ``siku_core.contact.damping``).
        ``None`` without a free element in contact."""
        from .stable_step import critical_step, limit_and_reason

        om, i = self.stiffness_bound()
        if om <= 0:
            return None
        rates = self.law.stability_rates()
        dt_l, il, d = critical_step(self, rates)
        self.stable_step_details = {**d, "undamped_bound": 2.0 / om, "linear": dt_l}
        dt_c, why = limit_and_reason(self.law.name, self.stable_step_details, il, i)
        if rates.get("unbounded"):
            warnings.warn(f"{self.where}: the stable-step estimate cannot be sure: "
                          f"{rates['unbounded']}", stacklevel=2)
            why += "; not sure: " + rates["unbounded"]
        return dt_c, why

    def describe(self) -> dict:
        built = self._built if self._slots is not None else self.n_joints  # (at set-up)
        return {"name": self.law.name, "params": dict(self.law.p), "joints": built,
                "broad_phase": self.broad.name}

    def element_fields(self) -> dict[str, np.ndarray]:
        """``damage``: share of each element's joints that have broken [1] (0 without joints);
        ``stress_ee``, ``stress_nn``, ``stress_en``: the element's mean stress from its contact
        forces of the last evaluation [N/m] (``siku_core.contact.stress``)."""
        from .stress import element_stress

        st = self.state
        n = st.n
        lists = ([(self.ji, self.jj, self.joint_rows, self.joint_active, self.joff, self.jidx,
                   self.jside)] if self.n_joints else [])
        if len(self.pairs) and len(self.pair_active) == len(self.pairs):
            lists.append((self.pairs[:, 0], self.pairs[:, 1], self.pair_rows, self.pair_active,
                          self.poff, self.pidx, self.pside))
        s = element_stress(st.q, self.rm, st.area, self.radius, lists)
        out = {"stress_ee": s[:, 0], "stress_nn": s[:, 1], "stress_en": s[:, 2]}
        if not self.n_joints:
            return {"damage": np.zeros(n), **out}
        total = np.bincount(self.ji, minlength=n) + np.bincount(self.jj, minlength=n)
        broken = ~self.intact
        nb = np.bincount(self.ji[broken], minlength=n) + np.bincount(self.jj[broken], minlength=n)
        return {"damage": np.where(total > 0, nb / np.maximum(total, 1), 0.0), **out}

    def diagnostics(self) -> dict[str, float]:
        """Joint counts, overlapping pairs, and with joints the lead area and fraction and the
        joint stress extremes (see :func:`siku_core.contact.joint_metrics.joint_diagnostics`)."""
        out = {"joints_intact": self.n_intact, "joints_broken": self.n_joints - self.n_intact,
               "contacts_overlapping": self.n_overlap}
        if self.n_joints:
            codes = np.bincount(self.break_mode.astype(np.int64), minlength=len(BREAK_MODES))
            for c, name in BREAK_MODES.items():
                if c:
                    out[f"joints_broken_{name}"] = int(codes[c])
        if self.n_joints:
            from .joint_metrics import joint_diagnostics

            st = self.state
            if self._rm_scratch is None:  # the current state's rotations (self.rm: the last
                self._rm_scratch = np.empty_like(self.rm)  # force evaluation's)
            rotation_matrices(st.q, self._rm_scratch, chunks(st.n))
            out.update(joint_diagnostics(st.q, self.ji, self.jj, self.ends_i, self.ends_j,
                                         self.L0, self.width, self.intact, self.E, st.area,
                                         st.flags, self.radius, rm=self._rm_scratch))
        return out
