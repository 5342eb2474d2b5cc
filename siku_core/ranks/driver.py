"""The run of one scene on many ranks, bit for bit the run on one.

Every rank builds the run (:class:`~siku_core.run.simulation.Simulation`, the *run* here: the
scene, its elements, joints and components, as one rank would). At a *redistribution* every
rank holds the whole current state; the elements are split among the ranks
(:mod:`.decompose`), each rank finds its ghosts (:mod:`.ghosts`) and builds its engine over
its elements and ghosts (:mod:`.local`). A step:

1. each rank steps its engine (forcing, contacts, integrator) over its elements and ghosts
   (an integrator that evaluates forces more than once a step gets the ghosts' stage states
   from their owners before each later evaluation);
2. owners send their elements' new state and damper bound to the ranks that hold them as
   ghosts (one ``alltoall``);
3. the element-local processes due (``runs_on_ranks``) change the rank's elements, owned
   and ghosts alike, and the owners send their new damper bounds again;
4. one ``allgather`` of a few numbers: how far elements moved since the redistribution, the
   joints that broke (of which the rank owns the first element), whether the state (and the
   fields components integrate) is sound, an error a process raised and whether some
   element's ice changed enough to check the stable step again (on the whole run, every rank
   alike); every rank applies the breaks to the run's joint table, and runs the joints' guard;
5. on output steps the ranks' elements, joints, ice, contact and declared fields are
   gathered on rank 0 in global order, and the run's writers write them: the same files as
   one rank's (the components' diagnostics computed there, on the gathered run);
6. then, if an element moved half the skin (the engine's own rule for its candidate list), or
   ``every`` steps passed, a redistribution (new engines, whose contact fields are empty
   until their first force evaluation: hence after the outputs): elements whose centre left
   their subdomain change owner; and whenever the slowest rank's measured work (at least
   :data:`MIN_WORK`) exceeds the mean by :data:`REBALANCE_MARGIN`, the elements are split
   again.

A joint between elements of two ranks is evaluated on both, from the same inputs (the owners'
states and damper bounds, its own state carried since the last redistribution): it breaks in
the same step on both, and the rank owning its first element reports the break.
"""
from __future__ import annotations

import hashlib
import json
from typing import Any, Callable

import numpy as np

from .. import parallel
from ..categories import ice_per_area
from ..diagnostics import rows_sound
from ..errors import SceneError, SikuError
from ..geometry.quat import centers, farthest_moved2
from ..run.guard import RECHECK_JOINTS, integrated_fields
from ..state import MELTED
from ..run.progress import clock, compile_time
from .comm import Comm
from .decompose import Cuts, bisect, imbalance
from .ghosts import exchange_plan, local_sets, reach_pairs
from .history import merge, to_global, to_local, unfit
from .local import JOINT_STATE, RankLink, local_engine

#: the element arrays processes change besides the declared fields (``siku_core.ice``)
ICE_STATE = ("thickness", "m", "I", "flags")
#: re-split the elements when the slowest rank's work exceeds the mean by this share
REBALANCE_MARGIN = 0.2
#: ... measured over at least this much work per rank since the last split [s] (a shorter
#: window measures noise)
MIN_WORK = 1.0


def refusal_reason(comp) -> str:
    """Why the component ``comp`` cannot run on more than one rank ("" where it can)."""
    if not comp.runs_on_ranks:
        return comp.ranks_refusal or "it reads the contacts of every element"
    return unfit(comp)  # its history, split between the ranks by its ``rank_history``


def refusals(sim, size: int) -> list[str]:
    """One line per component of ``sim`` that cannot run on ``size`` ranks (empty: all can)."""
    out = []
    for comp in sim.components():
        why = refusal_reason(comp)
        if not why:
            continue
        where = sim.scene.where(comp.table) if comp.table else comp.kind
        out.append(f"{where}: {comp.kind} '{comp.name}' cannot run on {size} ranks ({why}); "
                   "run it on one rank")
    return out


