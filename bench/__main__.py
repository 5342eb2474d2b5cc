"""Benchmark runner: ``python -m bench`` (from the repository root) or ``siku bench``.

Prints markdown tables of element-steps/s (and joints/s) for the bonded Siku-like pack with
each contact law, for the collision-dominated broken pack and for free drift, on each thread
count asked for, with the first step (compilation or loading of the compiled kernels, and the
first candidate list) reported apart from the steady steps; the cost per element-step across
sizes; the distance to the planar C floor (``bench/floor.c``: the same joints, pairs and clips
written plainly in C, one thread); the time per phase of the step; and "only what a scene
requires" (a free-drift scene has no contact arrays, costs a fraction of a bonded one, and
imports no NetCDF library).

Every size runs in a fresh Python process (``--repeat`` of them) that builds each scene once and
times it on every thread count, the thread counts taking turns in blocks of ten steps (each
sees the same stretch of the run: a pack's cost per step drifts as it deforms); ratios (against
free drift of the same size, against 3 000 elements) are computed from numbers measured in the
same process.
The steady rate uses the median step time of ``--steps`` steps per thread count after the
first step and two warm-up steps per thread count; ``--spinup N`` runs ``N`` steps before any
of it (a later stretch of the run).

Examples::

    python -m bench --quick                        # < 1 min: 3 000 elements, distributed_spring
    python -m bench                                # the full tables (3k, 10k, 40k; all laws)
    python -m bench --sizes 10000 --laws distributed_spring --threads 1,2 --repeat 3
    python -m bench --cold                         # empty kernel caches: true compile times
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the benchmark scenes (``bench.scenes.KINDS``; not imported here: the runner sets the thread
#: environment before anything imports numba)
KINDS = ("bonded", "bonded_ignore", "bonded_exclude", "collision", "free_drift", "floe",
         "floe_ignore", "floe_exclude")
#: scenes run for every law of ``--laws``
LAW_KINDS = ("bonded", "bonded_ignore", "bonded_exclude")
#: scenes run with ``bonded_particle`` and every other joint law of ``--laws``
FLOE_KINDS = ("floe", "floe_ignore", "floe_exclude")
#: steps per turn of a thread count (switching every step costs the 2-thread run about 2 %)
BLOCK = 10


def floe_laws(laws: list[str]) -> list[str]:
    """The laws a floe scene runs with: ``bonded_particle`` (Orzech et al.'s), then the other joint
    laws asked for, on the same elements and joints."""
    return ["bonded_particle"] + [x for x in laws if x not in ("collision", "bonded_particle")]


# ---------------------------------------------------------------------------------- worker
def step_times(sim, steps: int) -> list[float]:
    """Wall time [s] of each of ``steps`` calls of ``sim.step()``."""
    per = []
    for _ in range(steps):
        ta = time.perf_counter()
        sim.step()
        per.append(time.perf_counter() - ta)
    return per


def _measure(kind: str, n: int, law: str, steps: int, threads: list[int],
             floor: bool = True, spinup: int = 0) -> dict:
    import numba

    from siku_core.run.simulation import Simulation

    from .scenes import scene

    t0 = time.perf_counter()
    sc = scene(kind, n, law, steps=spinup + (steps + 3) * len(threads) + 10)
    t1 = time.perf_counter()
    sim = Simulation(sc, out=False, progress=False)
    t2 = time.perf_counter()
    cm = sim.contacts
    out: dict = {
        "kind": kind, "law": {"collision": "collision", "free_drift": "-"}.get(kind, law),
        "elements": sim.state.n, "scene_s": t1 - t0, "setup_s": t2 - t1, "runs": [],
        "spinup": spinup,
    }
    numba.set_num_threads(threads[0])
    ta = time.perf_counter()
    sim.step()
    first = time.perf_counter() - ta
    for _ in range(spinup):
        sim.step()
    for th in threads:  # warm-up: every thread count's kernels loaded and run once
        numba.set_num_threads(th)
        for _ in range(2):
            sim.step()
    # the thread counts take turns in blocks of BLOCK steps, so that each sees the same stretch
    # of the run (a scene's cost per step drifts as its pack deforms: bench/RESULTS.md)
    per: dict = {th: [] for th in threads}
    phases: dict = {th: dict.fromkeys(sim.timings, 0.0) for th in threads}
    for b in range(0, steps, BLOCK):
        for th in threads:
            numba.set_num_threads(th)
            for _ in range(min(BLOCK, steps - b)):
                before = dict(sim.timings)
                ta = time.perf_counter()
                sim.step()
                per[th].append(time.perf_counter() - ta)
                for key, v in sim.timings.items():
                    phases[th][key] = phases[th].get(key, 0.0) + v - before.get(key, 0.0)
    for th in threads:
        med = statistics.median(per[th])
        run = {
            "threads": th, "steps": steps, "median_step_s": med, "min_step_s": min(per[th]),
            "mean_step_s": sum(per[th]) / len(per[th]),
            "element_steps_per_s": sim.state.n / med,
            "phases_s_per_step": {p: v / steps for p, v in phases[th].items()},
        }
        if cm is not None:
            run.update(joints=cm.n_intact, pairs=int(len(cm.pairs)), overlapping=int(cm.n_overlap),
                       rebuilds=int(cm.rebuilds), joints_per_s=cm.n_intact / med)
        out["runs"].append(run)
    if floor and cm is not None:
        from . import floor as probe

        numba.set_num_threads(threads[0])
        out["floor"] = probe.measure(sim)
    out["first_step_s"] = first
    out["compile_s"] = max(0.0, first - out["runs"][0]["median_step_s"])
    return out


def _requires(n: int, steps: int) -> dict:
    """Free drift against the bonded pack of the same size, in this process: contact arrays,
    traced memory, cost per step, and which I/O libraries got imported."""
    import tracemalloc

    import numba
    import numpy as np

    from siku_core.run.simulation import Simulation

    from .scenes import scene

    numba.set_num_threads(1)
    res: dict = {"elements": n}
    for kind in ("free_drift", "bonded"):
        sc = scene(kind, n, "distributed_spring", steps=steps + 10)
        sim = Simulation(sc, out=False, progress=False)
        for _ in range(3):  # compile and warm up outside the traced region
            sim.step()
        per = []
        for _ in range(steps):
            ta = time.perf_counter()
            sim.step()
            per.append(time.perf_counter() - ta)
        cm = sim.contacts
        arrays = 0
        if cm is not None:
            arrays = sum(v.nbytes for v in vars(cm).values() if isinstance(v, np.ndarray))
        tracemalloc.start()
        sim2 = Simulation(sc, out=False, progress=False)
        for _ in range(3):
            sim2.step()
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        res[kind] = {"contacts_none": cm is None, "contact_array_bytes": int(arrays),
                     "traced_peak_bytes": int(peak), "median_step_s": statistics.median(per)}
    res["cost_ratio"] = res["free_drift"]["median_step_s"] / res["bonded"]["median_step_s"]
    heavy = ("netCDF4", "xarray", "h5py")
    res["imported"] = sorted(m for m in heavy if m in sys.modules)
    return res


def _worker(args: argparse.Namespace) -> None:
    if os.environ.get("SIKU_BENCH_COHERENT") == "1":  # --coherent
        from siku_core.testing import switches
        switches.coherent_clip = True
    if args.worker == "requires":
        print(json.dumps(_requires(args.sizes[0], args.steps)))
        return
    results = []
    n = args.sizes[0]
    for kind in args.scenes:
        laws = (args.laws if kind in LAW_KINDS
                else floe_laws(args.laws) if kind in FLOE_KINDS else ["collision"])
        for law in laws:
            results.append(_measure(kind, n, law, args.steps, args.threads,
                                    floor=not args.no_floor, spinup=args.spinup))
    print(json.dumps(results))


# ---------------------------------------------------------------------------------- driver
def _spawn(argv: list[str], env: dict) -> object:
    cmd = [sys.executable, "-m", "bench", *argv]
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write(r.stderr)
        raise SystemExit(f"bench: worker failed: {' '.join(cmd)}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def _fmt(x: float) -> str:
    return f"{x:.3g}" if x < 1e4 else f"{x:.2e}".replace("e+0", "e").replace("e+", "e")


def _machine() -> str:
    import numba
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, numba "
            f"{numba.__version__}, NUMBA_THREADING_LAYER={numba.config.THREADING_LAYER}")


def _best(reps: list[list[dict]]) -> list[dict]:
    """Per case and thread count, the best rate over the repeats (and its step time) and the
    median rate; everything else (phases, counts, the C floor) from the repeat with the highest
    single-thread rate. (A repeat's two-thread rate can fall far below the others' while its
    one-thread rate is the best: the two virtual CPUs of these machines are at times unequal.)"""
    out = []
    for cases in zip(*reps):
        best = max(cases, key=lambda c: c["runs"][0]["element_steps_per_s"])
        best = json.loads(json.dumps(best))
        for i, r in enumerate(best["runs"]):
            rates = [c["runs"][i]["element_steps_per_s"] for c in cases]
            r["median_over_repeats"] = statistics.median(rates)
            r["element_steps_per_s"] = max(rates)
            r["median_step_s"] = min(c["runs"][i]["median_step_s"] for c in cases)
            if r.get("joints"):
                r["joints_per_s"] = r["joints"] / r["median_step_s"]
        out.append(best)
    return out


def _floor_cells(r: dict, ns: float) -> str:
    """The planar C floor of the case (one thread, best of its repetitions) and the ratio."""
    fl = r.get("floor")
    if not fl:
        return " | "
    return f"{fl['best_ns']:.0f} | {ns / fl['best_ns']:.2f}"


def _tables(results: list[dict], threads: list[int], repeat: int) -> str:
    lines: list[str] = []
    free = {r["elements"]: r for r in results if r["kind"] == "free_drift"}
    sizes = sorted({r["elements"] for r in results})
    base = sizes[0]
    for th in threads:
        lines.append(f"\n### {th} thread{'s' if th > 1 else ''}\n")
        lines.append("| scene | law | elements | joints | pairs (overlapping) | first step [s] | "
                     "step [ms] | element-steps/s | joints/s | ns / element-step | "
                     f"vs {base} | vs free drift | C floor [ns] | × floor |")
        lines.append("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for kind in KINDS:
            for r in [x for x in results if x["kind"] == kind]:
                run = next(x for x in r["runs"] if x["threads"] == th)
                ns = 1e9 / run["element_steps_per_s"]
                ref = next((x for x in results if x["kind"] == kind and x["law"] == r["law"]
                            and x["elements"] == base), None)
                scale = ""
                if ref is not None:
                    rr = next(x for x in ref["runs"] if x["threads"] == th)
                    scale = f"{ns * rr['element_steps_per_s'] / 1e9:.2f}"
                fd = free.get(r["elements"])
                vs_free = ""
                if fd is not None:
                    fr = next(x for x in fd["runs"] if x["threads"] == th)
                    vs_free = f"{run['median_step_s'] / fr['median_step_s']:.1f}"
                rate = _fmt(run["element_steps_per_s"])
                if repeat > 1:
                    rate += f" ({_fmt(run['median_over_repeats'])})"
                lines.append(
                    f"| {kind} | {r['law']} | {r['elements']} | {run.get('joints', 0)} | "
                    f"{run.get('pairs', 0)} ({run.get('overlapping', 0)}) | "
                    f"{r['first_step_s']:.2f} | {run['median_step_s'] * 1e3:.2f} | {rate} | "
                    f"{_fmt(run['joints_per_s']) if run.get('joints') else '-'} | {ns:.0f} | "
                    f"{scale} | {vs_free} | {_floor_cells(r, ns)} |")
    if len(threads) > 1:
        lines.append(f"\n### speed-up, {threads[-1]} threads against {threads[0]}\n")
        lines.append("| scene | law | elements | speed-up |")
        lines.append("|---|---|---:|---:|")
        for r in results:
            a = next(x for x in r["runs"] if x["threads"] == threads[0])
            b = next(x for x in r["runs"] if x["threads"] == threads[-1])
            lines.append(f"| {r['kind']} | {r['law']} | {r['elements']} | "
                         f"{b['element_steps_per_s'] / a['element_steps_per_s']:.2f} |")
    th = threads[0]
    phases = list(dict.fromkeys(p for r in results for p in r["runs"][0]["phases_s_per_step"]))
    lines.append(f"\n### time per phase, ns per element-step ({th} thread{'s' if th > 1 else ''})"
                 "\n")
    lines.append("| scene | law | elements | " + " | ".join(phases) + " |")
    lines.append("|---|---|---:|" + "---:|" * len(phases))
    for r in results:
        run = next(x for x in r["runs"] if x["threads"] == th)
        cells = [f"{run['phases_s_per_step'].get(p, 0.0) / r['elements'] * 1e9:.0f}"
                 for p in phases]
        lines.append(f"| {r['kind']} | {r['law']} | {r['elements']} | " + " | ".join(cells) + " |")
    lines.append("\nSet-up (scene text + validation, then elements, joints and first candidate "
                 "list), not part of any rate:\n")
    lines.append("| scene | law | elements | scene [s] | build [s] | first step [s] | "
                 "of which compile/load [s] |")
    lines.append("|---|---|---:|---:|---:|---:|---:|")
    for r in results:
        lines.append(f"| {r['kind']} | {r['law']} | {r['elements']} | {r['scene_s']:.2f} | "
                     f"{r['setup_s']:.2f} | {r['first_step_s']:.2f} | {r['compile_s']:.2f} |")
    return "\n".join(lines)


def _requires_table(res: dict) -> str:
    fd, bd = res["free_drift"], res["bonded"]
    return "\n".join([
        f"\n### only what a scene requires ({res['elements']} elements, 1 thread)\n",
        "| scene | sim.contacts | contact arrays [MB] | traced peak, build + 3 steps [MB] | "
        "step [ms] |",
        "|---|---|---:|---:|---:|",
        f"| free_drift | {'None' if fd['contacts_none'] else 'ContactModel'} | "
        f"{fd['contact_array_bytes'] / 1e6:.2f} | {fd['traced_peak_bytes'] / 1e6:.2f} | "
        f"{fd['median_step_s'] * 1e3:.3f} |",
        f"| bonded distributed_spring | {'None' if bd['contacts_none'] else 'ContactModel'} | "
        f"{bd['contact_array_bytes'] / 1e6:.2f} | {bd['traced_peak_bytes'] / 1e6:.2f} | "
        f"{bd['median_step_s'] * 1e3:.3f} |",
        f"\nfree drift costs {res['cost_ratio']:.3f} of the bonded step; I/O libraries imported "
        f"after building and running both scenes: {', '.join(res['imported']) or 'none'}.",
    ])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="3000,10000,40000",
                    help="element counts, comma-separated (default: 3000,10000,40000)")
    ap.add_argument("--laws", default="collision,distributed_spring,mohr_coulomb,bonded_particle",
                    help="contact laws of the bonded pack (default: all four); the floe runs "
                         "bonded_particle and the other joint laws of the list")
    ap.add_argument("--scenes", default=",".join(KINDS),
                    help="scenes: bonded, bonded_ignore (contact.touching = ignore), "
                         "bonded_exclude (contact.jointed = exclude), collision, free_drift, "
                         "floe, floe_ignore, floe_exclude (default: all)")
    ap.add_argument("--steps", type=int, default=50,
                    help="timed steps per case and thread count (default 50)")
    ap.add_argument("--spinup", type=int, default=0,
                    help="steps run before the timed ones (default 0: the run's first steps)")
    ap.add_argument("--threads", default="1,2", help="numba thread counts (default 1,2)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="fresh processes per size; the best is shown, the median in brackets")
    ap.add_argument("--quick", action="store_true",
                    help="3 000 elements, distributed_spring, 20 steps (under a minute)")
    ap.add_argument("--cold", action="store_true",
                    help="empty numba and siku kernel caches: first steps include compilation")
    ap.add_argument("--no-requires", action="store_true",
                    help="skip the 'only what a scene requires' check")
    ap.add_argument("--no-floor", action="store_true",
                    help="skip the planar C floor (bench/floor.c; needs a C compiler)")
    ap.add_argument("--json", help="also write the raw results to this file")
    ap.add_argument("--coherent", action="store_true",
                    help="the coherent clip (siku_core.geometry.coherent; off by default)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.quick:
        args.sizes, args.laws, args.steps = "3000", "distributed_spring", 20
    args.sizes = [int(s) for s in str(args.sizes).split(",") if s]
    args.laws = [s for s in str(args.laws).split(",") if s]
    args.scenes = [s for s in str(args.scenes).split(",") if s]
    args.threads = [int(s) for s in str(args.threads).split(",") if s]
    bad = [s for s in args.scenes if s not in KINDS]
    if bad:
        ap.error(f"unknown scene {bad[0]!r}; known: {', '.join(KINDS)}")
    if args.worker:
        _worker(args)
        return 0

    import numba
    avail = numba.config.NUMBA_NUM_THREADS
    if max(args.threads) > avail:
        print(f"bench: only {avail} numba threads available; dropping larger counts",
              file=sys.stderr)
        args.threads = [t for t in args.threads if t <= avail] or [1]
    env = dict(os.environ)
    env["SIKU_BENCH_COHERENT"] = "1" if args.coherent else "0"
    tmp = None
    if args.cold:
        tmp = tempfile.TemporaryDirectory(prefix="siku-bench-")
        env["NUMBA_CACHE_DIR"] = str(Path(tmp.name) / "numba")
        env["SIKU_KERNEL_CACHE"] = str(Path(tmp.name) / "kernels")
    common = ["--steps", str(args.steps), "--spinup", str(args.spinup),
              "--threads", ",".join(map(str, args.threads)),
              "--laws", ",".join(args.laws), "--scenes", ",".join(args.scenes),
              *(["--no-floor"] if args.no_floor else [])]
    t0 = time.perf_counter()
    results = []
    for n in args.sizes:
        reps = []
        for _ in range(max(1, args.repeat)):
            if args.cold and reps:  # every repeat compiles afresh
                tmp.cleanup()
                tmp = tempfile.TemporaryDirectory(prefix="siku-bench-")
                env["NUMBA_CACHE_DIR"] = str(Path(tmp.name) / "numba")
                env["SIKU_KERNEL_CACHE"] = str(Path(tmp.name) / "kernels")
            reps.append(_spawn(["--worker", "cases", "--sizes", str(n), *common], env))
            print(f"bench: {n} elements done ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr)
        results.extend(_best(reps))
    req = None
    if not args.no_requires:
        req = _spawn(["--worker", "requires", "--sizes", str(args.sizes[0]), "--steps", "10"],
                     env)
    if tmp is not None:
        tmp.cleanup()
    cmd = "python -m bench " + " ".join(a for a in (argv if argv is not None else sys.argv[1:]))
    print(f"## {cmd.strip()}\n")
    print(f"machine: {_machine()}; {'cold' if args.cold else 'warm'} kernel caches; "
          f"{args.steps} timed steps per case and thread count, the thread counts taking turns"
          f" every {BLOCK} steps"
          + (f", after {args.spinup} steps of spin-up" if args.spinup else "")
          + "; rate from the median step"
          + (f"; best of {args.repeat} processes (median in brackets)" if args.repeat > 1 else ""))
    print(_tables(results, args.threads, args.repeat))
    if req is not None:
        print(_requires_table(req))
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")
    if args.json:
        Path(args.json).write_text(json.dumps({"results": results, "requires": req}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
