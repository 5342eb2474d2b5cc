"""Peak memory of building a benchmark scene (one process): the stable-step check's share.

``python -m bench.build_memory --sizes 100000 1000000`` builds the bonded pack of
:mod:`bench.scenes` at each size in a fresh process (no step taken) and prints the elements,
the joints, the peak resident memory (``ru_maxrss``) [MB], the resident memory once built
(``VmRSS``) [MB], the CPU time of the build [s] and the critical step the build found [s]
(printed in full: two trees that build the same operators find it to the last bit). The
build's peak is its stable-step check of the whole pack
(``siku_core.contact.stable_step.critical_step``); every MPI rank builds the whole run, so
the numbers hold per rank too.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

from bench.ranks import resident_mb


def worker(kind: str, n: int) -> None:
    from bench.scenes import scene
    from siku_core.run.simulation import Simulation

    c0 = time.process_time()
    sim = Simulation(scene(kind, n, steps=2), out=False, progress=False)
    cm = sim.contacts
    print(json.dumps({"n": sim.state.n, "joints": cm.n_joints if cm is not None else 0,
                      "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                      "built_mb": resident_mb(), "cpu_s": time.process_time() - c0,
                      "critical_dt": repr(sim.critical_dt)}), flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.build_memory",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000])
    ap.add_argument("--kind", default="bonded", help="a scene of bench.scenes (default bonded)")
    ap.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker(a.worker[0], int(a.worker[1]))
        return 0
    print("| elements | joints | peak memory | built | build CPU | critical step |")
    print("|---:|---:|---:|---:|---:|---|")
    env = dict(os.environ, NUMBA_NUM_THREADS=os.environ.get("NUMBA_NUM_THREADS", "1"))
    for n in a.sizes:
        p = subprocess.run([sys.executable, "-m", "bench.build_memory", "--worker", a.kind,
                            str(n)], env=env, capture_output=True, text=True, timeout=3600)
        if p.returncode:
            raise SystemExit(p.stderr[-2000:])
        r = json.loads(p.stdout.strip().splitlines()[-1])
        print(f"| {r['n']} | {r['joints']} | {r['peak_mb']:.0f} MB | {r['built_mb']:.0f} MB | "
              f"{r['cpu_s']:.1f} s | {r['critical_dt']} s |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
