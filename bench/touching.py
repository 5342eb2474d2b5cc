"""What ``contact.touching = "ignore"`` trades: the same runs with the exact rule and with it.

``python -m bench.touching`` (from the repository root; ``--quick``: a smaller subset) runs the
cases below with ``touching = "contact"`` and ``"ignore"``; ``--compare face`` runs them under
the default rule with the touching faces of jointed neighbours found by the clip (``clip``:
``siku_core.testing.switches.face_path`` off, the contact at the mean of the sliver's vertices, the
width the common span across the normal) and from the joint's edges (``face``, the engine's default:
``siku_core.geometry.face``):

* **V6 pack pull** (``bench.accuracy.pull``: the clamped pack of
  ``tests/contacts/test_v6_resolution.py``, ``siku2`` at the test's step): the quasi-static
  handle force against the continuum answer for both rules, and the largest difference of the
  handle force between them over the run, over the continuum force at the end ``F_cont(T)``;
* **lead pattern** of the shipped default scene (Beaufort–Chukchi, the first ``--hours``): the
  broken joints of both runs and their overlap with the exact run's (Jaccard index: shared /
  either), the lead area,
  and the broken joints gridded on the 10 km polar stereographic grid of
  ``tests/test_default_scene.py`` reduced to leads (``siku_io.analysis.leads``): the cells shared,
  the number and total length of the leads. A third run, the exact rule at a time step of 1.5 s
  instead of 1.75 s, shows how much the pattern moves with the discretisation alone;
* **virtual ice tests** (``siku_plugins.lab.virtual_test``: tension, compression, flexure of
  the bonded block, law ``bonded_particle``): Young's modulus and strength under both rules;
* **bench pack** (``bench.scenes`` bonded, 10 000 elements, 100 steps): the largest distance
  between the element centres of the two runs, against the handle's displacement.

and prints markdown tables (pasted into ``bench/RESULTS.md`` and
``docs/explanation/contacts.md``). Wall times are of the steps (one thread).
"""
from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from siku_core.run.cli import default_scene_path
from siku_core.geometry.quat import centers
from siku_core.scene.scene_file import load_scene
from siku_core.run.simulation import Simulation
from siku_core.testing import switches

#: the compared variants: label -> (``contact.touching``, ``switches.face_path``)
COMPARE = {
    "touching": {"contact": ("contact", True), "ignore": ("ignore", True)},
    "face": {"clip": ("contact", False), "face": ("contact", True)},
}
VARIANTS = COMPARE["touching"]


def _variant(name: str) -> str:
    """Set the face path for variant ``name``; return its ``contact.touching``."""
    rule, face = VARIANTS[name]
    switches.face_path = face
    return rule


def v6(nx: int, ny: int) -> list[str]:
    from .accuracy import critical_dt, pull

    dt_c = critical_dt(nx, ny)
    names = list(VARIANTS)
    runs = {v: pull(nx, ny, "siku2", 1.0, dt_c, touching=_variant(v)) for v in names}
    a, b = runs[names[0]], runs[names[1]]
    f_end = a.stiffness * 3.0 * a.t[-1]
    diff = np.abs(b.force - a.force).max() / f_end
    rows = []
    for v in names:
        r = runs[v]
        rows.append(f"| {nx}×{ny} | {v} | {r.point.steps} | "
                    f"{r.force[-1]:.5e} | {r.ratio:+.3%} | "
                    + (f"{diff:.2e} |" if v == names[1] else "- |"))
    return rows


#: the step of this study [s] (the default scene's when it was made), and the smaller step of
#: the baseline run
DT_DEFAULT = 1.75
DT_BASELINE = 1.5


def _run(text_or_scene, hours: float | None, variant: str, dt: float = DT_DEFAULT):
    rule = _variant(variant)
    if hours is not None:
        sc = load_scene(default_scene_path(), {
            "time.duration": f"{hours:g}h", "contact.touching": rule, "time.dt": repr(dt)})
    else:
        sc = text_or_scene(rule)
    sim = Simulation(sc, out=False, progress=False)
    t0 = time.perf_counter()
    sim.run()
    return sim, time.perf_counter() - t0


def _shared(a: np.ndarray, b: np.ndarray) -> float:
    """Jaccard index of two masks: shared over either."""
    return float((a & b).sum() / max(1, (a | b).sum()))


