"""The test suite's CPU time per test: a pytest plugin, and a summary of what it wrote.

CPU time (user + system of the test's process and of the processes it waited for, read with
``getrusage`` before and after each test) carries over from a busy machine to an idle one;
wall time does not. Each test also names the contact-loop instances it added to the kernel
cache (``siku_core.contact.kernel_cache``): a compile of a loop of its own. Run from the
repository root::

    NUMBA_NUM_THREADS=1 SUITE_CPU=/tmp/suite_cpu.jsonl python -m pytest -q -n 2 \\
        --dist loadfile -p bench.suite_cpu
    python -m bench.suite_cpu /tmp/suite_cpu.jsonl      # by file and the costliest tests

One JSON line per test (``id``, ``cpu`` [s], ``wall`` [s], ``new_kernels``), appended to
``$SUITE_CPU`` (default ``suite_cpu.jsonl`` in the working directory) by every worker.
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import resource
import time

import pytest


def _cpu() -> float:
    """User + system seconds of this process and of its waited-for children."""
    a = resource.getrusage(resource.RUSAGE_SELF)
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _kernels() -> set[str]:
    """The contact-loop instances compiled into the kernel cache so far."""
    from siku_core.contact.kernel_cache import cache_dir

    d = cache_dir()
    if d is None or not (d / "__pycache__").is_dir():
        return set()
    return {p.name.split(".")[0] for p in (d / "__pycache__").glob("*.nbi")}


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    k0, c0, t0 = _kernels(), _cpu(), time.time()
    yield
    row = {"id": item.nodeid, "cpu": round(_cpu() - c0, 2), "wall": round(time.time() - t0, 2),
           "new_kernels": sorted(_kernels() - k0)}
    with open(os.environ.get("SUITE_CPU", "suite_cpu.jsonl"), "a", encoding="utf-8") as f:
        f.write(json.dumps(row) + "\n")


def summary(paths: list[str], top: int = 30) -> str:
    """The CPU seconds by file and the ``top`` costliest tests of the files ``paths``."""
    rows = [json.loads(line) for p in paths for line in open(p, encoding="utf-8") if line.strip()]
    by_file: collections.Counter = collections.Counter()
    for r in rows:
        by_file[r["id"].split("::")[0]] += r["cpu"]
    out = [f"{len(rows)} tests, {sum(r['cpu'] for r in rows):.1f} s of CPU", "", "by file:"]
    out += [f"{s:8.1f}  {f}" for f, s in by_file.most_common()]
    out += ["", f"the {top} costliest tests (CPU s, wall s, loops compiled):"]
    for r in sorted(rows, key=lambda r: -r["cpu"])[:top]:
        out.append(f"{r['cpu']:8.1f} {r['wall']:8.1f}  {r['id']}  {' '.join(r['new_kernels'])}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="+", help="JSON-lines files the plugin wrote")
    ap.add_argument("--top", type=int, default=30)
    a = ap.parse_args(argv)
    print(summary(a.files, a.top))


if __name__ == "__main__":
    main()