def run_digest(sim) -> str:
    """A hash of what the run's results depend on (the effective scene, the components'
    parameters and the versions of their packages): ranks that disagree are refused."""
    text = json.dumps(sim.run_record(), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class RankRun:
    """Run the built simulation ``sim`` on the ranks of ``comm``.

    ``every``: redistribute at least every ``every`` steps (``None``: only when elements
    moved half the skin); ``owner``: a function ``(step, centres) -> rank per element`` that
    replaces the bisection (tests move elements between ranks with it); ``margin``,
    ``min_work`` [s]: split again when the slowest rank's work exceeds the mean by ``margin``,
    measured over at least ``min_work`` per rank.
    """

    def __init__(self, sim, comm: Comm | None = None, every: int | None = None,
                 owner: Callable[[int, np.ndarray], np.ndarray] | None = None,
                 margin: float = REBALANCE_MARGIN, min_work: float = MIN_WORK):
        self.sim = sim
        self.comm = comm or Comm()
        self.rank, self.size = self.comm.rank, self.comm.size
        self.root = self.rank == 0
        self.every = every
        self.owner_fn = owner
        self.margin, self.min_work = margin, min_work
        bad = refusals(sim, self.size)
        if bad:
            raise SceneError(bad[0])
        digests = self.comm.allgather(run_digest(sim))
        if len(set(digests)) > 1:
            odd = next(r for r, d in enumerate(digests) if d != digests[0])
            raise SceneError(f"{sim.scene.label}: rank {odd} was given a different scene or "
                             "plugin versions than rank 0; every rank must run the same")
        self.cuts: Cuts | None = None
        self.work = 0.0  # this rank's measured step time since the last split [s]
        self.exchange_time = 0.0  # [s] in ghost exchanges and the per-step allgather
        self.redistributions = 0
        self.splits = 0
        self.migrated = 0
        self.owner = np.zeros(sim.state.n, dtype=np.int64)
        self._recheck = ""
        self.reports: list[dict[str, float]] | None = None
        self.stepping = 0.0
        #: the joints the ranks created in this step: ``(batch, pair key) -> run's index``
        self._created: dict[tuple[int, int], int] = {}
        with compile_time(sim):  # (the engine's first build may compile: left out of rates)
            self._redistribute(resplit=True)

    # ------------------------------------------------------------------ distribution
    def _redistribute(self, resplit: bool) -> None:
        sim = self.sim
        st = sim.state
        c = centers(st.q)
        if self.owner_fn is not None:
            owner = np.asarray(self.owner_fn(sim.step_index, c), dtype=np.int64)
        else:
            if resplit or self.cuts is None:
                self.cuts = bisect(c, self._weights(), self.size)
                self.work = 0.0
                self.splits += 1
            owner = self.cuts.assign(c)
        self.migrated += int(np.count_nonzero(owner != self.owner))
        self.owner = owner
        gc = sim.contacts
        links = []
        if gc is not None:
            links = [reach_pairs(gc, c), np.stack([gc.ji, gc.jj], axis=1)]
        # a process reading the contacts: the ghosts next to owned elements with all theirs
        depth = 2 if any(p.reads_contacts for p in sim.processes) else 1
        held = local_sets(owner, self.size, links, depth)
        self.ids = held[self.rank]
        self.mine = owner[self.ids] == self.rank  # local rows owned here
        self.own_rows = np.flatnonzero(self.mine)
        self.ghost_rows = np.flatnonzero(~self.mine)
        self.send, recv = exchange_plan(owner, held, self.rank)
        self.send_rows = [np.searchsorted(self.ids, s) for s in self.send]
        self.recv_rows = [np.searchsorted(self.ids, r) for r in recv]
        #: where each rank's ghosts sit among this rank's ghosts (for their damper bounds)
        self.recv_ghosts = [np.searchsorted(self.ghost_rows, r) for r in self.recv_rows]
        if getattr(self, "loc", None) is not None:
            self._close_local()
        self.link = RankLink(sim, self.ids, self.own_rows, self.comm, self.send_rows,
                             self.recv_rows)
        self.loc, self.jg = local_engine(sim, self.ids, self.ghost_rows, self.link)
        self.loc.check_time_step = self._local_check  # (made on the whole run, :meth:`step`)
        lc = self.loc.contacts
        # joints reported here: those whose first element this rank owns
        self.j_mine = (owner[sim.contacts.ji[self.jg]] == self.rank if gc is not None
                       else np.zeros(0, bool))
        if lc is not None:
            lc.ghost_dmob = self._ghost_dmob_from_run()
            lc.n_broken_total = 0
            lc.reports = self.j_mine
        self._local_histories()
        self.ref = c[self.ids[self.own_rows]]
        self.skin = gc.skin if gc is not None else np.inf
        self.since = sim.step_index
        self.redistributions += 1

    def _local_histories(self) -> None:
        """Each process of the rank's engine that keeps history takes its part of the run's
        (:mod:`.history`: its elements, joints and pairs, in local indices)."""
        sim = self.sim
        for run_p, loc_p in zip(sim.processes, self.loc.processes):
            layout = run_p.rank_history
            fresh = loc_p.history()
            if not layout or fresh is None:
                continue
            loc_p.set_history(to_local(layout, run_p.history(), fresh, self.ids, self.jg,
                                       self.rank, sim.state.n, sim.scene.where(run_p.table)))

    def _close_local(self) -> None:
        """Release what the rank's engine's processes opened in their set-up (files)."""
        for proc in self.loc.processes:
            proc.close()

    def _ghost_dmob_from_run(self) -> np.ndarray:
        """The ghosts' damper bounds from the run's joint table (current at a redistribution)."""
        from ..contact.damping import contact_mobility

        full = contact_mobility(self.sim.contacts)
        return full[self.ids[self.ghost_rows]]

    def _weights(self) -> np.ndarray:
        """Per element cost for the bisection: one plus its joints and candidate pairs,
        scaled per rank by the work measured since the last split (``None`` before)."""
        sim = self.sim
        n = sim.state.n
        w = np.ones(n)
        gc = sim.contacts
        if gc is not None and gc.n_joints:
            w += np.bincount(gc.ji, minlength=n) + np.bincount(gc.jj, minlength=n)
        work = self.comm.allgather(self.work) if self.splits else None
        if work is not None and sum(work) > 0:
            share = np.bincount(self.owner, weights=w, minlength=self.size)
            rate = np.array(work) / np.maximum(share, 1e-300)
            w = w * np.where(rate[self.owner] > 0, rate[self.owner] / max(rate.mean(), 1e-300),
                             1.0)
        return w

    # ------------------------------------------------------------------ records
    def _record(self, fields: bool) -> dict[str, Any]:
        """This rank's owned elements, its joints and (``fields``) contact fields: a record
        the run takes (:meth:`_apply`)."""
        ls, lc = self.loc.state, self.loc.contacts
        own = self.own_rows
        rec: dict[str, Any] = {"ids": self.ids[own]}
        for k in ("q", "V", "w", "F", "T"):
            rec[k] = getattr(ls, k)[own]
        ice = self.loc.ice
        if ice.active:  # the ice processes change and the fields components own
            rec["ice"] = {k: v[own] for k, v in ice.values.items()}
            if ice.processes:
                for k in ICE_STATE:
                    rec[k] = getattr(ls, k)[own]
            rec["cats"] = {k: v[own] for k, v in ice._category_arrays().items()}
        hist = {}
        for k, proc in enumerate(self.loc.processes):
            layout = proc.rank_history
            h = proc.history() if layout else None
            if h is not None:
                hist[k] = to_global(layout, h, self.ids, own, self.jg, self.j_mine, self.owner,
                                    self.rank, self.sim.state.n)
        if hist:
            rec["proc_hist"] = hist
        if lc is not None:
            jm = self.j_mine
            rec["jg"] = self.jg[jm]
            for k in JOINT_STATE:
                rec[k] = getattr(lc, k)[jm]
            if fields:
                rec["fields"] = {k: v[own] for k, v in lc.element_fields().items()}
                pairs, active = lc.committed_pairs()  # (one rank counts the committing's)
                ok = active == 1 if len(active) == len(pairs) else None
                if ok is not None and len(pairs):
                    first = self.ids[np.minimum(pairs[:, 0], pairs[:, 1])]
                    rec["overlap"] = int(np.count_nonzero(ok & (self.owner[first] == self.rank)))
                else:
                    rec["overlap"] = 0
            if lc.n_contact_hist:
                keys, rows = lc._chist_pending or lc._contact_rows()
                n = ls.n
                a, b = self.ids[keys // n], self.ids[keys % n]
                keep = self.owner[a] == self.rank
                rec["chist"] = (a[keep], b[keep], rows[keep])
        return rec

    def _apply(self, recs: list[dict[str, Any]], fields: bool) -> None:
        """Put the ranks' records into the run (its state, joint table, contact fields)."""
        sim = self.sim
        st, gc = sim.state, sim.contacts
        ice = sim.ice
        for rec in recs:
            ids = rec["ids"]
            for k in ("q", "V", "w", "F", "T"):
                getattr(st, k)[ids] = rec[k]
            if "ice" in rec:
                for k, v in rec["ice"].items():
                    ice.values[k][ids] = v
                for k in ICE_STATE:
                    if k in rec:
                        getattr(st, k)[ids] = rec[k]
                cats = ice._category_arrays()
                for k, v in rec["cats"].items():
                    cats[k][ids] = v
            if gc is not None:
                for k in JOINT_STATE:
                    getattr(gc, k)[rec["jg"]] = rec[k]
        for k, proc in enumerate(sim.processes):  # their histories, by global identities
            layout = proc.rank_history
            if layout and all(k in rec.get("proc_hist", ()) for rec in recs):
                parts = [(rec["ids"], rec.get("jg", np.zeros(0, np.int64)), rec["proc_hist"][k])
                         for rec in recs]
                proc.set_history(merge(layout, proc.history(), parts))
        if gc is None:
            return
        if ice.processes:  # the run's contact model follows the ice (melted elements gone)
            gc.ice_changed(None, True)
        if fields:
            got: dict[str, np.ndarray] = {}
            for rec in recs:
                for k, v in rec["fields"].items():
                    got.setdefault(k, np.zeros(st.n, dtype=v.dtype))[rec["ids"]] = v
            gc.element_fields = lambda: dict(got)  # (this step's, from the ranks)
            gc.n_overlap = sum(rec["overlap"] for rec in recs)
        if gc.n_contact_hist:
            a = np.concatenate([r["chist"][0] for r in recs])
            b = np.concatenate([r["chist"][1] for r in recs])
            rows = np.concatenate([r["chist"][2] for r in recs]).reshape(-1, gc.n_contact_hist)
            gc._chist_pending = (gc._keys(a, b), rows)

    def _sync_all(self) -> None:
        """Every rank's run holds the whole current state (before a redistribution)."""
        self._apply(self.comm.allgather(self._record(False)), False)

    # ------------------------------------------------------------------ step
    def step(self, write: bool = False) -> None:
        """One step of the run on every rank; with ``write``, the outputs due at its end are
        written (rank 0) before a redistribution replaces the ranks' engines (their contact
        fields are those of the step's last force evaluation)."""
        sim, loc = self.sim, self.loc
        lc = loc.contacts
        if sim.phase_log is not None:
            sim.phase_log.before_step(sim)
        timings = sim.timings  # (the rank's engine's phases add to them too: the same dict)
        t0 = clock()
        loc.step_index = sim.step_index
        loc._commit = True
        loc._force_time = 0.0
        evaluations = [0]

        def forces(t, q, V, w, F, T):
            # a later evaluation of the step (a multi-stage integrator): the ghosts' stage
            # states and bounds from their owners first (the first's are current)
            if evaluations[0]:
                self._exchange(q, V, w)
            evaluations[0] += 1
            loc.compute_forces(t, q, V, w, F, T)
        with parallel.threads_for(loc.state.n):
            loc.integrator.step(loc.state, sim.time, sim.dt, forces)
        t1 = clock()
        self.work += t1 - t0
        timings["integrator"] += t1 - t0 - loc._force_time
        sim.step_index += 1
        loc.step_index = sim.step_index
        self._exchange()
        stepped = lc.take_changes() if lc is not None else None
        failed = self._processes() if loc.processes else None
        t2 = clock()
        breaks = None
        if lc is not None:
            lc._pending = []
            breaks = self._joint_news(stepped, lc.take_changes())
        moved = self._moved()
        sound = self._sound()
        due = self.every is not None and sim.step_index - self.since >= self.every
        recheck, self._recheck = self._recheck, ""
        t3 = clock()
        timings["guard"] += t3 - t2
        news = self.comm.allgather((moved, sound, breaks, self.work, failed, recheck))
        t4 = clock()
        self._exchanged(t4 - t3)
        for got in news:  # a process raised on some rank: the same error on every rank
            if got[4] is not None:
                raise got[4][0](got[4][1])
        self._take_joints([n[2] for n in news if n[2] is not None])
        sim.guard.after_step()  # the joints' guard, on the run's joint table (every rank)
        if not all(n[1] for n in news):
            self._sync_all()
            sim.guard.check()  # raises on every rank alike
        synced = False
        who = next((n[5] for n in news if n[5]), "")
        if who:  # some element's ice changed enough: the stable step of the whole run
            self._sync_all()
            synced = True
            sim.check_time_step(after=who)  # raises on every rank alike
            for run in (sim, self.loc):  # every element checked now, as on one rank
                ice = run.ice
                ice._h_checked[:] = run.state.thickness
                ice._v_checked[:] = ice_per_area(run.state.thickness, ice.categories)
        work = np.array([n[3] for n in news])
        resplit = (self.owner_fn is None and bool(work.min() >= self.min_work)
                   and imbalance(work) > self.margin)
        t5 = clock()
        timings["guard"] += t5 - t4
        if write:
            self._write()
        if sim.step_index < sim.n_steps and (any(n[0] for n in news) or due or resplit):
            t6 = clock()
            if not synced:
                self._sync_all()
            self._redistribute(resplit=resplit)
            timings["redistribute"] += clock() - t6
        sim.timed_steps += 1

    def _processes(self) -> tuple[type, str] | None:
        """The processes due at this step on the rank's engine, then the ghosts' new damper
        bounds from their owners; an error they raise is returned (type, message) for every
        rank to raise (it may arise on some ranks only: the elements it names)."""
        loc = self.loc
        if not any(loc.step_index % every == 0 for every in loc._process_every):
            return None
        t0 = clock()
        ex0 = self.exchange_time
        failed = None
        ran = []
        lc = loc.contacts
        for k, (proc, every) in enumerate(zip(loc.processes, loc._process_every)):
            if loc.step_index % every:
                continue
            if lc is not None:  # the joints it creates are numbered after the earlier ones'
                lc.create_batch = k
            if failed is None:  # (after an error: the exchanges only, as on every rank)
                try:
                    before = loc.ice.before_process()
                    proc.apply(loc.context, every * loc.dt)
                    loc.ice.after_process(before, f"process '{proc.name}'")
                    ran.append(f"process '{proc.name}'")
                except SikuError as exc:
                    failed = type(exc), str(exc)
            if proc.reads_contacts:
                # its change of a ghost may lack the ghost's contacts beyond this rank: the
                # ghosts take their owners' ice before the next process reads it
                self._exchange_ice()
        if ran and failed is None:
            try:
                loc.ice.after_processes(" and ".join(ran))
            except SikuError as exc:
                failed = type(exc), str(exc)
        spent = clock() - t0 - (self.exchange_time - ex0)  # (its ghosts' ice exchanges apart)
        self.work += spent
        self.sim.timings["processes"] += spent
        self._exchange()
        return failed

    def _exchange_ice(self) -> None:
        """Owners' ice (thickness, flags, categories, declared fields) to the ranks holding
        their elements as ghosts; a ghost its owner melted melts here too (its joints break
        here as there)."""
        t0 = clock()
        loc = self.loc
        ls, ice = loc.state, loc.ice
        arrays = {"thickness": ls.thickness, "flags": ls.flags, **ice._category_arrays(),
                  **{f"field:{k}": v for k, v in ice.values.items()}}
        out = []
        for s, rows in enumerate(self.send_rows):
            out.append(None if s == self.rank or not len(rows)
                       else {k: v[rows] for k, v in arrays.items()})
        got = self.comm.alltoall(out)
        for s, rows in enumerate(self.recv_rows):
            rec = got[s]
            if rec is None or not len(rows):
                continue
            melted = rows[(rec["flags"] == MELTED) & (ls.flags[rows] != MELTED)]
            for k, v in rec.items():
                if k != "flags":
                    arrays[k][rows] = v
            if len(melted):
                ice.melt(melted)
        self._exchanged(clock() - t0)

    def _exchanged(self, seconds: float) -> None:
        """Count ``seconds`` [s] as this rank's time in exchanges with the others."""
        self.exchange_time += seconds
        self.sim.timings["exchange"] += seconds

    def _local_check(self, after: str = "") -> None:
        """The rank's engine's stable-step check after its processes changed the ice: noted,
        and made on the whole run by every rank (:meth:`step`)."""
        self._recheck = after

    def _exchange(self, *arrays: np.ndarray) -> None:
        """Owners' new states (and damper bounds) to the ranks holding them as ghosts: of the
        state, or of the arrays ``q, V, w`` an integrator evaluates forces at."""
        t0 = clock()
        ls, lc = self.loc.state, self.loc.contacts
        q, V, w = arrays or (ls.q, ls.V, ls.w)
        dmob = lc.own_mobility() if lc is not None and len(self.ghost_rows) + sum(
            len(s) for s in self.send) else None
        out = []
        for s, rows in enumerate(self.send_rows):
            if s == self.rank or not len(rows):
                out.append(None)
                continue
            rec = {"q": q[rows], "V": V[rows], "w": w[rows]}
            if dmob is not None:
                rec["dmob"] = dmob[rows]
            out.append(rec)
        got = self.comm.alltoall(out)
        for s, rows in enumerate(self.recv_rows):
            rec = got[s]
            if rec is None or not len(rows):
                continue
            q[rows], V[rows], w[rows] = rec["q"], rec["V"], rec["w"]
            if lc is not None and "dmob" in rec:
                lc.ghost_dmob[self.recv_ghosts[s]] = rec["dmob"]
        self._exchanged(clock() - t0)

    def _moved(self) -> bool:
        """Whether an owned element moved half the skin since the redistribution."""
        if not np.isfinite(self.skin) or not len(self.own_rows):
            return False
        return farthest_moved2(self.loc.state.q, self.own_rows, self.ref) > (0.5 * self.skin) ** 2

    def _sound(self) -> bool:
        sim = self.sim
        k = sim.step_index
        if not (k % sim.scene.cfg.run.nan_check_every == 0 or k == sim.n_steps
                or sim.state_schedule.due(k, sim.n_steps)):  # (rank 0 checks a snapshot)
            return True
        ls = self.loc.state
        own = self.own_rows
        vmax = sim.scene.cfg.run.max_speed
        if not rows_sound(ls.F, ls.T, ls.V, ls.w, ls.q, vmax * vmax, own):
            return False
        for _, _, arr, bound in integrated_fields(self.loc):  # (the guard's, on the run)
            v = arr[own]
            if not np.isfinite(v).all() or bound == "speed" and len(v) and (
                    np.abs(v).max() > vmax):
                return False
        return True

    def _joint_news(self, stepped: tuple[np.ndarray, np.ndarray, np.ndarray],
                    processed: tuple[np.ndarray, np.ndarray, np.ndarray]
                    ) -> dict[str, Any] | None:
        """What this rank reports of the step's joint changes: the joints that broke in the
        step's force evaluations, then those that broke in its processes (global indices,
        with the pass of a check in which each broke), the new state of every joint that
        broke or refroze (of those it reports), and the joints its processes created (of those
        it reports: their elements' global indices, batch, line and state; a break of one is
        named by its place among them)."""
        lc = self.loc.contacts
        rep = lc.reports
        old = len(self.jg)
        b1, p1, c1 = stepped
        b2, p2, c2 = processed
        changed = np.union1d(c1, c2)
        changed = changed[rep[changed] & (changed < old)]
        fresh = np.arange(old, lc.n_joints)
        fresh = fresh[rep[fresh]]
        if not len(changed) and not len(fresh):
            return None
        broke, passes, broke_new, passes_new = [], [], [], []
        for b, pb in ((b1, p1), (b2, p2)):
            keep = rep[b]
            b, pb = b[keep], pb[keep]
            was = b < old
            broke.append(self.jg[b[was]])
            passes.append(pb[was])
            broke_new.append(np.searchsorted(fresh, b[~was]))
            passes_new.append(pb[~was])
        news: dict[str, Any] = {"broke": tuple(broke), "passes": tuple(passes),
                                "broke_new": tuple(broke_new), "passes_new": tuple(passes_new),
                                "jg": self.jg[changed]}
        for k in JOINT_STATE:
            news[k] = getattr(lc, k)[changed]
        if len(fresh):
            first = lc.n_joints - len(lc.created_batch)  # (the first joint created here)
            news["created"] = {
                "batch": lc.created_batch[fresh - first],
                "pairs": np.stack([self.ids[lc.ji[fresh]], self.ids[lc.jj[fresh]]], axis=1),
                "ends_i": lc.ends_i[fresh], **{k: getattr(lc, k)[fresh] for k in JOINT_STATE}}
        return news

    def _take_created(self, parts: list[dict[str, Any]]) -> list[np.ndarray]:
        """Append the joints the ranks' processes created to the run's joint table, numbered as
        one rank numbers them (batch after batch, by pair key within one), in the state their
        reporters give; every rank alike. Returns, per part, the run's indices of its created
        joints (in its order), and keeps the step's ``(batch, key) -> index`` for
        :meth:`_number_created`."""
        gc = self.sim.contacts
        n = self.sim.state.n
        made = [p.get("created") for p in parts]
        self._created = {}
        if not any(c is not None for c in made):
            return [np.zeros(0, np.int64) for _ in parts]
        got = [c for c in made if c is not None]
        batch = np.concatenate([c["batch"] for c in got])
        pairs = np.concatenate([c["pairs"] for c in got])
        key = pairs.min(axis=1) * n + pairs.max(axis=1)
        order = np.lexsort((key, batch))
        free = gc.joint_slots - gc.n_joints
        if len(order) > free:
            proc = self.sim.processes[int(batch[order[free]])]
            where = self.sim.scene.where(proc.table) if proc.table else "process"
            raise SceneError(f"{where}: process '{proc.name}' needs more than the {free} "
                             "joint slots the run has left for new joints (of the "
                             f"{proc.joints_to_create(n)} it reserves); raise its capacity "
                             "for new joints")
        new = gc.create_joints(pairs[order], np.concatenate([c["ends_i"] for c in got])[order])
        for k in JOINT_STATE:  # (the state its reporter's engine gave it, not the run's)
            getattr(gc, k)[new] = np.concatenate([c[k] for c in got])[order]
        number = np.empty(len(order), np.int64)
        number[order] = new
        self._created = {(int(b), int(k)): int(j) for b, k, j in zip(batch, key, number)}
        out, at = [], 0
        for c in made:
            m = 0 if c is None else len(c["batch"])
            out.append(number[at:at + m])
            at += m
        return out

    def _number_created(self) -> None:
        """The run's indices of the joints this rank's engine created in the step
        (:meth:`_take_created`): its joint table then maps to the run's again. Every rank
        holding both elements of a created joint created it, deciding from the same inputs;
        a rank that did not (or made one the run has not) is an error of the process."""
        lc = self.loc.contacts
        if lc is None:
            return
        made = self._created
        old, m = len(self.jg), lc.n_joints
        if m == old and not made:
            return
        n = self.sim.state.n
        x = np.arange(old, m)
        a, b = self.ids[lc.ji[x]], self.ids[lc.jj[x]]
        key = np.minimum(a, b) * n + np.maximum(a, b)
        batch = lc.created_batch[x - (m - len(lc.created_batch))]
        number = np.array([made.get((int(c), int(k)), -1) for c, k in zip(batch, key)],
                          dtype=np.int64)
        gc = self.sim.contacts
        held = np.zeros(n, dtype=bool)
        held[self.ids] = True
        expect = sum(1 for j in made.values() if held[gc.ji[j]] and held[gc.jj[j]])
        if (number < 0).any() or expect != len(x) or (np.diff(number) <= 0).any():
            raise SikuError(f"rank {self.rank}: the joints its processes created are not those "
                            "the ranks created (a process creating joints must decide each "
                            "from the pair's two elements alone, in ascending pair order)")
        self.jg = np.concatenate([self.jg, number])
        self.link.jg = self.jg
        self.j_mine = lc.reports

    def _take_joints(self, parts: list[dict[str, Any]]) -> None:
        """Apply the ranks' reported joint changes to the run's joint table: the new state of
        the joints that broke or refroze, and the breaks in the order one rank records them
        (those of the force evaluations, then those of the processes, each by the pass of a
        check in which they broke, then in joint order)."""
        gc = self.sim.contacts
        self._created = {}
        if gc is None:
            return
        numbers = self._take_created(parts)  # (before any break names one of them)
        self._number_created()  # (before the rank's joints are gathered again)
        if not parts:
            return
        j = np.concatenate([p["jg"] for p in parts])
        for k in JOINT_STATE:
            getattr(gc, k)[j] = np.concatenate([p[k] for p in parts])
        for phase in (0, 1):
            b = np.concatenate([p["broke"][phase] for p in parts]
                               + [num[p["broke_new"][phase]] for p, num in zip(parts, numbers)])
            passes = np.concatenate([p["passes"][phase] for p in parts]
                                    + [p["passes_new"][phase] for p in parts])
            b = b[np.lexsort((b, passes))]
            gc.n_broken_total += len(b)
            if self.root:
                gc._pending.extend(b.tolist())
        made = bool(self._created)
        refroze = bool(gc.intact[j].any()) or made
        if refroze:  # their rest state changed: the run's joint constants follow
            gc.refresh_joint_constants()
        nw = self.sim.guard.network
        if nw.cm is not None:  # the joints' guard rechecks the step on the run's state
            old = nw._checked
            changed = int(np.count_nonzero(gc.intact[:len(old)] != old)
                          + np.count_nonzero(gc.intact[len(old):]))
            if changed > RECHECK_JOINTS * max(nw._n_checked, 1):
                self._sync_all()
                if refroze:
                    gc.refresh_joint_constants()

    # ------------------------------------------------------------------ running
    def _write(self, force: bool = False) -> None:
        sim = self.sim
        k, last = sim.step_index, sim.n_steps
        if not (force or sim.state_schedule.due(k, last) or sim.diag_schedule.due(k, last)):
            return
        t0 = clock()
        self.gather_all()
        sim.timings["output"] += clock() - t0  # (the gather; rank 0's writing adds its own)
        if self.root:
            sim._write(force=force, diagnostics=not force or sim.restarted_from is None)

    def gather_all(self) -> None:
        """The whole run's state, joints, contact fields and diagnostics on rank 0 now (as on
        an output step; every rank calls it)."""
        recs = self.comm.gather(self._record(True))
        if self.root:
            self._apply(recs, True)

    def joints_agree(self) -> bool:
        """Whether every joint held on more than one rank has the same state on each
        (intact, break mode and time, history): a joint across a boundary broke once, in the
        same step on both sides. Every rank calls it; the answer is the same on each."""
        lc = self.loc.contacts
        mine = (self.jg, lc.intact, lc.break_mode, lc.break_time, lc.hist) if lc is not None \
            else None
        seen: dict[int, tuple] = {}
        for got in self.comm.allgather(mine):
            if got is None:
                continue
            for k, j in enumerate(got[0].tolist()):
                row = (bool(got[1][k]), int(got[2][k]), got[3][k].tobytes(), got[4][k].tobytes())
                if seen.setdefault(j, row) != row:
                    return False
        return True

    def run(self) -> "RankRun":
        """Run to the scene's end; a rank that raises ends the run on every rank
        (:meth:`Comm.abort`, one line naming the rank and the cause)."""
        sim = self.sim
        try:
            if self.root:
                sim.open_outputs()
            t0 = clock()
            with compile_time(sim):
                while sim.step_index < sim.n_steps:
                    self.step(write=True)
            #: seconds this rank stepped (its outputs included, compilation left out) [s]
            self.stepping = clock() - t0
            #: every rank's :meth:`report` (rank 0; ``None`` on the others)
            self.reports = self.comm.gather(self.report())
        except (KeyboardInterrupt, SystemExit):
            raise
        except Exception as exc:
            from ..errors import NonFiniteError, StabilityError

            if isinstance(exc, (NonFiniteError, StabilityError)):
                raise  # decided on every rank alike: each ends by itself
            msg = " | ".join(str(exc).splitlines()) or type(exc).__name__
            self.comm.abort(f"siku: error: rank {self.rank}: {type(exc).__name__}: {msg}")
        finally:
            self._close_local()
            if self.root:
                sim.close()
        return self

    def report(self) -> dict[str, float]:
        """This rank's numbers: ``work`` (the step's computation since the last split) and
        ``exchange`` [s], ``sent_bytes``, the elements it ``held`` and ``owned`` last, and
        from the run's phase timers (compilation left out) its ``steps`` taken, ``busy`` [s]
        (every phase but the exchanges and the redistributions), ``exchanged`` and
        ``redistributing`` [s], and ``stepping`` [s], the time of its steps and outputs."""
        t = self.sim.timings
        spent = sum(t.values()) - t["exchange"] - t["redistribute"]
        return {"work": self.work, "exchange": self.exchange_time,
                "sent_bytes": float(self.comm.sent_bytes), "held": float(len(self.ids)),
                "owned": float(len(self.own_rows)), "steps": float(self.sim.timed_steps),
                "busy": spent, "exchanged": t["exchange"], "redistributing": t["redistribute"],
                "stepping": self.stepping}

    def profile_table(self) -> str:
        """Every rank's share of the run (rank 0, after :meth:`run`): its elements, steps,
        seconds busy in its own phases, in exchanges with the others (ghost states and ice,
        the per-step agreement) and in redistributions, and the exchange's share of its
        stepping time (:attr:`stepping`: compilation left out)."""
        lines = [f"ranks: {self.size} (each rank's own phase timers; rank 0's phases above)",
                 f"  {'rank':>4} {'owned':>9} {'held':>9} {'steps':>7} {'busy s':>9} "
                 f"{'exchange s':>10} {'share':>6} {'redistribute s':>14} {'sent kB/step':>12}"]
        for r, rep in enumerate(self.reports or []):
            steps = max(rep["steps"], 1.0)
            wall = rep["stepping"]
            share = 100.0 * rep["exchanged"] / wall if wall > 0 else 0.0
            lines.append(f"  {r:>4} {int(rep['owned']):>9} {int(rep['held']):>9} "
                         f"{int(rep['steps']):>7} {rep['busy']:9.3f} {rep['exchanged']:10.3f} "
                         f"{share:5.1f}% {rep['redistributing']:14.3f} "
                         f"{rep['sent_bytes'] / steps / 1e3:12.2f}")
        return "\n".join(lines)


def run_on_ranks(sim, **kwargs: Any) -> RankRun:
    """Run ``sim`` on the ranks it was launched among (``mpiexec -n N``)."""
    return RankRun(sim, **kwargs).run()


__all__ = ["REBALANCE_MARGIN", "RankRun", "refusal_reason", "refusals", "run_digest",
           "run_on_ranks"]