def leads(hours: float) -> list[str]:
    from siku_io.analysis.gridded_fields import grid_snapshot, snapshot_of
    from siku_io.analysis.leads import detect
    from siku_forcing.gridded.regular_grid import Grid, GridCfg

    out = {}
    first, second = VARIANTS
    for rule, dt in ((first, DT_DEFAULT), (second, DT_DEFAULT), (first, DT_BASELINE)):
        sim, sec = _run(None, hours, rule, dt)
        c = sim.contacts
        grid = Grid(GridCfg(kind="polar_stereographic", central_longitude=-155.0,
                            x=(-800e3, 800e3), y=(-2400e3, -1200e3), resolution=10e3),
                    sim.radius)
        cells = grid_snapshot(grid, snapshot_of(sim))["broken_joints"] > 0
        found, _ = detect(cells, grid, min_length=3)
        name = rule if dt == DT_DEFAULT else f"{first}, dt = {dt:g} s"
        out[name] = dict(sec=sec, broken=~c.intact, cells=cells, leads=found,
                         lead_area=sim.diagnostics()["lead_area"])
    a = out[first]
    rows = []
    for rule, r in out.items():
        length = sum(ld.length for ld in r["leads"]) / 1e3
        longest = max((ld.length for ld in r["leads"]), default=0.0) / 1e3
        rows.append(f"| {hours:g} h | {rule} | {r['sec']:.1f} | {int(r['broken'].sum())} | "
                    f"{r['lead_area'] / 1e6:.1f} | {len(r['leads'])} | {length:.0f} | "
                    f"{longest:.0f} | "
                    + ("- | - |" if rule == first else
                       f"{_shared(a['broken'], r['broken']):.2f} | "
                       f"{_shared(a['cells'], r['cells']):.2f} |"))
    return rows


def pack(n: int, steps: int) -> list[str]:
    from siku_core.scene.scene_file import scene_from_text

    from .scenes import bonded_text

    sims = {}
    for v in VARIANTS:
        sims[v] = _run(lambda r: scene_from_text(bonded_text(n, steps=steps, touching=r)),
                       None, v)
    (a, ta), (b, tb) = sims.values()
    d = np.linalg.norm(centers(a.state.q) - centers(b.state.q), axis=1).max() * a.radius
    moved = 3.0 * a.dt * steps
    dv = np.sqrt(((a.state.V - b.state.V) ** 2).mean() / (a.state.V ** 2).mean())
    return [f"| {a.state.n} | {steps} | {ta:.1f} | {tb:.1f} | {d:.2f} | {moved:.0f} | "
            f"{dv:.2e} |"]


def lab() -> list[str]:
    from siku_plugins.lab import TESTS, virtual_test

    rows = []
    for test in TESTS:
        res = {v: virtual_test(test, touching=_variant(v)) for v in VARIANTS}
        a, b = res.values()
        rows.append(f"| {test} | {a.modulus / 1e9:.6f} | {b.modulus / 1e9:.6f} | "
                    f"{b.modulus / a.modulus - 1:+.1e} | {a.strength / 1e6:.6f} | "
                    f"{b.strength / 1e6:.6f} | {b.strength / a.strength - 1:+.1e} |")
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.touching",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="10×4 pull, 2 h, 3 000 elements")
    ap.add_argument("--hours", type=float, default=None, help="default scene hours (6)")
    ap.add_argument("--compare", choices=sorted(COMPARE), default="touching",
                    help="touching: contact.touching contact/ignore; face: the touching faces "
                         "of jointed neighbours by the clip or from the joint's edges")
    a = ap.parse_args(argv)
    global VARIANTS
    VARIANTS = COMPARE[a.compare]
    x, y = VARIANTS
    numba.set_num_threads(1)
    res = [(10, 4)] if a.quick else [(10, 4), (20, 8)]
    print("### V6 pack pull: handle force\n")
    print(f"| pack | {a.compare} | steps | F(T) [N] | <F>/expected − 1 | "
          "max |ΔF| / F_cont(T) |")
    print("|---|---|---:|---:|---:|---:|")
    for nx, ny in res:
        print("\n".join(v6(nx, ny)), flush=True)
    hours = a.hours if a.hours is not None else (2.0 if a.quick else 6.0)
    print("\n### default scene: lead pattern\n")
    print(f"| run | {a.compare} | run [s] | joints broken | lead area [km²] | leads | "
          "length [km] | longest [km] | broken joints shared | lead cells shared |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    print("\n".join(leads(hours)), flush=True)
    print("\n### virtual ice tests (bonded_particle)\n")
    print(f"| test | E, {x} [GPa] | E, {y} [GPa] | change | strength, {x} [MPa] | "
          f"strength, {y} [MPa] | change |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    print("\n".join(lab()), flush=True)
    print("\n### bench pack: positions\n")
    print(f"| elements | steps | run, {x} [s] | run, {y} [s] | max centre distance [m] | "
          "handle moved [m] | rms ΔV / rms V |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    print("\n".join(pack(3000 if a.quick else 10000, 100)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
