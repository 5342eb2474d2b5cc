"""Restart check of the contact-law conformance suite
(:mod:`siku_core.testing.contact_conformance`): a law's history, the joints' rows
(``history_names``) and the contacts' rows (``contact_history_names``), survives a restart, so
that a run stopped at a snapshot and continued is the run that never stopped, bit for bit.
"""
from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .contact_cases import (
    joint_kwargs,
    overlap_kwargs,
    contact_scene,
    law_registry,
)

#: element velocities [m/s] of the restart scenes: the overlapping pair closes (its contact
#: lasts longer than the runs), the jointed pair is pulled and sheared
_PRESS = ((0.3, -0.1), (-0.2, 0.25))
_PULL = ((-0.02, 0.01), (0.02, -0.01))


def _run(law_cls: type, params: Mapping[str, Any] | None, kwargs: dict[str, Any],
         velocities: tuple, dt: float, steps: int, out: Path | bool,
         restart: Path | None = None, run_steps: int | None = None) -> Any:
    from ..run.simulation import Simulation

    scene = contact_scene(law_cls.name, params, label=f"<conformance {law_cls.name}>", dt=dt,
                          steps=2 * steps, output={"every": steps * dt}, **kwargs)
    sim = Simulation(scene, out=out, restart=restart, progress=False,
                     registry=law_registry(law_cls))
    if restart is None:
        sim.state.V[:] = np.asarray(velocities, dtype=float)
    sim.run(steps=run_steps) if run_steps else sim.run()
    return sim


def _same(a: Any, b: Any, what: str, law: str) -> None:
    for k in ("q", "V", "w"):
        x, y = getattr(a.state, k), getattr(b.state, k)
        assert np.array_equal(x, y), (
            f"{law}: restart: {what}: {k} after the restart differs from the run that never "
            f"stopped by up to {np.abs(x - y).max():.3e}: the law's history (or state it "
            "keeps outside it) is not what a snapshot stores")
    ha, hb = a.contacts.history(), b.contacts.history()
    assert sorted(ha) == sorted(hb), f"{law}: restart: {what}: history keys {sorted(ha)}"
    for k in ha:
        assert np.array_equal(np.asarray(ha[k]), np.asarray(hb[k]), equal_nan=True), (
            f"{law}: restart: {what}: history {k!r} after the restart {np.asarray(ha[k])} "
            f"!= {np.asarray(hb[k])} of the run that never stopped")


def check_restart(law_cls: type, params: Mapping[str, Any] | None = None, steps: int = 10,
                  dt: float = 0.01, directory: str | Path | None = None) -> None:
    """Through the engine and the HDF5 writer: ``2 steps`` steps of ``dt`` [s] in one run
    equal ``steps`` steps written to a file and continued from its snapshot for ``steps``
    more, bit for bit (positions, velocities, spins and every history array), for an
    overlapping pair pressed together (the collision evaluator and its contact rows) and, for a
    joint law, a jointed pair pulled and sheared. ``directory``: where the file goes (default:
    a temporary folder, removed after)."""
    cases = [("overlapping pair", overlap_kwargs(), _PRESS)]
    if law_cls.uses_joints:
        cases.append(("jointed pair", joint_kwargs(), _PULL))
    with tempfile.TemporaryDirectory(dir=directory) as tmp:
        for k, (what, kwargs, velocities) in enumerate(cases):
            whole = _run(law_cls, params, kwargs, velocities, dt, steps, out=False)
            part = Path(tmp) / f"restart_{k}.h5"
            _run(law_cls, params, kwargs, velocities, dt, steps, out=part, run_steps=steps)
            again = _run(law_cls, params, kwargs, velocities, dt, steps, out=part,
                         restart=part)
            assert again.step_index == whole.step_index == 2 * steps, (
                f"{law_cls.name}: restart: {what}: the continued run stopped at step "
                f"{again.step_index}, not {2 * steps}")
            _same(again, whole, what, law_cls.name)
