"""The verification cases' numbers under ``contact.touching = "contact"`` and ``"ignore"``.

``python -m bench.touching_verification`` (from the repository root of a clone: it reuses the
scenes of ``tests/contacts/``) prints, for both rules, what each case measures:

* **V3** binary collision (``tests/contacts/test_v3_collision.py``): the restitution of the
  face-on impact at damping ratios 0.1 and 0.3 against ``exp(-z pi / sqrt(1 - z²))``, the
  elastic (``z = 0``) energy error, the contact's duration in steps, and the angular momentum
  drift;
* **V4** joints (``tests/contacts/test_v4_joints.py``): the step at which the pulled pair's joint
  breaks and the strain that broke it, at both of the test's steps;
* **V6** (``bench.accuracy.pull`` through ``bench.touching``): printed by ``python -m
  bench.touching``.

V1 and V2 (free drift, great circles) have no ``[contact]`` table: the rule cannot change them.
V5 (Mohr–Coulomb) loads joints of pairs pulled apart or evaluated one joint at a time: no
touching overlap takes part.
"""
from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

from siku_core.run.simulation import Simulation

TESTS = Path(__file__).resolve().parent.parent / "tests" / "contacts"


def _module(name: str):
    spec = importlib.util.spec_from_file_location(name, TESTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def _with_touching(scene, touching: str):
    scene.cfg.contact.touching = touching
    return scene


def v3(touching: str) -> list[str]:
    m = _module("test_v3_collision")
    rows = []
    for z in (0.0, 0.1, 0.3):
        sim = Simulation(_with_touching(m.face_on_scene(z, m.DT), touching), out=False,
                         progress=False)
        res = m.collide(sim)
        e = -res["vn_out"] / res["vn_in"]
        if z == 0.0:
            rows.append(f"| V3 elastic: `|KE_out/KE_in - 1|` | {touching} | "
                        f"{abs(res['ke_out'] / res['ke_in'] - 1):.4e} |")
            rows.append(f"| V3 elastic: contact steps | {touching} | {res['contact_steps']} |")
        else:
            exact = math.exp(-z * math.pi / math.sqrt(1 - z * z))
            rows.append(f"| V3 restitution z = {z}: `e / e_exact - 1` | {touching} | "
                        f"{e / exact - 1:+.4e} |")
        rows.append(f"| V3 z = {z}: angular momentum drift | {touching} | {res['dL']:.1e} |")
    return rows


def v4(touching: str) -> list[str]:
    m = _module("test_v4_joints")
    rows = []
    for dt in m.DTS:
        sim = Simulation(_with_touching(m.break_scene(dt), touching), out=False, progress=False)
        cm = sim.contacts
        for n in range(10_000):
            sim.step()
            if not cm.intact[0]:
                break
        rows.append(f"| V4 break, dt = {dt} s: step, strain / threshold | {touching} | {n}, "
                    f"{cm.hist[0, 0] / m.EPS_T:.6f} |")
    return rows


def main() -> None:
    print("| case | touching | value |\n|---|---|---|")
    for case in (v3, v4):
        for touching in ("contact", "ignore"):
            for row in case(touching):
                print(row, flush=True)


if __name__ == "__main__":
    main()
