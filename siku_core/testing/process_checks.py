"""The process conformance suite: checks any process (``siku_core.interfaces.Process``),
built-in or third-party, must pass.

.. code-block:: python

    from siku_core.testing.process_checks import check_process

    def test_my_growth_process_conforms(tmp_path):
        check_process(MyGrowth, {"rate": 1e-6}, tmp_path)

Each check runs the process in a small bonded pack (12 elements of 2 km, jointed by
``distributed_spring`` or the ``law`` given, at rest, no forcing; 40 steps of 0.4 s, the
process every step unless ``every`` is given; with ``categories = (a_k, h_k)`` every element has
those thickness categories) and raises ``AssertionError`` saying what
failed:

* :func:`check_process_finite`: thickness finite and positive, declared fields finite, every
  run's state finite;
* :func:`check_process_conservation`: a process that ``conserves`` ``"volume"`` keeps the total
  ice volume (:func:`ice_volume`) of the elements not melted to 1e-12 relative; any other process
  changes it by exactly its ``budget`` (growth minus melt) to 1e-10 relative;
* :func:`check_process_idempotent`: applied over no time (``dt = 0``) it changes nothing, and
  two runs of the same scene end bit for bit equal;
* :func:`check_process_restart`: a run restarted from a mid-run snapshot ends bit for bit equal
  to an uninterrupted one (state, thickness, declared fields, history);
* :func:`check_process_on_ranks`: a process that declares ``runs_on_ranks = True`` changes
  every other element, set up over those elements alone as an MPI rank sets it up (its
  ``setup_on_rank``, from the run's copy), as it changes them among all, bit for bit
  (thickness, mass, inertia, flags, declared fields, thickness categories); one that also
  declares ``reads_contacts`` is set up over a third of the elements and their contact partners
  (its ghosts), with its history split as its ``rank_history`` says, stepped once beside the
  whole run, and must change those elements, the joints they report and its history of them as
  among all, bit for bit.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..categories import element_volume
from ..plugins import Registry
from ..scene.scene_file import scene_from_text
from ..state import MELTED
from .contact_cases import registry_with, square_pack
from .scenes import scene_text, toml_value

#: the conformance scene: steps and step [s]
PROCESS_STEPS, PROCESS_DT = 40, 0.4


def process_registry(cls: type, registry: Registry | None = None) -> Registry:
    """A registry holding process ``cls`` (under its ``name``) next to the components of
    ``registry`` (default: the process-wide one)."""
    return registry_with("process", cls, registry)


def process_scene_text(name: str, params: Mapping[str, Any] | None = None,
                       every: float | None = None, steps: int = PROCESS_STEPS,
                       dt: float = PROCESS_DT,
                       out: str | None = None, thickness: float = 0.5,
                       law: str = "distributed_spring", categories: Any = None) -> str:
    """The conformance scene (module docstring) with process ``name`` and ``params``; ``out``
    writes an HDF5 file every 10 steps; ``law``: the contact law (a process that needs one,
    e.g. ``ridging``); ``categories``: ``(a_k, h_k)`` [1], [m] that every element of the pack
    has (thickness categories; a process that needs them, e.g. lateral growth)."""
    proc = f'[[process]]\nname = "{name}"\n'
    if params:
        proc += f"params = {toml_value(dict(params))}\n"
    if every is not None:
        proc += f"every = {every!r}\n"
    output = (f'\n[output]\nfile = {toml_value(out)}\nevery = {10 * dt!r}\n'
              if out is not None else "")
    pack = square_pack(0.0, 80.0, 4, 3, size=2000.0)
    if categories is not None:  # the same pack from the source that adds categories
        src = f'[[elements.source]]\nname = "{CATEGORY_PACK}"\nparams = ' \
              f'{toml_value(pack)}\n\n'
        return scene_text([], dt=dt, duration=steps * dt, thickness=thickness,
                          extra=src + f'[contact]\nlaw = "{law}"\n\n' + proc + output)
    return scene_text([], packs=[pack], dt=dt, duration=steps * dt, thickness=thickness,
                      extra=f'[contact]\nlaw = "{law}"\n\n' + proc + output)


def process_simulation(cls: type, params: Mapping[str, Any] | None = None, *,
                       out: Path | None = None, restart: Path | None = None, **kwargs: Any):
    """A :class:`~siku_core.run.simulation.Simulation` of the conformance scene with ``cls``."""
    from ..run.simulation import Simulation

    text = process_scene_text(cls.name, params, out=None if out is None else str(out), **kwargs)
    scene = scene_from_text(text, f"<process conformance {cls.name}>")
    registry = process_registry(cls)
    if kwargs.get("categories") is not None:
        pack = registry.get("element_source", "pack")
        registry = registry_with("element_source", category_pack(kwargs["categories"], pack),
                                 registry)
    return Simulation(scene, out=False if out is None else out, restart=restart,
                      progress=False, registry=registry)


#: the element source of the conformance scene with categories
CATEGORY_PACK = "conformance_category_pack"


def category_pack(categories: Any, pack: type) -> type:
    """The element source ``pack`` (the registry's ``pack``) whose every element has the
    thickness categories ``categories`` (``(a_k, h_k)``): the conformance scene's with them."""
    cats = tuple(np.asarray(x, dtype=float) for x in categories)

    class CategoryPack(pack):
        name = CATEGORY_PACK

        def build(self, scene, seed, where):
            out = super().build(scene, seed, where)
            for spec in out:
                spec.categories = cats
            return out

    return CategoryPack


def ice_volume(sim: Any) -> float:
    """Total ice volume of the elements not melted [m³]: ``sum(area h)``, or with thickness
    categories ``sum(area sum_k a_k h_k)`` (:func:`~siku_core.categories.element_volume`)."""
    st = sim.state
    live = st.flags != MELTED
    return math.fsum(element_volume(st.area, st.thickness, sim.context.categories)[live])


def _procs(sim: Any, cls: type) -> list:
    return [p for p in sim.processes if isinstance(p, cls)]


def check_process_finite(cls: type, params: Mapping[str, Any] | None = None,
                         **kwargs: Any) -> None:
    sim = process_simulation(cls, params, **kwargs)
    sim.run()
    st = sim.state
    assert np.isfinite(st.thickness).all() and (st.thickness > 0).all(), (
        f"process '{cls.name}': thickness not finite and positive: {st.thickness}")
    for name, arr in sim.context.fields.items():
        assert np.isfinite(arr).all(), f"process '{cls.name}': field '{name}' not finite"
    for k in ("q", "V", "w", "m", "I"):
        assert np.isfinite(getattr(st, k)).all(), f"process '{cls.name}': {k} not finite"


def check_process_conservation(cls: type, params: Mapping[str, Any] | None = None,
                               **kwargs: Any) -> None:
    sim = process_simulation(cls, params, **kwargs)
    v0 = ice_volume(sim)
    sim.run()
    v1 = ice_volume(sim)
    procs = _procs(sim, cls)
    scale = max(abs(v0), abs(v1))
    if "volume" in cls.conserves:
        assert abs(v1 - v0) <= 1e-12 * scale, (
            f"process '{cls.name}' declares that it conserves volume, but the ice volume went "
            f"from {v0!r} to {v1!r} m³")
        return
    budget = math.fsum(p.budget(sim.context) for p in procs)
    assert abs((v1 - v0) - budget) <= 1e-10 * scale, (
        f"process '{cls.name}': the ice volume changed by {v1 - v0!r} m³ but its budget says "
        f"{budget!r} m³")


def _snapshot(sim: Any) -> dict[str, np.ndarray]:
    st = sim.state
    out = {k: getattr(st, k).copy() for k in ("q", "V", "w", "thickness", "m", "I", "flags")}
    out.update({f"field:{k}": v.copy() for k, v in sim.context.fields.items()})
    for key, arrays in sim.history_arrays().items():
        out.update({f"{key}/{k}": np.array(v) for k, v in arrays.items()})
    return out


def _assert_same(a: dict, b: dict, what: str) -> None:
    assert a.keys() == b.keys(), f"{what}: different arrays {sorted(a)} vs {sorted(b)}"
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=True), f"{what}: '{k}' differs"


