"""The default scene's step at one thread, on process CPU time, with its phases' shares.

``python -m bench.default_step`` builds the shipped default scene
(``siku_core/data/default_scene.toml``, with ``--set KEY=VALUE`` overrides as ``siku run
--set`` takes them), runs ``--spinup`` steps, then times ``--steps`` steps with
``time.process_time()`` (the process's CPU time: on a shared machine the wall time says more
about the neighbours than about the code) and prints one line: milliseconds of CPU per step,
the load average, the overlapping pairs at the end and every phase's share of the run's own
timings (``Simulation.profile``). Run it with ``NUMBA_NUM_THREADS=1``; alternate the variants
to compare in one window::

    NUMBA_NUM_THREADS=1 python -m bench.default_step --spinup 2400 --steps 600
    NUMBA_NUM_THREADS=1 python -m bench.default_step --spinup 2400 --steps 600 \\
        --set forcing.0.field.params.resample=60
"""
from __future__ import annotations

import argparse
import importlib.resources as ir
import os
import time


def measure(spinup: int, steps: int, overrides: dict[str, str]) -> dict:
    """CPU milliseconds per step over ``steps`` steps after ``spinup``, with the phases'
    shares [%], the load average before and after, and the overlapping pairs at the end."""
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    path = ir.files("siku_core") / "data" / "default_scene.toml"
    sim = Simulation(load_scene(str(path), overrides), out=False, progress=False)
    for _ in range(spinup):
        sim.step()
    sim.reset_timings()
    load0 = os.getloadavg()[0]
    c0 = time.process_time()
    for _ in range(steps):
        sim.step()
    cpu = (time.process_time() - c0) / max(steps, 1)
    prof = dict(sim.profile())
    total = sum(prof.values()) or 1.0
    return {"ms_per_step": 1e3 * cpu, "load": (load0, os.getloadavg()[0]),
            "overlapping": sim.contacts.n_overlap if sim.contacts is not None else 0,
            "shares": {k: 100.0 * v / total for k, v in prof.items()}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.default_step",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--spinup", type=int, default=400, help="steps before the timed ones")
    ap.add_argument("--steps", type=int, default=300, help="timed steps")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                    help="scene overrides, as siku run --set")
    a = ap.parse_args(argv)
    over = dict(kv.split("=", 1) for kv in a.set)
    r = measure(a.spinup, a.steps, over)
    shares = " ".join(f"{k}={v:.1f}%" for k, v in r["shares"].items() if v >= 0.5)
    print(f"{' '.join(a.set) or 'as shipped'}: {r['ms_per_step']:.3f} ms/step CPU, load "
          f"{r['load'][0]:.1f}-{r['load'][1]:.1f}, {r['overlapping']} overlapping pairs; {shares}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
