"""What processes cost: the whole step with and without each built-in process, alternated in
one window.

``python -m bench.processes`` (from the repository root) runs the bonded 10 000-element pack of
:mod:`bench.scenes` (law ``ridging`` for every variant, so that only the process differs) and
one hour of the shipped default scene, each as: no process; ``thermodynamics`` every step
(uniform -20 °C); ``ridging`` every step and every ``--every`` steps. Variants alternate,
``--rounds`` times, each after a first step that compiles its kernels; each prints its best wall
time per element-step [ns], the share of the step spent in the ``processes`` phase
(``Simulation.timings``), the share spent in the processes' own ``apply`` (the rest of the
phase is the engine's follow-up of a thickness change: mass, inertia, inverse masses and the
joints' constants, which after a change of every element the next joint loop computes, in the
``joints`` phase), the contact phases (joints, broad phase, collisions,
contact sum) per element-step [ns], which carry most of the spread between runs of the same
scene, the ratio to the run without processes, and the median over the rounds of the time per
element-step and of the ``processes`` share (``--only`` runs some cases). Targets (issue: ice
that changes): thermodynamics at most 5 % of the step, ridging at most 10 %, the run without
processes as fast as before (``bench.fingerprint`` checks it is also bit for bit the same).

    python -m bench.processes --rounds 3 --steps 50
    python -m bench.processes --only "pack none" "pack ridging"
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bench.scenes import text as bench_text
from siku_core.run.cli import default_scene_path
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation

#: ridging law parameters on top of the pack's joint parameters
RIDGING = {"tensile_strain": 0.05, "strength": 2.75e4}
VARIANTS = {
    "none": "",
    "thermodynamics": ('[[process]]\nname = "thermodynamics"\n'
                       'params = { surface_temperature = -20.0 }\n'),
    "ridging": '[[process]]\nname = "ridging"\n',
    "ridging/N": '[[process]]\nname = "ridging"\nevery = EVERY\n',
}


def _table(variant: str, dt: float, every: int) -> str:
    return VARIANTS[variant].replace("EVERY", repr(every * dt))


def pack_scene(variant: str, n: int, steps: int, every: int):
    from bench.scenes import DT_BONDED

    text = bench_text("bonded", n, "distributed_spring", steps)
    text = text.replace('law = "distributed_spring"', 'law = "ridging"')
    text = text.replace("tensile_strain = 0.05", "tensile_strain = 0.05, strength = 2.75e4")
    return scene_from_text(text + "\n" + _table(variant, DT_BONDED, every),
                           f"<bench processes {variant}>")


def default_scene(variant: str, hours: float, every: int):
    """The shipped default scene for ``hours`` under the ridging law, with the variant's
    process table (its data files resolved from its own folder)."""
    path = default_scene_path()
    dt = float(path.read_text(encoding="utf-8").split("dt = ")[1].split()[0])
    text = path.read_text(encoding="utf-8") + "\n" + _table(variant, dt, every)
    return scene_from_text(text, f"<default {variant}>", path.resolve(),
                           {"time.duration": f"{hours}h", "contact.law": "ridging",
                            "output.plots": "false"})


#: the contact phases of ``Simulation.timings``
CONTACT = ("joints", "broad_phase", "collisions", "contact_sum")


def _timed(apply, spent: list):
    """``apply`` that adds its wall time [s] to ``spent[0]``."""
    def run(ctx, dt):
        t0 = time.perf_counter()
        apply(ctx, dt)
        spent[0] += time.perf_counter() - t0
    return run


def run_once(scene) -> tuple[float, float, float, float, int]:
    """``(wall, processes phase, the processes' apply, contact phases [s], element-steps)`` of
    a run of ``scene`` after its first step."""
    sim = Simulation(scene, out=False, progress=False)
    sim.run(steps=1)  # compile outside the timing
    sim.reset_timings()
    spent = [0.0]
    for proc in sim.processes:
        proc.apply = _timed(proc.apply, spent)
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    contact = sum(sim.timings.get(k, 0.0) for k in CONTACT)
    return (wall, sim.timings.get("processes", 0.0), spent[0], contact,
            (sim.step_index - 1) * sim.state.n)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.processes", description=__doc__)
    ap.add_argument("--elements", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--hours", type=float, default=1.0, help="of the default scene")
    ap.add_argument("--every", type=int, default=60, help="steps between ridging applications")
    ap.add_argument("--only", nargs="+", default=None, metavar="CASE",
                    help="run only these cases (e.g. 'pack none' 'pack ridging'); a case's ratio "
                    "needs its scene's 'none' among them")
    args = ap.parse_args(argv)
    cases = {f"pack {v}": (lambda v=v: pack_scene(v, args.elements, args.steps, args.every))
             for v in VARIANTS}
    for v in VARIANTS:
        cases[f"default {v}"] = (lambda v=v: default_scene(v, args.hours, args.every))
    if args.only:
        unknown = set(args.only) - set(cases)
        if unknown:
            ap.error(f"unknown case {sorted(unknown)[0]!r}; one of {', '.join(cases)}")
        cases = {k: cases[k] for k in args.only}
    best: dict[str, tuple[float, ...]] = {}
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in cases}
    for _ in range(args.rounds):
        for name, make in cases.items():
            wall, proc, own, contact, work = run_once(make())
            ns = wall / work * 1e9
            runs[name].append((ns, proc / wall))
            if name not in best or ns < best[name][0]:
                best[name] = (ns, proc / wall, own / wall, contact / work * 1e9)
    print(f"{'case':<24} {'ns/element-step':>16} {'processes':>10} {'apply':>8} "
          f"{'contact ns':>11} {'ratio':>7} {'median ns':>10} {'median processes':>17}")
    for name, (ns, share, own, contact) in best.items():
        ref = best.get(name.split()[0] + " none", (float("nan"),))[0]
        med_ns, med_share = (float(np.median(x)) for x in zip(*runs[name]))
        print(f"{name:<24} {ns:16.1f} {100 * share:9.1f}% {100 * own:7.1f}% {contact:11.1f} "
              f"{ns / ref:7.3f} {med_ns:10.1f} {100 * med_share:16.1f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
