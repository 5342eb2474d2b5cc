"""Large scenes on one machine: ``python -m bench.large`` (from the repository root).

Builds the benchmark's free-drift and bonded packs of ``--elements`` elements (default one
million; cells of 0.04° for packs wider than 40°, ``bench/scenes.py``) in a fresh process
each, and reports the set-up time, the first and the median step, element-steps/s on every
thread count, and memory: the process's resident size while running and at its peak (the
build's temporaries), and what the scene adds over the interpreter with siku imported, per
element.

    python -m bench.large                          # 1 000 000 elements, 1 and 2 threads
    python -m bench.large --elements 400000 --steps 10
"""
from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 1e6


def _worker(kind: str, n: int, steps: int, threads: list[int]) -> dict:
    import numba

    from siku_core.run.simulation import Simulation

    from .__main__ import step_times
    from .scenes import scene

    base = _rss_mb()
    t0 = time.perf_counter()
    sc = scene(kind, n, steps=steps + 10)
    sim = Simulation(sc, out=False, progress=False)
    t1 = time.perf_counter()
    built = _rss_mb()
    out = {"kind": kind, "elements": sim.state.n, "setup_s": t1 - t0, "runs": [],
           "joints": sim.contacts.n_joints if sim.contacts else 0}
    for k, th in enumerate(threads):
        numba.set_num_threads(th)
        ta = time.perf_counter()
        sim.step()
        first = time.perf_counter() - ta
        med = statistics.median(step_times(sim, steps))
        out["runs"].append({"threads": th, "first_step_s": first, "median_step_s": med,
                            "element_steps_per_s": sim.state.n / med})
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3  # kB -> MB
    now = _rss_mb()
    peak = max(peak, now)  # (getrusage and /proc count pages slightly differently)
    out.update(base_mb=base, built_mb=built, peak_mb=peak, running_mb=now,
               pairs=len(sim.contacts.pairs) if sim.contacts else 0,
               bytes_per_element=(now - base) * 1e6 / sim.state.n,
               peak_bytes_per_element=(peak - base) * 1e6 / sim.state.n)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.large", description=__doc__)
    ap.add_argument("--elements", type=int, default=1_000_000)
    ap.add_argument("--scenes", default="free_drift,bonded")
    ap.add_argument("--steps", type=int, default=10, help="timed steps per thread count")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    threads = [int(t) for t in args.threads.split(",")]
    if args.worker:
        print(json.dumps(_worker(args.worker, args.elements, args.steps, threads)))
        return 0
    rows = []
    for kind in args.scenes.split(","):
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, "-m", "bench.large", "--worker", kind,
                              "--elements", str(args.elements), "--steps", str(args.steps),
                              "--threads", args.threads], capture_output=True, text=True)
        if res.returncode:
            print(res.stderr, file=sys.stderr)
            return res.returncode
        r = json.loads(res.stdout.strip().splitlines()[-1])
        r["wall_s"] = time.perf_counter() - t0
        rows.append(r)
        print(f"bench.large: {kind} done ({r['wall_s']:.0f} s)", file=sys.stderr)
    print(f"## python -m bench.large {' '.join(argv if argv is not None else sys.argv[1:])}\n")
    print("| scene | elements | joints | pairs | set-up [s] | threads | first step [s] | "
          "step [s] | element-steps/s | RSS running / peak [MB] | bytes / element running "
          "(peak) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        for run in r["runs"]:
            print(f"| {r['kind']} | {r['elements']} | {r['joints']} | {r['pairs']} | "
                  f"{r['setup_s']:.1f} | {run['threads']} | {run['first_step_s']:.2f} | "
                  f"{run['median_step_s']:.3f} | {run['element_steps_per_s']:.3g} | "
                  f"{r['running_mb']:.0f} / {r['peak_mb']:.0f} | {r['bytes_per_element']:.0f} "
                  f"({r['peak_bytes_per_element']:.0f}) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
