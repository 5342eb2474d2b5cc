"""The price of a step: the default scene's leads and cost against ``dt``.

``python -m bench.steps`` runs the default scene (the same scene, mesh and physics as ``siku
run``) for ``--hours`` of model time at each step of ``--dt``, the first being the reference,
and compares every run's leads with the reference's:

* ``first break`` [min]: the model time of the first joint to break, and its difference from
  the reference's;
* ``lead fraction`` (the run's ``lead_fraction`` diagnostic, lead area over free ice plus leads)
  at every hour, relative to the reference's;
* ``co-located`` [%]: the share of the run's broken joints whose midpoint lies within
  ``--near`` (10 km) of a joint broken in the reference, and the share of the reference's
  broken joints with a broken joint of the run that near;
* cost: wall and CPU seconds of the steps (``time.process_time()``: on a shared machine the
  CPU time is the number that carries to an idle one; compilation excluded: a first short run
  compiles), steps, and milliseconds of CPU per step; one thread unless ``--threads`` is given;
* the stable step: the critical step the engine estimates at the start and after every
  recheck (``siku_core.run.guard``), the mode that sets it, and the largest ratio of the step
  to it over the run, against ``[run] dt_safety``. Every run goes on above the accepted step
  (``[run] allow_unstable_dt``, so the price of a step beyond it can be measured), and says so
  at its start; the break guard stays on.

Each run's break times and positions are kept in ``--out`` (``steps_<dt>.npz``), so a later
call with ``--reuse`` only runs the steps it has not. The table goes to stdout and, with
``--table``, to a Markdown file; ``--figure`` draws cost and lead errors against the step.
"""
from __future__ import annotations

import argparse
import importlib.resources as ir
import math
import time
import warnings
from pathlib import Path

import numpy as np

#: mean Earth radius the scene uses [m] (distances between break positions)
EARTH_RADIUS = 6.371e6


def _scene(dt: float, hours: float, extra: dict[str, str] | None = None):
    from siku_core.scene.scene_file import load_scene

    path = ir.files("siku_core") / "data" / "default_scene.toml"
    over = {"time.dt": f"{dt!r}s", "time.duration": f"{hours!r}h",
            "run.allow_unstable_dt": "true", **(extra or {})}
    return load_scene(str(path), over)


def run(dt: float, hours: float, extra: dict[str, str] | None = None,
        log=print) -> dict[str, np.ndarray]:
    """Run the default scene at ``dt`` [s] for ``hours``; returns the joints' break times [s]
    and midpoints (latitude, longitude [deg]), the lead fraction at every hour, the wall
    seconds of every hour's steps and the critical step [s]."""
    from siku_core.run.simulation import Simulation

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_scene(dt, hours, extra), out=False, progress=False)
    cm = sim.contacts
    per_hour = int(round(3600.0 / dt))
    pos = np.full((cm.n_joints, 2), np.nan)
    lead, wall, cpu, crit = [], [], [], []
    safety = sim.scene.cfg.run.dt_safety
    log(f"  dt {dt:g} s: {stable_step_line(sim)}")
    t0 = time.perf_counter()
    spent = spent_cpu = 0.0
    for h in range(int(round(hours))):
        for _ in range(per_hour):
            before = cm.intact.copy()
            a, c = time.perf_counter(), time.process_time()
            sim.step()
            spent += time.perf_counter() - a
            spent_cpu += time.process_time() - c
            new = np.flatnonzero(before & ~cm.intact)
            if len(new):
                pos[new] = cm.joint_midpoints(new)
        d = sim.diagnostics()
        lead.append(float(d.get("lead_fraction", math.nan)))
        wall.append(spent)
        cpu.append(spent_cpu)
        crit.append(sim.critical_dt)
        log(f"  dt {dt:g} s: {h + 1} h, {int((~cm.intact).sum())} joints broken, lead "
            f"fraction {100 * lead[-1]:.4g} %, {spent:.1f} s stepping, {spent_cpu:.1f} s of "
            f"CPU, critical step {sim.critical_dt:.4g} s ({dt / sim.critical_dt:.2f} of it; "
            f"accepted up to {safety:g}) ({time.perf_counter() - t0:.0f} s)")
    return {"break_time": cm.break_time.copy(), "pos": pos, "lead": np.array(lead),
            "wall": np.array(wall), "cpu": np.array(cpu), "dt": np.array(dt),
            "critical": np.array(sim.critical_dt), "critical_hourly": np.array(crit),
            "dt_safety": np.array(safety), "steps": np.array(sim.step_index)}


