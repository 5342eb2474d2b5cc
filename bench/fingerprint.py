"""Fingerprints of the states a set of scenes reach: a check that a change keeps results bit
for bit.

Runs each case below to its end (no output file) and prints one line per case: the SHA-256 of
its final element state (``q``, ``V``, ``w``) and, where the scene has joints, of the joints'
state (intact flags, history, break modes and times). Two checkouts agree bit for bit on a case
when the lines are equal::

    python -m bench.fingerprint > before.txt     # on the old code
    python -m bench.fingerprint > after.txt      # on the new code
    diff before.txt after.txt

Cases (about two minutes on two cores, kernels compiled): the bonded 3 000-element pack with
``distributed_spring`` and ``mohr_coulomb`` (100 steps), the collision scene (100 steps), the
shipped default scene for 1 h of model time, ``examples/waves_on_ice.toml`` for 60 s, and the
two-way coupled wave flume of ``examples/coupling`` driven through the BMI for 5 s.
``--only NAME`` runs one case.
"""
from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def fingerprint(sim) -> str:
    """``elements=<hash> joints=<hash>`` of a simulation's current state."""
    st = sim.state
    text = f"elements={_digest(st.q, st.V, st.w)}"
    hist = sim.history_arrays()
    if hist:
        parts = []
        for key in sorted(hist):
            for name in sorted(hist[key]):
                parts.append(np.asarray(hist[key][name]))
        text += f" history={_digest(*parts)}"
    return text


def _scene_case(kind: str, law: str | None):
    def run():
        from bench.scenes import scene
        from siku_core.run.simulation import Simulation

        sim = Simulation(scene(kind, 3000, law, steps=100), out=False, progress=False)
        sim.run()
        return sim
    return run


def _file_case(path: Path, **overrides: str):
    def run():
        from siku_core.scene.scene_file import load_scene
        from siku_core.run.simulation import Simulation

        sim = Simulation(load_scene(path, overrides), out=False, progress=False)
        sim.run()
        return sim
    return run


def _coupled():
    """The flume of ``examples/coupling/two_way_waves.py`` driven through the BMI for 5 s."""
    sys.path.insert(0, str(ROOT / "examples" / "coupling"))
    from two_way_waves import FlumeWaves, R

    from siku_io.coupling.bmi import SikuBmi

    ice = SikuBmi()
    ice.initialize(str(ROOT / "examples" / "coupling" / "waves_ice.toml"))
    ny, nx = ice.get_grid_shape(0, np.zeros(2, dtype=int))
    lon = ice.get_grid_x(0, np.zeros(nx))
    waves = FlumeWaves(R * np.radians(lon - lon[0]))
    t = ice.get_current_time()
    while t < 5.0 - 1e-9:
        conc = ice.get_value("sea_ice__area_fraction", np.zeros(ny * nx)).reshape(ny, nx)
        waves.set_ice(conc)
        eta, u = waves.fields(t + 0.25, ny)
        ice.set_value("sea_water_surface__elevation", eta.ravel())
        ice.set_value("sea_water_flowing__x_component_of_velocity", u.ravel())
        ice.update_until(t + 0.5)
        t = ice.get_current_time()
    return ice.sim


def _default_scene() -> Path:
    from siku_core.run.cli import default_scene_path

    return default_scene_path()


CASES = {
    "bonded_spring": _scene_case("bonded", "distributed_spring"),
    "bonded_mohr_coulomb": _scene_case("bonded", "mohr_coulomb"),
    "collision": _scene_case("collision", None),
    "default_1h": lambda: _file_case(_default_scene(), **{"time.duration": "1h"})(),
    "waves_on_ice": _file_case(ROOT / "examples" / "waves_on_ice.toml",
                               **{"time.duration": "60s"}),
    "coupled_bmi": _coupled,
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.fingerprint", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", action="append", choices=sorted(CASES),
                    help="run only this case (repeatable)")
    args = ap.parse_args(argv)
    for name in args.only or CASES:
        sim = CASES[name]()
        print(f"{name:22s} {fingerprint(sim)}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
