"""One contact phase timed alone: the joint loop and the collision loop of a benchmark scene.

``python -m bench.phase collision`` (from the repository root) builds a scene of
:mod:`bench.scenes` (10 000 elements by default), runs ``--spinup`` steps, then calls the
engine's :func:`~siku_core.contact.contact_forces.collision_forces` and, where the law has joints,
:func:`~siku_core.contact.contact_forces.joint_forces` on that state ``--reps`` times each and
prints the best
time per element (ns per element-step, the unit of the phase table in ``bench/RESULTS.md``),
per candidate pair and per joint. Joint histories are not committed, so every repetition does
the same work on the same state; the numbers isolate a kernel from the rest of the step (no
broad phase, no gather, no integrator), which whole-step benchmarks cannot.

``--processes N`` repeats the measurement in N fresh processes and prints each process's
best: one process's best can sit in a slow mode of its own (``bench/RESULTS.md``, "Process
modes"), so kernel changes are compared over several processes, not one.

    python -m bench.phase bonded --law mohr_coulomb --reps 60
    python -m bench.phase collision --processes 6
    python -m bench.phase collision --coherent     # the coherent clip (geometry.coherent)
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numba

from bench.scenes import KINDS, LAWS, scene
from siku_core.contact.contact_tables import NO_DMOB, pair_table
from siku_core.contact.contact_forces import collision_forces, joint_forces
from siku_core.parallel import chunks
from siku_core.run.simulation import Simulation
from siku_core.testing import switches


def _best(fn, reps: int) -> tuple[float, object]:
    best, res = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        res = fn()
        best = min(best, time.perf_counter() - t0)
    return best, res


def measure(kind: str, n: int, law: str | None, spinup: int, reps: int,
            coherent: bool = False) -> dict:
    """Best seconds of one call of each contact phase on ``kind`` after ``spinup`` steps
    (``coherent``: with the coherent clip, ``switches.coherent_clip``, from the spin-up on)."""
    switches.coherent_clip = coherent
    sim = Simulation(scene(kind, n, law), out=False)
    for _ in range(spinup):
        sim.step()
    cm, st = sim.contacts, sim.state
    if cm is None:
        raise ValueError(f"bench.phase: scene {kind!r} has no contacts")
    pairs = cm._candidates(st.q, cm._rotations(st.q))

    # the dampers unbounded, no per-contact history, no cap flags: the loops' work alone
    el = cm.element_table(st.V, st.w)._replace(dmob=NO_DMOB)
    pt = pair_table(pairs, cm.pair_rows, cm.pair_active, cm.separating_hint, cm.pface,
                    chint=cm.clip_hint if len(cm.clip_hint) else None)
    cm.jK  # the joints' constants current (no fresh ones in the timed loop)
    jt = cm.joint_table() if cm.n_joints and cm.law.uses_joints else None

    def collisions():
        return collision_forces(cm._cev, cm._cpars, el, pt, sim.radius, cm.nmax,
                                switches.pretest, chunks(len(pairs)), cm.drop_touching)

    def joints():
        return joint_forces(cm._jev, cm._jpars, el, jt, sim.radius, sim.dt, False,
                            chunks(cm.n_joints))

    out = {"elements": st.n, "pairs": len(pairs)}
    out["collisions_s"], out["overlapping"] = _best(collisions, reps)
    if cm.n_joints and cm.law.uses_joints:
        out["joints"] = cm.n_joints
        out["joints_s"], _ = _best(joints, reps)
    return out


def report(kind: str, law: str | None, r: dict) -> str:
    n = r["elements"]
    line = (f"{kind} ({law or 'scene law'}): {r['pairs']} pairs, {r['overlapping']} overlapping;"
            f" collisions {r['collisions_s'] / n * 1e9:.1f} ns/element"
            f" ({r['collisions_s'] / max(r['pairs'], 1) * 1e9:.1f} ns/pair)")
    if "joints" in r:
        line += (f"; joints {r['joints_s'] / n * 1e9:.1f} ns/element"
                 f" ({r['joints_s'] / r['joints'] * 1e9:.1f} ns/joint)")
    return line


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.phase", description=__doc__.split("\n")[0])
    ap.add_argument("kind", choices=KINDS, help="benchmark scene (bench.scenes)")
    ap.add_argument("--law", choices=LAWS, default=None, help="contact law of a bonded pack")
    ap.add_argument("--elements", type=int, default=10000)
    ap.add_argument("--spinup", type=int, default=20, help="steps before timing")
    ap.add_argument("--reps", type=int, default=40, help="calls per phase (best kept)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--coherent", action="store_true",
                    help="the coherent clip (siku_core.geometry.coherent)")
    ap.add_argument("--processes", type=int, default=1,
                    help="fresh processes, each printing its own best")
    a = ap.parse_args(argv)
    if a.elements < 100 or a.reps < 1 or a.spinup < 0 or a.threads < 1 or a.processes < 1:
        print("bench.phase: --elements >= 100, --reps >= 1, --spinup >= 0, --threads >= 1,"
              " --processes >= 1", file=sys.stderr)
        return 2
    if a.processes > 1:
        args = [sys.executable, "-m", "bench.phase", a.kind, "--elements", str(a.elements),
                "--spinup", str(a.spinup), "--reps", str(a.reps), "--threads", str(a.threads)]
        if a.law:
            args += ["--law", a.law]
        if a.coherent:
            args.append("--coherent")
        for _ in range(a.processes):
            rc = subprocess.run(args).returncode
            if rc:
                return rc
        return 0
    numba.set_num_threads(min(a.threads, numba.config.NUMBA_NUM_THREADS))
    try:
        r = measure(a.kind, a.elements, a.law, a.spinup, a.reps, a.coherent)
    except ValueError as exc:
        print(exc, file=sys.stderr)
        return 2
    print(report(a.kind, a.law, r) + (" [coherent clip]" if a.coherent else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
