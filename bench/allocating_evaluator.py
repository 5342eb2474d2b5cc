"""What an allocating evaluator costs: the distributed spring against the same law whose
evaluator goes through an allocated temporary (``np.zeros(4)`` per joint and step).

An evaluator that allocates needs numba's reference counting, so siku compiles its joint loop
with it (``siku_core.contact.kernel_cache``): the loop's array views and calls then pay atomic
reference-count operations too. Both laws compute the same forces bit for bit (a test holds
this); only the time differs.

    python -m bench.allocating_evaluator [--n 10000] [--steps 40] [--repeat 3]

Runs the bonded pack of ``bench.scenes`` on one thread, the two laws alternated in one process
``--repeat`` times, and prints the joint phase's cost per joint and step (best and median).
"""
from __future__ import annotations

import argparse
import statistics

import numpy as np
from numba import njit

from siku_plugins.contact_laws import DistributedSpring, spring_evaluator


@njit(cache=True)
def allocating_spring(g, pars, hist, out):
    """The spring evaluator through an allocated temporary."""
    tmp = np.zeros(4)
    spring_evaluator(g, pars, hist, tmp)
    for a in range(4):
        out[a] = tmp[a]


class AllocatingSpring(DistributedSpring):
    """The distributed spring with an allocating evaluator (benchmark only)."""

    name = "allocating_spring_bench"
    joint_evaluator = allocating_spring


def _joint_ns(law_cls, n: int, steps: int) -> float:
    """Joint phase [ns] per joint and step on the bonded pack, one thread."""
    import numba

    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.testing.contact_conformance import law_registry

    from .scenes import bonded_text

    text = bonded_text(n, "distributed_spring", steps=steps + 10)
    text = text.replace('law = "distributed_spring"', f'law = "{law_cls.name}"')
    sim = Simulation(scene_from_text(text, "<bench>"), out=False, progress=False,
                     registry=law_registry(law_cls))
    numba.set_num_threads(1)
    for _ in range(3):
        sim.step()
    sim.reset_timings()
    for _ in range(steps):
        sim.step()
    return sim.timings["joints"] / steps / sim.contacts.n_intact * 1e9


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.allocating_evaluator",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=10000, help="elements (default 10000)")
    ap.add_argument("--steps", type=int, default=40, help="timed steps (default 40)")
    ap.add_argument("--repeat", type=int, default=3, help="alternations (default 3)")
    a = ap.parse_args(argv)
    res: dict[str, list[float]] = {"distributed_spring": [], "allocating": []}
    for _ in range(a.repeat):
        res["distributed_spring"].append(_joint_ns(DistributedSpring, a.n, a.steps))
        res["allocating"].append(_joint_ns(AllocatingSpring, a.n, a.steps))
    print(f"joint phase, ns per joint and step, {a.n} elements, 1 thread, {a.steps} steps, "
          f"{a.repeat} alternations")
    print("| evaluator | best | median |\n|---|---|---|")
    for k, v in res.items():
        print(f"| {k} | {min(v):.0f} | {statistics.median(v):.0f} |")
    ratio = statistics.median(res["allocating"]) / statistics.median(res["distributed_spring"])
    print(f"ratio allocating / non-allocating (medians): {ratio:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
