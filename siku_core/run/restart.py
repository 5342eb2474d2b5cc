"""Restarting a run: the writer's last snapshot checked against the scene and put into the run.

A restart continues a run bit for bit from the last complete snapshot of its output. The
writer reads the file (:meth:`~siku_core.interfaces.Writer.read_restart`); here the run record
stored with it is compared with the scene's (only the keys of :data:`RESTART_MAY_CHANGE` may
differ without ``--force``), ``--extend`` lengthens a finished run, and the state, the step and
every component's history are restored.
"""
from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import SceneError
from .limits import check_limits
from .outputs import options, restart_differences
from ..scene.scene_file import Scene

if TYPE_CHECKING:  # pragma: no cover
    from ..context import Run

#: run-record keys a restart may change: how long, where and how often to write, safety switches
RESTART_MAY_CHANGE = ("scene.time.duration", "scene.time.end", "scene.output", "scene.title",
                      "scene.run.progress", "scene.run.nan_check_every", "scene.run.max_speed",
                      "scene.run.dt_safety", "scene.run.allow_unstable_dt",
                      "scene.run.break_guard",
                      "scene.elements.mesh.cache", "scene.elements.mesh.mesh_file")
#: history arrays whose first axis (one entry per contact) changes length from snapshot to
#: snapshot (``ContactModel.history`` under a law with ``contact_history_names``); a file
#: pads them to its longest (integers with -1, floats with NaN) and ``contact_count`` says how
#: many entries are real
RAGGED_HISTORY = frozenset({"contact_pairs", "contact_hist"})


def restart(sim: "Run", path: Path, force: bool = False,
            extend: float | None = None) -> None:
    """Continue ``sim`` from the last complete snapshot of ``path``: the writer reads it, the
    run record is compared with the scene's (:data:`RESTART_MAY_CHANGE` may differ; others
    refuse unless ``force``), ``extend`` [s] lengthens a finished run, and the state, step and
    every component's history are restored."""
    writer_cls = type(sim.writers[0]) if sim.writers else sim.registry.get(
        "writer", sim.scene.cfg.output.writer
    )
    data = writer_cls.read_restart(path, sim.context)
    said = options()  # the caller's wording: --force on the command line, force=True in Python
    restore(sim, path, data)
    sim.restarted_from = data["step"]
    record = data.get("record")
    #: whether the scene gives the run another duration or end than the file's run had
    retimed = False
    if record is not None:
        stored = json.loads(json.dumps(record, default=str))
        mine = json.loads(json.dumps(sim.run_record(), default=str))
        diffs = restart_differences(stored, mine, RESTART_MAY_CHANGE)
        retimed = any(d.startswith(("scene.time.duration", "scene.time.end"))
                      for d in restart_differences(stored, mine))
        if diffs and not force:
            more = f" and {len(diffs) - 4} more" if len(diffs) > 4 else ""
            raise SceneError(
                f"{path}: restart refused: this scene differs from the run that wrote the "
                f"file ({'; '.join(diffs[:4])}{more}); restart with the same scene, or pass "
                f"{said.force} to continue anyway (results will not match an uninterrupted run)")
        if diffs:
            warnings.warn(f"{path}: restarting with a different scene ({said.force}): "
                          f"{'; '.join(diffs)}", stacklevel=2)
    stored_steps = int(data.get("n_steps", sim.n_steps))
    base = data.get("extended_from")
    # an --extend cut short (by a kill or a full disk) is finished by a plain restart, and the
    # same --extend again ends where it would have: it extends the end before the cut-short one
    cut_short = base is not None and data["step"] < stored_steps
    if extend is not None:
        if not (math.isfinite(extend) and extend > 0):
            raise SceneError(f"{said.extend}{extend!r}: give a positive duration, e.g. "
                             f"{said.extend}{said.duration_example}")
        if cut_short:
            stored_steps = int(base)
        sim.n_steps = stored_steps + max(1, round(extend / sim.dt))
        check_limits(sim.scene, n_steps=sim.n_steps)
        note = (f"\n# siku run --extend {extend:g} s: continued from step {data['step']} "
                f"of {stored_steps} to step {sim.n_steps} (t = {sim.n_steps * sim.dt:g} "
                "s)\n")
        sim.scene = Scene(sim.scene.cfg, sim.scene.text.rstrip("\n") + "\n" + note,
                           sim.scene.path)
    elif retimed and sim.step_index >= sim.n_steps:  # a new duration: the scene's end rules
        raise SceneError(
            f"{path}: the scene's duration {sim.scene.cfg.time.total:g} s ends before the "
            f"file's last snapshot (step {sim.step_index}, t = {sim.time:g} s); give a "
            f"duration past it, or lengthen the run with {said.extend}{said.duration}")
    elif (sim.step_index >= sim.n_steps and stored_steps > sim.n_steps
          and sim.time_origin == (0, 0.0)):  # steps of another dt say nothing here
        # a run extended beyond its scene's end: go on to the end the file records
        sim.n_steps = stored_steps
        if cut_short:
            note = (f"\n# siku run --extend (resumed): continued from step {data['step']} "
                    f"of {int(base)} to step {sim.n_steps} (t = {sim.n_steps * sim.dt:g} s)\n")
            sim.scene = Scene(sim.scene.cfg, sim.scene.text.rstrip("\n") + "\n" + note,
                               sim.scene.path)
    if sim.step_index >= sim.n_steps:
        raise SceneError(
            f"{path}: the run is already complete (step {sim.step_index} of "
            f"{sim.n_steps}, t = {sim.time:g} s); to run longer, add "
            f"{said.extend}{said.duration} (e.g. {said.extend}{said.duration_example})")