def stable_step_line(sim) -> str:
    """The guard's view of a run's step: the critical step [s], what sets it, the step's share
    of it and the share ``[run] dt_safety`` accepts (above it: run on by
    ``allow_unstable_dt``)."""
    run_cfg = sim.scene.cfg.run
    if not math.isfinite(sim.critical_dt):
        return "no stable-step limit"
    who, why = sim.critical_by
    share = sim.dt / sim.critical_dt
    verdict = ("within it" if share <= run_cfg.dt_safety else
               "ABOVE it: running on under [run] allow_unstable_dt")
    return (f"critical step {sim.critical_dt:.4g} s set by '{who}': {why}; the step is "
            f"{share:.2f} of it, [run] dt_safety accepts {run_cfg.dt_safety:g}: {verdict}")


def _warm(dt: float, extra: dict[str, str]) -> None:
    """Compile every kernel of the scene (a few steps), so no run's time counts it."""
    from siku_core.run.simulation import Simulation

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_scene(dt, 1.0, extra), out=False, progress=False)
    for _ in range(3):
        sim.step()


def _xyz(latlon: np.ndarray) -> np.ndarray:
    lat, lon = np.radians(latlon[:, 0]), np.radians(latlon[:, 1])
    return np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=1)


def near_share(a: np.ndarray, b: np.ndarray, within: float) -> float:
    """Share of the points ``a`` (latitude, longitude [deg]) within ``within`` [m] of a point
    of ``b`` (great-circle chord; NaN without points)."""
    if not len(a):
        return math.nan
    if not len(b):
        return 0.0
    from scipy.spatial import cKDTree

    chord = 2.0 * math.sin(within / (2.0 * EARTH_RADIUS))
    d, _ = cKDTree(_xyz(b)).query(_xyz(a), k=1)
    return float(np.mean(d <= chord))


def compare(ref: dict, other: dict, near: float = 10e3) -> dict[str, float]:
    """The leads of run ``other`` against run ``ref`` (see the module)."""
    hours = min(len(ref["lead"]), len(other["lead"]))
    rb = np.isfinite(ref["break_time"]) & (ref["break_time"] >= 0)
    ob = np.isfinite(other["break_time"]) & (other["break_time"] >= 0)
    rpos, opos = ref["pos"][rb], other["pos"][ob]
    out = {
        "broken": int(ob.sum()), "broken_ref": int(rb.sum()),
        "first_break_min": float(other["break_time"][ob].min() / 60) if ob.any() else math.nan,
        "first_break_shift_min": (float((other["break_time"][ob].min()
                                         - ref["break_time"][rb].min()) / 60)
                                  if ob.any() and rb.any() else math.nan),
        "near_of_run": near_share(opos, rpos, near),
        "near_of_ref": near_share(rpos, opos, near),
        "wall": float(other["wall"][hours - 1]), "steps": int(other["steps"]),
        "cpu": float(other["cpu"][hours - 1]) if "cpu" in other else math.nan,
        "share": float(other["dt"] / np.min(other.get("critical_hourly", other["critical"]))),
    }
    for h in sorted({min(2, hours), hours}):
        out[f"lead_{h}h"] = float(other["lead"][h - 1])
        r, o = float(ref["lead"][h - 1]), float(other["lead"][h - 1])
        # (no leads in either run yet, as at 2 h of the day's 6 h wind ramp: no error)
        out[f"lead_err_{h}h"] = o / r - 1.0 if r else (0.0 if o == 0.0 else math.inf)
    return out


#: the bounds a step's leads are held to against the reference: the first break within
#: ``FIRST_BREAK_MIN`` [min], the lead fraction at 2 h and at the end within ``LEAD_REL`` of
#: the reference's, at least ``NEAR_SHARE`` of the run's breaks near a reference break
FIRST_BREAK_MIN, LEAD_REL, NEAR_SHARE = 5.0, 0.05, 0.90


def misses(c: dict, hours: int) -> list[str]:
    """The bounds (:data:`FIRST_BREAK_MIN`, :data:`LEAD_REL`, :data:`NEAR_SHARE`) that the
    comparison ``c`` (:func:`compare`) misses; empty: within every bound."""
    out = []
    if not abs(c["first_break_shift_min"]) <= FIRST_BREAK_MIN:
        out.append("first break")
    for h in sorted({min(2, hours), hours}):
        if not abs(c[f"lead_err_{h}h"]) <= LEAD_REL:
            out.append(f"lead {h} h")
    if not c["near_of_run"] >= NEAR_SHARE:
        out.append("co-location")
    return out


def table(rows: list[tuple[float, dict]], hours: int) -> str:
    """The comparison as a Markdown table."""
    marks = sorted({min(2, hours), hours})
    head = ("| dt [s] | dt / critical (largest) | steps | wall [s] | CPU [s] | CPU ms/step | "
            "broken | first break [min] (shift) | "
            + "".join(f"lead {h} h [%] (err) | " for h in marks)
            + "near ref [%] | ref near [%] | bounds |")
    lines = [head, "|" + "---|" * (11 + len(marks))]
    for dt, c in rows:
        leads = "".join(f"{100 * c[f'lead_{h}h']:.4f} ({100 * c[f'lead_err_{h}h']:+.1f} %) | "
                        for h in marks)
        lines.append(
            f"| {dt:g} | {c['share']:.2f} | {c['steps']} | {c['wall']:.1f} | {c['cpu']:.1f} | "
            f"{1e3 * c['cpu'] / c['steps']:.2f} | "
            f"{c['broken']} | {c['first_break_min']:.1f} ({c['first_break_shift_min']:+.1f}) | "
            f"{leads}{100 * c['near_of_run']:.1f} | {100 * c['near_of_ref']:.1f} | "
            f"{'missed: ' + ', '.join(misses(c, hours)) if misses(c, hours) else 'within'} |")
    return "\n".join(lines)


