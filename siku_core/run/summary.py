"""The summary of a run, printed when ``siku run`` ends and by ``siku info FILE`` for any output:
elements by kind, steps and model time, joints broken by mode, the lead fraction, the smallest
free cell's share of the median area and what it costs in step (:mod:`siku_core.scene.cells`), wall
time and where the output went. Plain numbers in, text out: the run loop and the file reader
(the ``siku info`` command) fill the same :class:`RunSummary`."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..scene.cells import small_cell_report
from ..state import FREE, STATIC, STEADY


@dataclass
class RunSummary:
    title: str
    flags: Any  # per element: FREE, STATIC or STEADY
    steps: int  # steps done
    n_steps: int  # steps the run asks for
    dt: float  # s
    time: float  # model time reached [s]
    diagnostics: dict[str, float] = field(default_factory=dict)  # the last row
    n_joints: int | None = None
    wall: float | None = None  # s
    output: str | None = None
    start: str | None = None  # ISO date of t = 0
    areas: Any = None  # per element [m²]: the smallest free cells' share of the median
    compile: float | None = None  # s of ``wall`` numba spent compiling kernels
    run_steps: int | None = None  # steps taken in ``wall`` (default: ``steps``)


def _duration(s: float) -> str:
    if s >= 86400 and s % 3600 == 0:
        return f"{s / 86400:g} d" if s % 86400 == 0 else f"{s / 3600:g} h"
    if s >= 3600:
        return f"{s / 3600:.4g} h"
    if s >= 60:
        return f"{s / 60:.4g} min"
    return f"{s:.4g} s"


def _rate(r: RunSummary) -> str:
    """`` (N steps/s)`` over the stepping time: the wall time less the compilation."""
    steps = r.steps if r.run_steps is None else r.run_steps
    compiling = r.compile or 0.0
    stepping = r.wall - compiling if r.wall is not None else 0.0
    rate = f"{steps / stepping:.4g} steps/s" if stepping > 0 and steps else ""
    if compiling >= 0.05:
        return f" (compiling kernels {compiling:.1f} s; {rate or 'no steps'} without it)"
    return f" ({rate})" if rate else ""


def format_summary(r: RunSummary) -> str:
    """The summary as aligned ``key  value`` lines."""
    import numpy as np

    flags = np.asarray(r.flags)
    n = int(flags.size)
    kinds = [(int(np.sum(flags == FREE)), "free"),
             (int(np.sum(flags == STATIC)), "static (held in place: coast, landfast, handles)"),
             (int(np.sum(flags == STEADY)), "steady (moving at a set velocity)")]
    rows = [("elements", f"{n}: " + ", ".join(f"{k} {w}" for k, w in kinds if k or w == "free"))]
    state = "complete" if r.steps >= r.n_steps else f"stopped at step {r.steps} of {r.n_steps}"
    since = f" from {r.start}" if r.start else ""
    rows.append(("steps", f"{r.steps} of {r.dt:.6g} s: {_duration(r.time)} of model time{since} "
                          f"({state})"))
    d = r.diagnostics
    if "joints_intact" in d:
        broken = int(d.get("joints_broken", 0))
        modes = [(k.removeprefix("joints_broken_"), int(v)) for k, v in sorted(d.items())
                 if k.startswith("joints_broken_") and v]
        total = r.n_joints if r.n_joints is not None else int(d["joints_intact"]) + broken
        by = f" ({', '.join(f'{m} {v}' for m, v in modes)})" if modes else ""
        rows.append(("joints", f"{total} frozen: {int(d['joints_intact'])} intact, "
                               f"{broken} broken{by}"))
        if "lead_fraction" in d:
            rows.append(("leads", f"lead fraction {100 * d['lead_fraction']:.3g} % (open water "
                                  f"in leads {d.get('lead_area', 0.0) / 1e6:.4g} km²)"))
    if "mean_speed" in d:
        rows.append(("speed", f"mean {d['mean_speed']:.3g} m/s, largest "
                              f"{d.get('max_speed', float('nan')):.3g} m/s"))
    small = small_cell_report(r.areas, flags) if r.areas is not None else None
    if small is not None and small.n_free > 1:
        rows.append(("cells", small.line(p5=False)))
    if r.wall is not None:
        rows.append(("wall time", f"{r.wall:.1f} s{_rate(r)}"))
    rows.append(("output", r.output or "none (out=False)"))
    width = max(len(k) for k, _ in rows)
    head = f"summary: {r.title}" if r.title else "summary"
    return "\n".join([head] + [f"  {k:<{width}}  {v}" for k, v in rows])


def summary_of(sim: Any, wall: float | None = None, output: str | None = None,
               run_steps: int | None = None) -> RunSummary:
    """The summary of a :class:`~siku_core.run.simulation.Simulation` as it stands; ``wall`` [s]:
    the time of its :meth:`~siku_core.run.simulation.Simulation.run` (the compilation in it,
    ``sim.compile_seconds``, is shown apart and left out of the rate); ``run_steps``: the
    steps that run took (default: all the steps done)."""
    cfg = sim.scene.cfg
    start = cfg.time.start.isoformat() if getattr(cfg.time, "start", None) else None
    return RunSummary(
        title=cfg.title or "", flags=sim.state.flags, steps=int(sim.step_index),
        n_steps=int(sim.n_steps), dt=float(sim.dt), time=float(sim.time),
        diagnostics=sim.diagnostics(),
        n_joints=None if sim.contacts is None else int(sim.contacts.n_joints),
        wall=wall, output=output, start=start, areas=sim.state.area,
        compile=float(getattr(sim, "compile_seconds", 0.0)) if wall is not None else None,
        run_steps=run_steps)