def restore(sim: "Run", path: Path, data: dict[str, Any]) -> None:
    """Put a writer's restart data (:meth:`~siku_core.interfaces.Writer.read_restart`) into
    the run: the state ``q``, ``V``, ``w``, the step and every component's history."""
    st = sim.state
    for k in ("q", "V", "w"):
        arr = np.asarray(data[k])
        if arr.shape != getattr(st, k).shape:
            raise SceneError(f"{path}: restart holds {k} of shape {arr.shape}, the scene "
                             f"builds {getattr(st, k).shape}; restart with the scene that "
                             "wrote the file")
        getattr(st, k)[...] = arr
    sim.step_index = int(data["step"])
    set_time_origin(sim, data.get("time"))
    sim.restart_path = path
    sim.set_history_arrays(data.get("history", {}))



def set_time_origin(sim: "Run", t: float | None) -> None:
    """Continue the model time ``t`` [s] stored with the restart's snapshot. When the step
    changed (``t`` is not ``step_index * dt``) the time origin becomes ``(step_index, t)`` and
    the steps left are those of the scene's remaining time, so the time axis goes on from ``t``
    and ends at the scene's end; with the same step nothing changes (bit for bit)."""
    if t is None or t == sim.step_index * sim.dt:
        return
    t = float(t)
    sim.time_origin = (sim.step_index, t)
    sim.state_schedule = sim.state_schedule.from_origin(sim.step_index, t, sim.dt)
    sim.diag_schedule = sim.diag_schedule.from_origin(sim.step_index, t, sim.dt)
    left = sim.scene.cfg.time.total - t
    sim.n_steps = sim.step_index + max(0, math.ceil(left / sim.dt - 1e-9))


def keyed_components(sim: "Run") -> dict[str, Any]:
    """The run's components by the key their history is stored under: ``KIND{k}_NAME`` in
    step order, ``contacts`` (the contact model) and ``elements`` (declared per-element fields
    and a changing thickness, :class:`siku_core.ice.IceBook`)."""
    out: dict[str, Any] = {f"{c.kind}{k}_{c.name}": c for k, c in enumerate(sim.components())}
    if sim.contacts is not None:
        out["contacts"] = sim.contacts
    if sim.ice.active:
        out["elements"] = sim.ice
    return out


def history(sim: "Run") -> dict[str, dict[str, np.ndarray]]:
    """Per-component history (joint damage, contact lists, declared fields...) needed to
    restart exactly. Components that keep history declare it with ``history() -> {name:
    array}`` and ``set_history({name: array})`` (:class:`~siku_core.interfaces.Component`; by
    default a component keeps none)."""
    out = {}
    for key, c in keyed_components(sim).items():
        arrays = c.history()
        if arrays is not None:
            out[key] = arrays
    return out


def set_history(sim: "Run", hist: dict[str, dict[str, np.ndarray]]) -> None:
    """Put what :func:`history` returned back into the run's components."""
    comps = keyed_components(sim)
    for key, arrays in hist.items():
        if key not in comps or comps[key].history() is None:
            raise SceneError(
                f"{sim.scene.label}: restart holds history for '{key}', which this scene "
                "does not have; restart with the scene that wrote the file"
            )
        comps[key].set_history(arrays)
