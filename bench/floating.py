"""What floating elements cost: the step with and without the ``floating`` process, the
process alone on a large pack, and capytaine's set-up per shape.

``python -m bench.floating`` (from the repository root) prints:

1. the bonded floe of ``examples/waves_on_ice.toml`` (300 m × 60 m of 10 m elements, frozen by
   distributed springs) in a monochromatic sea (0.5 m, 8 s), stepped with and without
   ``floating`` (one run of each, built and compiled first, then ``--steps`` steps of each in
   turn, ``--rounds`` times, so both see the same load): the best and the median wall time
   per element-step [ns] and the ratio of the bests and the median of the rounds' ratios
   (target: at most 1.5), and the same from the CPU time of the calling thread (the floe's
   184 elements run on one thread), which a loaded machine inflates less;
2. the ``floating`` process alone (``apply`` over one step of the scene's ``dt``) on a pack of
   ``--n`` elements (default 10 000, 10 m squares) in the same sea: element-steps/s of the
   vertical motion (target: 1e6 on two threads);
3. capytaine's set-up for the 10 m × 10 m × 1 m block (the three modes at their natural
   frequencies), uncached and cached (``--no-capytaine`` skips it).

    python -m bench.floating --rounds 3 --steps 40
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SEA = ('[[forcing]]\nsource = "waves"\nparams = { breaking = false }\nfield = { type = '
       '"linear_wave", params = { amplitude = 0.5, period = 8.0, direction = 90.0, origin = '
       '[0.0, 0.0] } }\n')
FLOAT = '[[process]]\nname = "floating"\n'


def floe_text(floating: bool, steps: int) -> str:
    text = (ROOT / "examples" / "waves_on_ice.toml").read_text()
    head, _, _ = text.partition("[[forcing]]")
    head = head.replace("duration = 20.0", f"duration = {steps * 0.001!r}")
    return head + SEA + (FLOAT if floating else "")


def floe_sim(floating: bool, steps: int):
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    sim = Simulation(scene_from_text(floe_text(floating, steps), "<bench floating>"),
                     out=False, progress=False)
    sim.step()   # compiles
    return sim


def time_per_element_step(sim, steps: int) -> tuple[float, float]:
    """Wall and calling thread's CPU time [s] per element-step of ``steps`` steps."""
    t0, c0 = time.perf_counter(), time.thread_time()
    for _ in range(steps):
        sim.step()
    c1 = time.thread_time()
    return (time.perf_counter() - t0) / (steps * sim.state.n), (c1 - c0) / (steps * sim.state.n)


def pack_rate(n: int, repeat: int = 5) -> tuple[float, int]:
    """Element-steps/s of ``Floating.apply`` on ``n`` 10 m elements, and the sub-steps."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    side = int(round(n ** 0.5))
    text = f"""
title = "floating pack"
[time]
duration = 0.2
dt = 0.1
[elements]
thickness = 1.0
[[elements.source]]
name = "floe"
[elements.source.params]
outline = "rectangle"
center = [0.0, 0.0]
length = {10.0 * side}
width = {10.0 * side}
element_size = 10.0
{SEA}{FLOAT}"""
    sim = Simulation(scene_from_text(text, "<bench floating pack>"), out=False, progress=False)
    proc = sim.processes[0]
    proc.apply(sim.context, sim.dt)  # compiles
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        proc.apply(sim.context, sim.dt)
        best = min(best, time.perf_counter() - t0)
    import math
    n_sub = max(1, math.ceil(sim.dt * proc.p["steps_per_period"] / proc.period_min - 1e-9))
    return sim.state.n / best, n_sub


def capytaine_setup() -> tuple[float, float]:
    import numpy as np

    from siku_plugins.floating import hydro

    sq = np.array([[-5.0, -5.0], [5.0, -5.0], [5.0, 5.0], [-5.0, 5.0]])
    h, rho, g = 1.0, 1026.0, 9.81
    d = h * 910.0 / rho
    m = 910.0 * h * 100.0
    J = 1e4 / 12
    M = (m, 910.0 * h * J + m * h * h / 12, 910.0 * h * J + m * h * h / 12)
    ct = rho * g * (J - 100 * d * (h - d) / 2)
    C = (rho * g * 100.0, ct, ct)
    with tempfile.TemporaryDirectory() as tmp:
        out = []
        for _ in range(2):
            t0 = time.perf_counter()
            hydro.shape_coefficients(sq, h, d, M, C, rho, g, 10.0 / 16, None, Path(tmp), "bench")
            out.append(time.perf_counter() - t0)
    return out[0], out[1]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--no-capytaine", action="store_true")
    a = ap.parse_args(argv)
    sims = {fl: floe_sim(fl, a.steps * a.rounds + 2) for fl in (False, True)}
    runs = {fl: [] for fl in (False, True)}     # (wall, cpu) of each round
    for _ in range(a.rounds):
        for fl in (False, True):
            runs[fl].append(time_per_element_step(sims[fl], a.steps))
    print("| bonded floe in a monochromatic sea, ns per element-step | wall: best | median "
          "| CPU: best | median |")
    print("|---|---:|---:|---:|---:|")
    for fl, what in ((False, "horizontal only"), (True, "with floating")):
        cols = [f(x[c] for x in runs[fl]) * 1e9 for c in (0, 1)
                for f in (min, statistics.median)]
        print(f"| {what} | " + " | ".join(f"{v:.0f}" for v in cols) + " |")
    rat = []
    for c in (0, 1):
        h, fl = [x[c] for x in runs[False]], [x[c] for x in runs[True]]
        rat += [min(fl) / min(h), statistics.median(b / a for a, b in zip(h, fl))]
    print("| ratio (of the bests; median of the rounds') | " + " | ".join(
        f"{v:.2f}" for v in rat) + " |")
    rate, n_sub = pack_rate(a.n)
    print(f"\nfloating alone, {a.n} elements: {rate:.3g} element-steps/s "
          f"({n_sub} sub-steps per step of 0.1 s)")
    if not a.no_capytaine:
        try:
            cold, warm = capytaine_setup()
        except Exception as exc:  # noqa: BLE001 - capytaine absent or failing: say so
            print(f"\ncapytaine set-up not measured ({type(exc).__name__}: {exc})")
        else:
            print(f"\ncapytaine set-up, 10 m block (3 modes at natural frequency): "
                  f"{cold:.2f} s uncached, {warm * 1e3:.2f} ms cached")


if __name__ == "__main__":
    main()
