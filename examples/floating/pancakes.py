"""The attenuation a field of pancakes implies by its radiation, against the frequency.

A flume (``spectral`` wave field, 10 m cells, 0–200 m east of the origin, one cell wide) holds a
field of 2 m × 2 m pancakes, 0.3 m thick, free, covering two cells (C = 1) from x = 100 m,
under a monochromatic sea of 5 cm amplitude that the field does not damp (``constant`` law,
``alpha = 0``): the pancakes heave, roll and pitch with the ``floating`` process, and the power
their radiation damping takes, over the energy flux of the sea, is the attenuation rate their
response implies (``Spectral.attenuations``, the mean over the last wave period after a ramp of
two periods). Run from the root of a clone of siku:

    python examples/floating/pancakes.py [--coefficients auto small_body capytaine scene]

prints, per frequency, the rate ``k_i`` [1/m] for each choice of coefficients beside the rates
of Rogers et al. (2016) and of the fit of Meylan et al. (2014)
(``docs/explanation/attenuation.md``).
"""
from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

#: the pancakes: side [m], thickness [m], columns and rows of the field
SIDE, THICKNESS, NX, NY = 2.0, 0.3, 10, 5
#: the sea's amplitude [m] and the flume's cells [m]
AMPLITUDE, CELL = 0.05, 10.0
R = 6_371_000.0
#: Rogers et al. (2016): k_i from about 1e-6 at 0.05 Hz to 1e-5 at 0.15 Hz (their Fig. 9,
#: pancake and frazil ice of the autumn Beaufort Sea), the power law through both
ROGERS = ((0.05, 1e-6), (0.15, 1e-5))


def rogers(f: float) -> float:
    (f0, k0), (f1, k1) = ROGERS
    n = math.log(k1 / k0) / math.log(f1 / f0)
    return k0 * (f / f0) ** n


def meylan(f: float) -> float:
    """``k_i`` [1/m] of the ``meylan2014`` law (amplitude rate, half the energy rate)."""
    from siku_forcing.waves.attenuation import Meylan2014

    return float(Meylan2014({}).rate(f, 0.3, math.inf))


def scene(frequency: float, coefficients: str) -> str:
    from siku_core.testing import scene_text
    from siku_core.testing.contact_cases import square_pack

    period = 1.0 / frequency
    pack = square_pack(math.degrees(100.0 / R), -math.degrees(NY * SIDE / 2 / R), NX, NY,
                       size=SIDE)
    field = {"type": "spectral", "params": {
        "spectrum": "monochromatic", "amplitude": AMPLITUDE, "period": period,
        "x": [0.0, 200.0], "y": [-NY * SIDE / 2, NY * SIDE / 2], "resolution": CELL,
        "origin": [0.0, 0.0], "attenuation": "constant", "attenuation_params": {"alpha": 0.0}}}
    dt = period / 40
    txt = scene_text([], packs=[pack], dt=dt, duration=4 * period, thickness=THICKNESS,
                     forcing=[{"source": "waves", "params": {"drag": False, "slope": False},
                               "field": field}])
    params = f'ramp = {2 * period!r}'
    if coefficients != "auto":
        params += f', coefficients = "{coefficients}"'
        if coefficients == "capytaine":
            params += ', frequency = "wave"'
    return txt + f'\n[[process]]\nname = "floating"\nparams = {{ {params} }}\n'


def attenuation(frequency: float, coefficients: str = "auto") -> tuple[float, str]:
    """``(k_i [1/m], the coefficients used)``: the rate the pancakes' radiation implies, mean
    over the cells they cover and over the last wave period of four."""
    import numpy as np

    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "pancakes.toml"
        path.write_text(scene(frequency, coefficients))
        sim = Simulation(load_scene(path), out=False, progress=False)
    n_period = 40
    sim.run(steps=sim.n_steps - n_period)
    f = sim.forcing[0].field
    k = 0.0
    for _ in range(n_period):
        sim.step()
        k = k + f.attenuations(f.response_power())[1] / n_period
    proc = next(p for p in sim.processes if p.name == "floating")
    return float(np.mean(k[f.C > 0.5])), proc.coefficients_used


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--coefficients", nargs="+", default=["auto", "small_body", "scene"])
    ap.add_argument("--frequencies", nargs="+", type=float, default=[0.05, 0.1, 0.15, 0.2])
    a = ap.parse_args(argv)
    print("f [Hz]  " + "  ".join(f"{c:>22}" for c in a.coefficients)
          + "  Rogers2016  Meylan2014")
    for fr in a.frequencies:
        cells = []
        for c in a.coefficients:
            k, used = attenuation(fr, c)
            cells.append(f"{k:10.3g} ({used:>10})")
        print(f"{fr:6.3f}  " + "  ".join(f"{x:>22}" for x in cells)
              + f"  {rogers(fr):10.3g}  {meylan(fr):10.3g}", flush=True)


if __name__ == "__main__":
    main()
