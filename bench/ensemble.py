"""Ensemble benchmark: 8 small members on a local Dask cluster of 2 workers against the same 8
run one after another in one process (``python -m bench.ensemble``).

The members are the rheology-comparison scene (48 elements, ``dt = 10 s``) run for 24 h
(``--duration``; 8 640 steps) with two contact laws times four values of the anticyclone's
``vmax``. Each measurement runs in
a fresh Python process (kernels loaded from the on-disk cache, as a user's second run), into an
empty folder; ``--repeat`` processes of each kind alternate. Reported per kind: the wall time of
``ensemble.run`` (best and median), and for the cluster its start-up (until the workers are up)
and the overhead per member: ``(workers × (wall − start-up) − Σ member run times) / members``,
the time a worker spent on a member beyond running it (scheduling, process start-up of the
worker, loading kernels, transfers). Speed-up = serial wall / cluster wall, start-up included.

Example::

    python -m bench.ensemble --repeat 3
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "rheology_comparison.toml"


def sweep(duration: str = "24h") -> dict:
    return {"title": "bench ensemble", "scene": str(SCENE), "set": {"time.duration": duration},
            "axis": [{"key": "contact.law", "values": ["distributed_spring", "mohr_coulomb"]},
                     {"key": "forcing.0.field.params.vmax", "values": [8.0, 9.0, 10.0, 11.0]}],
            "summary": {"final": ["joints_broken"]}}


def _worker(kind: str, workers: int, duration: str) -> None:
    t0 = time.perf_counter()
    from siku_io.ensemble import runs as ensemble

    t_import = time.perf_counter() - t0
    started: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        t1 = time.perf_counter()
        ds = ensemble.run(sweep(duration), scheduler="serial" if kind == "serial" else None,
                          workers=workers, threads=1, out_dir=tmp, progress=False, write=False,
                          on_start=lambda _: started.append(time.perf_counter()))
        wall = time.perf_counter() - t1
    assert (ds.status.values == "done").all(), ds.message.values
    print(json.dumps({"kind": kind, "import_s": t_import, "wall_s": wall,
                      "startup_s": started[0] - t1, "members": int(ds.status.size),
                      "member_sum_s": float(ds.wall_time.sum()),
                      "member_max_s": float(ds.wall_time.max())}))


def _run(kind: str, workers: int, duration: str) -> dict:
    out = subprocess.run([sys.executable, "-m", "bench.ensemble", "--worker", kind,
                          "--workers", str(workers), "--duration", duration], cwd=ROOT,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.ensemble", description=__doc__.split(
        "\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="processes of each kind")
    ap.add_argument("--workers", type=int, default=2, help="worker processes of the cluster")
    ap.add_argument("--duration", default="24h", help="model time of each member")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        _worker(args.worker, args.workers, args.duration)
        return 0
    _run("serial", 1, "1h")  # fill the kernel cache first (not timed)
    res: dict[str, list[dict]] = {"serial": [], "cluster": []}
    for _ in range(args.repeat):
        for kind in ("serial", "cluster"):
            res[kind].append(_run(kind, args.workers, args.duration))
            print(f"  {kind}: {res[kind][-1]['wall_s']:.2f} s", file=sys.stderr)
    w = args.workers
    rows = []
    for kind, rs in res.items():
        walls = [r["wall_s"] for r in rs]
        n = rs[0]["members"]
        if kind == "cluster":
            over = [(w * (r["wall_s"] - r["startup_s"]) - r["member_sum_s"]) / n for r in rs]
            start = [r["startup_s"] for r in rs]
            extra = (f"{min(start):.2f} ({statistics.median(start):.2f})",
                     f"{min(over):.3f} ({statistics.median(over):.3f})")
        else:
            extra = ("—", "—")
        member = [r["member_sum_s"] / n for r in rs]
        rows.append((kind, f"{min(walls):.2f} ({statistics.median(walls):.2f})",
                     f"{min(member):.3f} ({statistics.median(member):.3f})", *extra))
    s = [r["wall_s"] for r in res["serial"]]
    c = [r["wall_s"] for r in res["cluster"]]
    print(f"{res['serial'][0]['members']} members of {args.duration}, {w} workers, best "
          f"(median) of "
          f"{args.repeat} processes each\n")
    print("| run | wall [s] | member run time, mean [s] | cluster start-up [s] "
          "| overhead per member [s] |")
    print("|---|---:|---:|---:|---:|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
    print(f"\nspeed-up of the cluster (start-up included): best {min(s) / min(c):.2f}, "
          f"median {statistics.median(s) / statistics.median(c):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
