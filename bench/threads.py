"""Every phase of the step on one thread and on two, from 24 to 400 000 elements.

``python -m bench.threads`` (from the repository root; ``--sizes 24,400,4000,40000,400000``,
``--threads 1,2``) runs the bonded benchmark pack (``bench.scenes``, ``distributed_spring``,
the engine's default contact options) writing an HDF5 snapshot every ``--every`` steps to a
temporary folder, so that the output phase is measured with the others. For each size, the
thread counts take turns in blocks of steps on the same run (as ``python -m bench`` does), so
each sees the same stretch of it; ``Simulation.timings`` gives each phase's seconds, printed
as ns per element-step with the ratio two threads / one thread (below 1: two are faster).

The rule under test is ``siku_core.parallel``: a loop with less work than ``PARALLEL_MIN``
reference items (a contact's cost, ``ITEM_NS``) runs in one chunk on the calling thread
(``chunks(n, item_ns)``, ``alone``), and a scene below ``PARALLEL_MIN`` elements runs its whole
loop on one thread (``threads_for``), so that a run on all cores is never slower than on one.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba

from bench.scenes import text
from siku_core.scene import scene_from_text
from siku_core.simulation import PHASES, Simulation

#: timed steps per thread count by size (about a second of work each on this machine)
STEPS = {24: 2000, 400: 600, 4000: 120, 40000: 40, 400000: 20}
#: steps per block: thread counts alternate every block (a multiple of the snapshot interval,
#: so that every block writes as many snapshots)
BLOCK = {24: 200, 400: 60, 4000: 20, 40000: 10, 400000: 10}


def measure(n: int, threads: list[int], every: int, steps: int | None = None) -> dict:
    """Seconds per phase (and ``wall``) of ``steps`` steps at each thread count, alternated."""
    steps = steps or STEPS.get(n, max(4, 2_000_000 // max(n, 1)))
    block = min(BLOCK.get(n, max(2, steps // 10)), steps)
    block = max(every, block // every * every)
    src = text("bonded", n, steps=10 * steps + 10)
    dt_line = next(line for line in src.splitlines() if line.startswith("dt ="))
    dt = float(dt_line.split("=")[1])
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.h5"
        src += f'\n[output]\nfile = "{out}"\nevery = {dt * every!r}\n'
        sim = Simulation(scene_from_text(src, f"<bench threads {n}>"), progress=False)
        sim.advance(2)  # compile and settle
        acc = {t: dict.fromkeys((*PHASES, "wall"), 0.0) for t in threads}
        before = numba.get_num_threads()
        try:
            done = 0
            while done < steps:
                k = min(block, steps - done)
                for t in threads:
                    numba.set_num_threads(t)
                    sim.reset_timings()
                    t0 = time.perf_counter()
                    sim.advance(k)
                    acc[t]["wall"] += time.perf_counter() - t0
                    for ph, v in sim.timings.items():
                        acc[t][ph] = acc[t].get(ph, 0.0) + v
                done += k
        finally:
            numba.set_num_threads(before)
            sim.close()
    return {"n": sim.state.n, "steps": steps, "by_threads": acc}


def table(results: list[dict], threads: list[int]) -> str:
    """Markdown: ns per element-step of each phase at each thread count, and the ratio."""
    head = " | ".join(f"{t} thread{'s' if t > 1 else ''} [ns]" for t in threads)
    lines = [f"| elements | phase | {head} | {threads[-1]} / {threads[0]} |",
             "|---" * (3 + len(threads)) + "|"]
    for r in results:
        n, steps, acc = r["n"], r["steps"], r["by_threads"]
        for ph in (*PHASES, "other", "wall"):
            vals = []
            for t in threads:
                a = acc[t]
                v = (a["wall"] - sum(a.get(p, 0.0) for p in PHASES)) if ph == "other" \
                    else a.get(ph, 0.0)
                vals.append(max(v, 0.0) / steps / n * 1e9)
            if ph not in ("wall", "other") and max(vals) < 0.5:
                continue
            ratio = vals[-1] / vals[0] if vals[0] > 0 else float("nan")
            cells = " | ".join(f"{v:.1f}" for v in vals)
            name = f"**{ph}**" if ph == "wall" else ph
            lines.append(f"| {n} | {name} | {cells} | {ratio:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="24,400,4000,40000,400000")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--every", type=int, default=10, help="steps between snapshots")
    ap.add_argument("--steps", type=int, default=None, help="timed steps per thread count")
    a = ap.parse_args(argv)
    threads = [int(t) for t in a.threads.split(",")]
    results = []
    for n in (int(s) for s in a.sizes.split(",")):
        results.append(measure(n, threads, a.every, a.steps))
        print(f"# {n} elements done", flush=True)
    print(f"## python -m bench.threads --sizes {a.sizes} --threads {a.threads}\n")
    print(table(results, threads))


if __name__ == "__main__":
    main()
