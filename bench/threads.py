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

``python -m bench.threads --defaults`` (``--scene default`` or ``--scene bonded:10000``,
``--rounds 5``, ``--steps 300``) measures the thread settings a user gets without choosing:
each round runs the scene in a fresh process per configuration, one after the other, so each
configuration sees the same load: ``1 thread`` (``NUMBA_NUM_THREADS=1``), ``all threads``
(all cores, idle threads spinning as OpenMP lets them by default: what ``siku run`` did
before), ``siku run (chosen)`` (``Simulation.auto_threads``: one thread or all, timed as the
run goes, ``siku_core.parallel.ThreadTuner``), ``PASSIVE`` (all cores, idle threads asleep)
and ``workqueue`` (numba's own threading layer). It prints steps per second of one
``Simulation.run`` (median and every round, after untimed steps that load the kernels), the
steps taken on each thread count, and the load averages at the start of each round.

``python -m bench.threads --cold`` (``--scene``) builds the scene and takes its first step in
a fresh process with empty numba and siku kernel caches (``NUMBA_CACHE_DIR``,
``SIKU_KERNEL_CACHE`` in a temporary folder): the compile time, the kernels compiled and the
ten slowest (``siku_core.run.progress.CompileClock``).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba

from bench.scenes import text
from siku_core import parallel
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import PHASES, Simulation

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


#: the configurations of ``--defaults``: environment of the child process (``AUTO``: the
#: run chooses its threads as ``siku run`` does, ``Simulation.auto_threads``)
CONFIGS = {"1 thread": {"NUMBA_NUM_THREADS": "1"}, "all threads": {},
           "siku run (chosen)": {"AUTO": "1"}, "PASSIVE": {"OMP_WAIT_POLICY": "PASSIVE"},
           "workqueue": {"NUMBA_THREADING_LAYER": "workqueue"}}
#: variables a configuration starts without (the user's choices of thread waiting, threads)
CLEARED = ("NUMBA_NUM_THREADS", "OMP_WAIT_POLICY", "KMP_BLOCKTIME", "GOMP_SPINCOUNT",
           "NUMBA_THREADING_LAYER")


def scene_of(spec: str, steps: int):
    """The scene ``default`` (the shipped one) or ``bonded:N`` (the bonded pack of N)."""
    if spec == "default":
        from siku_core.run.cli import default_scene_path
        from siku_core.scene.scene_file import load_scene

        return load_scene(default_scene_path())
    kind, _, n = spec.partition(":")
    return scene_from_text(text(kind, int(n or 10000), steps=steps), f"<bench {spec}>")


def child(spec: str, steps: int, warm: int, auto: bool) -> dict:
    """In a fresh process: ``steps`` steps of the scene (one :meth:`Simulation.run`, the
    threads chosen as it runs when ``auto``) after ``warm`` untimed ones."""
    sim = Simulation(scene_of(spec, warm + steps + 2), out=False, progress=False)
    sim.advance(warm)
    sim.auto_threads = auto
    t0 = time.perf_counter()
    sim.run(steps)
    wall = time.perf_counter() - t0
    tuned = dict(parallel.LAST_TUNED) if auto else {numba.get_num_threads(): steps}
    return {"rate": steps / wall, "threads": numba.get_num_threads(), "tuned": tuned,
            "layer": numba.threading_layer(), "n": sim.state.n,
            "policy": os.environ.get("OMP_WAIT_POLICY")}


def _spawn(args: list[str], env: dict) -> dict:
    r = subprocess.run([sys.executable, "-m", "bench.threads", *args], env=env,
                       capture_output=True, text=True, check=False, timeout=3600)
    if r.returncode != 0:
        raise RuntimeError(r.stderr[-2000:])
    return json.loads(r.stdout.strip().splitlines()[-1])


def defaults(spec: str, rounds: int, steps: int, warm: int) -> str:
    """``--defaults``: steps per second of each configuration of :data:`CONFIGS`, in turns."""
    base = {k: v for k, v in os.environ.items() if k not in CLEARED}
    rates: dict[str, list[float]] = {c: [] for c in CONFIGS}
    used: dict[str, dict] = {c: {} for c in CONFIGS}  # steps per thread count
    info: dict[str, dict] = {}
    loads = []
    for _ in range(rounds):
        loads.append(os.getloadavg())
        for name, extra in CONFIGS.items():
            env = {**base, **{k: v for k, v in extra.items() if k != "AUTO"}}
            argv = ["--child", spec, "--steps", str(steps), "--warm", str(warm)]
            got = _spawn(argv + (["--auto"] if "AUTO" in extra else []), env)
            rates[name].append(got["rate"])
            info[name] = got
            print(json.dumps({"config": name, **got}), file=sys.stderr, flush=True)
            for t, k in got["tuned"].items():
                used[name][t] = used[name].get(t, 0) + k
    one = statistics.median(rates["1 thread"])
    lines = [f"## python -m bench.threads --defaults --scene {spec} --rounds {rounds} "
             f"--steps {steps}\n",
             f"{info['1 thread']['n']} elements; load averages (1, 5, 15 min) at each round: "
             + "; ".join(f"{a:.1f} {b:.1f} {c:.1f}" for a, b, c in loads) + "\n",
             "| configuration | threads: steps | OMP_WAIT_POLICY | steps/s (median) | / 1 thread "
             "| every round |", "|---|---|---|---|---|---|"]
    for name in CONFIGS:
        med = statistics.median(rates[name])
        on = ", ".join(f"{t}: {k}" for t, k in sorted(used[name].items()))
        lines.append(f"| {name} | {on} ({info[name]['layer']}) | "
                     f"{info[name]['policy'] or 'unset'} | {med:.1f} | {med / one:.2f} | "
                     + ", ".join(f"{r:.1f}" for r in rates[name]) + " |")
    return "\n".join(lines)


def cold_child(spec: str) -> dict:
    """In a fresh process with empty caches: the scene's build and its first step."""
    from siku_core.run.progress import CompileClock

    t0 = time.perf_counter()
    with CompileClock() as clock:
        sim = Simulation(scene_of(spec, 10), out=False, progress=False)
        t1 = time.perf_counter()
        sim.advance(1)
    t2 = time.perf_counter()
    top = sorted(clock.kernels.items(), key=lambda kv: -kv[1])[:10]
    return {"build": t1 - t0, "first_step": t2 - t1, "compile": clock.seconds,
            "kernels": clock.count, "top": top}


def cold(spec: str) -> str:
    """``--cold``: compile times of the scene with empty caches, in a fresh process."""
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": f"{tmp}/numba", "SIKU_KERNEL_CACHE": f"{tmp}/k"}
        load = os.getloadavg()
        t0 = time.perf_counter()
        got = _spawn(["--cold-child", spec], env)
        total = time.perf_counter() - t0
    lines = [f"## python -m bench.threads --cold --scene {spec}\n",
             f"load averages {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}; process {total:.1f} s: "
             f"build {got['build']:.1f} s, first step {got['first_step']:.1f} s; "
             f"{got['kernels']} kernels compiled in {got['compile']:.1f} s; slowest:"]
    lines += [f"  {s:7.1f} s  {k}" for k, s in got["top"]]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="24,400,4000,40000,400000")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--every", type=int, default=10, help="steps between snapshots")
    ap.add_argument("--steps", type=int, default=None, help="timed steps per thread count")
    ap.add_argument("--defaults", action="store_true",
                    help="default thread settings against one thread, fresh processes")
    ap.add_argument("--cold", action="store_true", help="compile times with empty caches")
    ap.add_argument("--scene", default="default", help="default or bonded:N")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--warm", type=int, default=20, help="untimed steps first")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--auto", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--cold-child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(json.dumps(child(a.child, a.steps or 300, a.warm, a.auto)))
        return
    if a.cold_child:
        print(json.dumps(cold_child(a.cold_child)))
        return
    if a.defaults:
        print(defaults(a.scene, a.rounds, a.steps or 300, a.warm))
        return
    if a.cold:
        print(cold(a.scene))
        return
    threads = [int(t) for t in a.threads.split(",")]
    results = []
    for n in (int(s) for s in a.sizes.split(",")):
        results.append(measure(n, threads, a.every, a.steps))
        print(f"# {n} elements done", flush=True)
    print(f"## python -m bench.threads --sizes {a.sizes} --threads {a.threads}\n")
    print(table(results, threads))


if __name__ == "__main__":
    main()
