"""What each forcing source costs, timed alone, per element-step.

``python -m bench.forcing`` (from the repository root) builds the shipped default scene (its
gridded NCEP/NCAR-layout wind through ``air_drag``, still water through ``water_drag``, and
``coriolis``), runs ``--spinup`` steps so that the pack moves and the wind is past the start of
its ramp, then times each source's ``add`` alone on the scene's state, ``--calls`` calls per
round, ``--rounds`` rounds, on one thread and on the scene's threads (numba's thread count),
the thread counts alternated round by round. It prints ns per element-step (one call is one
element-step of the source: the integrator calls the forcing once per step), best and median.

Target (issue: speed): the gridded forcing at most 50 ns per element-step. The interpolation
happens in the ``air_drag`` source (the ``gridded`` field's one-pass ``add_drag``).

    python -m bench.forcing --rounds 5 --calls 400
"""
from __future__ import annotations

import argparse
import statistics
import time

import numba
import numpy as np

from siku_core.run.cli import default_scene_path
from siku_core.scene.scene_file import load_scene
from siku_core.run.simulation import Simulation


def build(spinup: int) -> Simulation:
    scene = load_scene(default_scene_path(), {"output.plots": "false"})
    sim = Simulation(scene)
    sim.run(steps=spinup)
    return sim


def time_source(src, t: float, st, calls: int) -> float:
    """Wall seconds of ``calls`` calls of ``src.add`` on the state ``st``."""
    F = np.zeros((st.n, 2))
    T = np.zeros(st.n)
    src.add(t, st.q, st.V, st.w, F, T)  # compiled already; one call settles caches
    t0 = time.perf_counter()
    for _ in range(calls):
        src.add(t, st.q, st.V, st.w, F, T)
    return time.perf_counter() - t0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--calls", type=int, default=400)
    ap.add_argument("--spinup", type=int, default=20)
    args = ap.parse_args(argv)
    sim = build(args.spinup)
    st = sim.state
    t = sim.time
    threads = sorted({1, numba.config.NUMBA_NUM_THREADS})
    results: dict[tuple[str, int], list[float]] = {}
    for _ in range(args.rounds):
        for nt in threads:
            numba.set_num_threads(nt)
            for src in sim.forcing:
                dt = time_source(src, t, st, args.calls)
                results.setdefault((src.name, nt), []).append(dt / args.calls / st.n * 1e9)
    numba.set_num_threads(max(threads))
    print(f"default scene: {st.n} elements, t = {t:.0f} s, {args.rounds} rounds of "
          f"{args.calls} calls")
    print(f"{'source':<14}{'threads':>8}{'best [ns]':>12}{'median [ns]':>13}")
    for (name, nt), v in results.items():
        print(f"{name:<14}{nt:>8}{min(v):>12.1f}{statistics.median(v):>13.1f}")


if __name__ == "__main__":
    main()
