"""Two MPI ranks of one thread against one rank of two threads, on the bonded pack.

``python -m bench.ranks`` (from the repository root) runs the bonded pack of
:mod:`bench.scenes` at each ``--sizes`` for ``--steps`` steps after ``--warm`` steps, as
1 rank × 2 threads (a plain run, ``NUMBA_NUM_THREADS=2``) and as 2 ranks × 1 thread
(``mpiexec -n 2``, ``siku_core.ranks``), the two alternated ``--repeat`` times in one window
(each run a fresh process), and prints per run: steps per second, the share of the rank's
step spent in the exchange (ghost update plus the per-step allgather, waiting included), the
bytes a rank sends per step, the CPU time of a step summed over the cores (``process_time`` of
the process, or of every rank: on a busy machine the fairer measure of work), the peak
memory of a rank (``ru_maxrss``) and its resident memory once the run is built and after
the steps (``VmRSS``: the peak is the build's, the whole scene's stable-step check). Outputs
are off. ``--steps`` takes one number, or one per size (fewer steps at the large sizes).

    python -m bench.ranks --sizes 2000 10000 --steps 50 --repeat 2
    python -m bench.ranks --sizes 10000 100000 1000000 --steps 40 10 3 --warm 2 --repeat 1
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

from bench.scenes import scene
from siku_core.ranks import launched_ranks, mpiexec


def resident_mb() -> float:
    """This process's resident memory now [MB] (``VmRSS``; 0 where ``/proc`` is missing)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def worker(n: int, warm: int, steps: int) -> None:
    """One run (on the launched ranks if any): a JSON line from rank 0."""
    from siku_core.run.simulation import Simulation

    sim = Simulation(scene("bonded", n, steps=warm + steps), out=False, progress=False)
    built = resident_mb()
    if launched_ranks() > 1:
        from siku_core.ranks.driver import RankRun

        run = RankRun(sim)
        for _ in range(warm):
            run.step()
        run.comm.barrier()
        run.work = run.exchange_time = 0.0
        sent0 = run.comm.sent_bytes
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(steps):
            run.step()
        cpu = time.process_time() - c0
        run.comm.barrier()
        wall = time.perf_counter() - t0
        mine = {"exchange": run.exchange_time / max(run.exchange_time + run.work, 1e-300),
                "bytes": (run.comm.sent_bytes - sent0) / steps,
                "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                "built_mb": built, "stepping_mb": resident_mb(), "cpu": cpu,
                "held": len(run.ids), "owned": len(run.own_rows)}
        every = run.comm.gather(mine)
        if not run.root:
            return
        out = {"mode": "2 ranks x 1 thread", "n": sim.state.n, "steps_per_s": steps / wall,
               "exchange_share": max(e["exchange"] for e in every),
               "bytes_per_step": max(e["bytes"] for e in every),
               "rss_mb_per_rank": max(e["rss_mb"] for e in every),
               "built_mb_per_rank": max(e["built_mb"] for e in every),
               "stepping_mb_per_rank": max(e["stepping_mb"] for e in every),
               "cpu_s_per_step": sum(e["cpu"] for e in every) / steps,
               "redistributions": run.redistributions,
               "held": [e["held"] for e in every], "owned": [e["owned"] for e in every]}
    else:
        sim.run(warm)
        t0, c0 = time.perf_counter(), time.process_time()
        sim.run(steps)
        cpu = time.process_time() - c0
        wall = time.perf_counter() - t0
        import numba

        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        out = {"mode": f"1 rank x {numba.get_num_threads()} threads", "n": sim.state.n,
               "steps_per_s": steps / wall, "rss_mb_per_rank": rss, "built_mb_per_rank": built,
               "stepping_mb_per_rank": resident_mb(), "cpu_s_per_step": cpu / steps}
    print(json.dumps(out), flush=True)


def _one(mode: str, n: int, warm: int, steps: int) -> dict:
    env = dict(os.environ)
    args = [sys.executable, "-m", "bench.ranks", "--worker", str(n), str(warm), str(steps)]
    if mode == "threads":
        env["NUMBA_NUM_THREADS"] = "2"
        cmd = args
    else:
        env["NUMBA_NUM_THREADS"] = "1"
        cmd = [mpiexec(), "-n", "2", *args]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=3600)
    if p.returncode:
        raise SystemExit(p.stderr[-2000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.ranks", description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    ap.add_argument("--steps", type=int, nargs="+", default=[50],
                    help="steps timed: one number for every size, or one per size")
    ap.add_argument("--warm", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--worker", type=int, nargs=3, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker(*a.worker)
        return 0
    if mpiexec() is None:
        print("bench.ranks needs mpiexec: pip install 'siku[mpi]'", file=sys.stderr)
        return 2
    if len(a.steps) not in (1, len(a.sizes)):
        ap.error(f"--steps: one number, or one per size ({len(a.sizes)})")
    steps = a.steps * len(a.sizes) if len(a.steps) == 1 else a.steps
    print("| elements | steps | mode | steps/s | CPU s/step (all cores) | exchange share | "
          "bytes/step per rank | peak memory per rank | built / stepping per rank |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    for n, k in zip(a.sizes, steps):
        for _ in range(a.repeat):
            for mode in ("threads", "ranks"):
                r = _one(mode, n, a.warm, k)
                ex = f"{r['exchange_share']:.0%}" if "exchange_share" in r else ""
                by = f"{r['bytes_per_step'] / 1e3:.1f} kB" if "bytes_per_step" in r else ""
                print(f"| {r['n']} | {k} | {r['mode']} | {r['steps_per_s']:.3g} | "
                      f"{r['cpu_s_per_step']:.3g} | {ex} | {by} | "
                      f"{r['rss_mb_per_rank']:.0f} MB | {r['built_mb_per_rank']:.0f} / "
                      f"{r['stepping_mb_per_rank']:.0f} MB |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