def figure(rows: list[tuple[float, dict]], hours: int, path: Path, ref: str = "") -> None:
    """Cost and lead errors against the step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dts = np.array([dt for dt, _ in rows])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.plot(dts, [c["steps"] for _, c in rows], "o-")
    ax1.set_xlabel("dt [s]")
    ax1.set_ylabel(f"steps for {hours} h (the cost)")
    ax1.set_xscale("log")
    ax1.set_yscale("log")
    ax1.grid(True, which="both", alpha=0.3)
    h2 = min(2, hours)
    ax2.plot(dts, [100 * abs(c[f"lead_err_{hours}h"]) for _, c in rows], "o-", color="C0",
             label=f"|lead fraction error| at {hours} h [%]")
    if h2 != hours and any(c[f"lead_{h2}h"] for _, c in rows):  # (leads open by then)
        ax2.plot(dts, [100 * abs(c[f"lead_err_{h2}h"]) for _, c in rows], "s--",
                 label=f"|lead fraction error| at {h2} h [%]")
    ax2.plot(dts, [100 * (1 - c["near_of_run"]) for _, c in rows], "^-", color="C2",
             label="breaks farther than 10 km from a reference break [%]")
    ax2.axhline(100 * LEAD_REL, color="C0", lw=0.8, ls=":", label="bound of the lead fraction")
    ax2.axhline(100 * (1 - NEAR_SHARE), color="C2", lw=0.8, ls=":",
                label="bound of the far breaks")
    ax2.set_xlabel("dt [s]")
    ax2.set_xscale("log")
    ax2.set_yscale("symlog", linthresh=1.0)
    ax2.set_ylim(bottom=0.0)
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=7, loc="upper left")
    fig.suptitle(f"The default scene against its step (reference: {ref or 'the first dt'})")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m bench.steps", description=__doc__.split("\n")[0])
    ap.add_argument("--dt", type=float, nargs="+", default=[0.75, 1.5, 2.0, 2.5, 3.0, 4.0])
    ap.add_argument("--hours", type=int, default=2)
    ap.add_argument("--near", type=float, default=10e3, help="co-location distance [m]")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("bench_steps"))
    ap.add_argument("--reuse", action="store_true", help="keep runs found in --out")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                    help="scene overrides for every run")
    ap.add_argument("--reference", type=Path, help="a run's .npz (another tree's, say) to "
                    "compare with instead of the first dt's")
    ap.add_argument("--label", default="", help="what the reference is, for the figure")
    ap.add_argument("--table", type=Path, help="write the table here (Markdown)")
    ap.add_argument("--figure", type=Path, help="draw the figure here (PNG)")
    a = ap.parse_args(argv)
    import numba

    numba.set_num_threads(a.threads)
    extra = dict(s.split("=", 1) for s in a.set)
    a.out.mkdir(parents=True, exist_ok=True)
    if not (a.reuse and all((a.out / f"steps_{dt:g}_{a.hours}h.npz").exists() for dt in a.dt)):
        _warm(a.dt[0], extra)
    runs = {}
    for dt in a.dt:
        f = a.out / f"steps_{dt:g}_{a.hours}h.npz"
        if a.reuse and f.exists():
            runs[dt] = dict(np.load(f))
            continue
        runs[dt] = run(dt, a.hours, extra)
        np.savez(f, **runs[dt])
    ref = dict(np.load(a.reference)) if a.reference else runs[a.dt[0]]
    rows = [(dt, compare(ref, runs[dt], a.near)) for dt in a.dt]
    text = table(rows, a.hours)
    crit = float(ref["critical"])
    text += (f"\n\nReference {a.reference or ''} dt = {float(ref['dt']):g} s; critical step "
             f"{crit:.4g} s; {a.hours} h of "
             f"model time; {a.threads} thread(s); co-location within {a.near / 1e3:g} km; "
             f"bounds: first break within {FIRST_BREAK_MIN:g} min, lead fraction within "
             f"{100 * LEAD_REL:g} %, at least {100 * NEAR_SHARE:g} % of breaks near a reference "
             "break.")
    print(text)
    if a.table:
        a.table.write_text(text + "\n")
    if a.figure:
        figure(rows, a.hours, a.figure, f"{float(ref['dt']):g} s" + (f", {a.label}" if a.label
                                                                     else ""))


if __name__ == "__main__":
    main()