def check_process_idempotent(cls: type, params: Mapping[str, Any] | None = None,
                             **kwargs: Any) -> None:
    sim = process_simulation(cls, params, **kwargs)
    sim.run(steps=PROCESS_STEPS // 2)
    before = _snapshot(sim)
    for p in _procs(sim, cls):
        p.apply(sim.context, 0.0)
    sim.ice.after_processes(f"process '{cls.name}'")
    after = _snapshot(sim)
    for k in before:
        if k.startswith("field:") or k in ("thickness", "m", "I", "flags", "q", "V", "w"):
            assert np.array_equal(before[k], after[k], equal_nan=True), (
                f"process '{cls.name}' applied over dt = 0 changed '{k}'")
    a = process_simulation(cls, params, **kwargs).run()
    b = process_simulation(cls, params, **kwargs).run()
    _assert_same(_snapshot(a), _snapshot(b), f"process '{cls.name}': two runs of one scene")


def check_process_restart(cls: type, params: Mapping[str, Any] | None, tmp_path: Path,
                          **kwargs: Any) -> None:
    tmp_path = Path(tmp_path)
    whole = process_simulation(cls, params, out=tmp_path / "whole.h5", **kwargs).run()
    part = tmp_path / "part.h5"
    process_simulation(cls, params, out=part, **kwargs).run(steps=PROCESS_STEPS // 2)
    again = process_simulation(cls, params, out=part, restart=part, **kwargs)
    assert again.step_index == PROCESS_STEPS // 2, f"restart began at step {again.step_index}"
    again.run()
    _assert_same(_snapshot(whole), _snapshot(again),
                 f"process '{cls.name}': restart from step {PROCESS_STEPS // 2}")


def _ice(sim: Any) -> dict[str, np.ndarray]:
    """What processes change per element: the ice book's arrays and mass, inertia."""
    st = sim.state
    return {"m": st.m, "I": st.I, **sim.ice.element_fields()}


def check_process_on_ranks(cls: type, params: Mapping[str, Any] | None = None,
                           **kwargs: Any) -> None:
    """A process that runs on ranks (``runs_on_ranks``) changes every other element, set up
    over those elements alone (``siku_core.ranks.local``), as it changes them among all, bit
    for bit; one that reads the contacts (``reads_contacts``) is checked on a rank holding a
    third of the elements and their ghosts (:func:`_check_contacts_on_ranks`); a process that
    declares it cannot run on ranks is not checked."""
    from ..ranks.driver import refusal_reason
    from ..ranks.local import local_engine

    sim = process_simulation(cls, params, **kwargs)
    if any(refusal_reason(p) for p in _procs(sim, cls)):
        return
    sim.run(steps=PROCESS_STEPS // 2)  # a state the process has changed
    if any(p.reads_contacts for p in sim.processes):
        return _check_contacts_on_ranks(cls, sim)
    ids = np.arange(1, sim.state.n, 2)
    loc, _ = local_engine(sim, ids, np.zeros(0, dtype=np.int64))
    loc.check_time_step = lambda after="": None  # (the run's check, below)
    for run in (sim, loc):
        for p in run.processes:
            p.apply(run.context, PROCESS_DT)
        run.ice.after_processes(f"process '{cls.name}'")
    a, b = _ice(sim), _ice(loc)
    for k in b:
        bad = ~(np.asarray(a[k])[ids] == b[k]).reshape(len(ids), -1).all(axis=1)
        i = int(np.argmax(bad)) if len(bad) else 0
        assert not bad.any(), (
            f"process '{cls.name}': '{k}' of element {ids[i]} is {b[k][i]!r} when set up over "
            f"a subset of the elements, {np.asarray(a[k])[ids[i]]!r} among all: a process that "
            "runs on ranks must change each element by itself (or set runs_on_ranks = False)")


def _check_contacts_on_ranks(cls: type, sim: Any) -> None:
    """:func:`check_process_on_ranks` for a process that reads the contacts: a rank owning the
    first third of the elements (of three, by bisection) holds them and their ghosts
    (``siku_core.ranks.ghosts``), takes its part of the processes' history, and steps once
    beside the whole run, its ghosts taking the run's state after the integrator and the run's
    ice after each process that reads the contacts (as the ranks driver does); its owned
    elements, the joints it reports and its part of the history must then be the run's, bit
    for bit."""
    from ..geometry.quat import centers
    from ..ranks import history as rh
    from ..ranks.decompose import bisect
    from ..ranks.ghosts import local_sets, reach_pairs
    from ..ranks.local import JOINT_STATE, local_engine

    n, gc = sim.state.n, sim.contacts
    c = centers(sim.state.q)
    owner = bisect(c, np.ones(n), 3).assign(c)  # this rank (0) owns a third
    links = [] if gc is None else [reach_pairs(gc, c), np.stack([gc.ji, gc.jj], axis=1)]
    ids = local_sets(owner, 3, links)[0]
    own = np.flatnonzero(owner[ids] == 0)
    ghosts = np.flatnonzero(owner[ids] != 0)
    loc, jg = local_engine(sim, ids, ghosts)
    loc.check_time_step = lambda after="": None  # (the run's check)
    lc = loc.contacts
    reports = owner[gc.ji[jg]] == 0 if gc is not None else np.zeros(0, bool)
    if lc is not None:
        lc.reports = reports
    for rp, lp in zip(sim.processes, loc.processes):
        layout = rp.rank_history
        if layout and lp.history() is not None:
            lp.set_history(rh.to_local(layout, rp.history(), lp.history(), ids, jg, 0, n, ""))
    t = sim.time
    made = gc.n_joints if gc is not None else 0  # (the joints the processes create follow)
    for run in (sim, loc):  # one step of the integrator, the ghosts then the run's
        run._commit = True
        run._force_time = 0.0
        run.integrator.step(run.state, t, sim.dt, run.compute_forces)
    for k in ("q", "V", "w"):
        getattr(loc.state, k)[ghosts] = getattr(sim.state, k)[ids[ghosts]]
    sim.step_index += 1
    loc.step_index = sim.step_index
    ran = []
    for rp, lp in zip(sim.processes, loc.processes):
        for run, proc in ((sim, rp), (loc, lp)):
            before = run.ice.before_process()
            proc.apply(run.context, PROCESS_DT)
            run.ice.after_process(before, f"process '{proc.name}'")
        ran.append(f"process '{rp.name}'")
        if lp.reads_contacts:  # the ghosts take their owners' ice
            rows = ids[ghosts]
            loc.state.thickness[ghosts] = sim.state.thickness[rows]
            for name, arr in loc.ice._category_arrays().items():
                arr[ghosts] = sim.ice._category_arrays()[name][rows]
            for name, arr in loc.ice.values.items():
                arr[ghosts] = sim.ice.values[name][rows]
    for run in (sim, loc):
        run.ice.after_processes(" and ".join(ran))
    what = f"process '{cls.name}' on a rank holding a third of the elements and its ghosts"
    if lc is not None and (lc.n_joints > len(jg) or gc.n_joints > made):
        jg, reports = _created_on_rank(what, sim, lc, ids, jg, made), lc.reports
    a, b = _ice(sim), _ice(loc)
    for k in b:
        bad = ~(np.asarray(a[k])[ids[own]] == b[k][own]).reshape(len(own), -1).all(axis=1)
        i = int(np.argmax(bad)) if len(bad) else 0
        assert not bad.any(), (
            f"{what}: '{k}' of element {ids[own][i]} is {b[k][own][i]!r}, "
            f"{np.asarray(a[k])[ids[own][i]]!r} among all: a process that reads the contacts "
            "must change an element from its own contacts (ctx.contacts) alone")
    if lc is not None:
        mine = np.flatnonzero(reports)
        for k in JOINT_STATE:
            same = np.asarray(getattr(gc, k))[jg[mine]].tobytes() == np.asarray(
                getattr(lc, k))[mine].tobytes()
            assert same, f"{what}: the joints' {k} differ from the run's"
    for rp, lp in zip(sim.processes, loc.processes):
        layout = rp.rank_history
        if not layout or lp.history() is None:
            continue
        part = rh.to_global(layout, lp.history(), ids, own, jg, reports, owner, 0, n)
        whole = rh.to_global(layout, rp.history(), np.arange(n), np.flatnonzero(owner == 0),
                             np.arange(len(gc.ji) if gc is not None else 0),
                             owner[gc.ji] == 0 if gc is not None else np.zeros(0, bool),
                             owner, 0, n)
        for name, kind in layout.items():
            if kind in ("total", "pair_count") or name not in whole:
                continue  # (a share of the run's, the count of the keys compared, or an
                # array this configuration of the process does not keep)
            assert np.asarray(part[name]).tobytes() == np.asarray(whole[name]).tobytes(), (
                f"{what}: its history '{name}' ({kind}) differs from the run's")


def _created_on_rank(what: str, sim: Any, lc: Any, ids: np.ndarray, jg: np.ndarray,
                     made: int) -> np.ndarray:
    """The run's indices of the rank's joints (``jg`` and those its processes created, which
    must be the run's new joints between two elements it holds, in the run's order)."""
    n, gc = sim.state.n, sim.contacts
    x = np.arange(len(jg), lc.n_joints)
    a, b = ids[lc.ji[x]], ids[lc.jj[x]]
    local = np.minimum(a, b) * n + np.maximum(a, b)
    new = np.arange(made, gc.n_joints)
    held = np.zeros(n, dtype=bool)
    held[ids] = True
    new = new[held[gc.ji[new]] & held[gc.jj[new]]]
    run = np.minimum(gc.ji[new], gc.jj[new]) * n + np.maximum(gc.ji[new], gc.jj[new])
    assert local.tolist() == run.tolist(), (
        f"{what}: it created joints between elements {list(zip(a.tolist(), b.tolist()))}, "
        f"among all between {list(zip(gc.ji[new].tolist(), gc.jj[new].tolist()))}: a process "
        "that creates joints on ranks must decide each from its pair's two elements, in "
        "ascending pair order")
    return np.concatenate([jg, new])


def check_process(cls: type, params: Mapping[str, Any] | None = None,
                  tmp_path: Path | None = None, **kwargs: Any) -> None:
    """Every check of the suite (the restart check only with a ``tmp_path`` to write in)."""
    check_process_finite(cls, params, **kwargs)
    check_process_conservation(cls, params, **kwargs)
    check_process_idempotent(cls, params, **kwargs)
    check_process_on_ranks(cls, params, **kwargs)
    if tmp_path is not None:
        check_process_restart(cls, params, tmp_path, **kwargs)
