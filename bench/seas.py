"""Element-steps per second of the ``waves`` forcing in a 768-component JONSWAP sea (48
frequencies x 16 directions, deep water) on a 10 000-element pack: the forces of one step
(``add_forces``: the sea at every element, slope force and drag) for the direct sum
(``jonswap``, one step: it is slow), the recurrences (``fast_jonswap``) and the interpolated
sea (``jonswap`` with ``method = "lines"``, siku_forcing.waves.wave_lines), alternated round by
round so that each sees the same stretch of a shared machine; and the largest difference of
the interpolated sea from the direct sum over the elements, over its stated bound.

    python -m bench.seas                       # 4 rounds of 20 steps, 1 and 2 threads (~1 min)
    python -m bench.seas --rounds 6 --threads 2 --extent 1000

Prints the load average before and after (the machine may be shared), then per method and
thread count: element-steps/s of every round, best and median. On a machine shared with other
work, set ``OMP_WAIT_POLICY=PASSIVE``: numba's OpenMP threads otherwise spin after each parallel
region and two threads run slower than one.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np


def pack(n: int, extent: float, lat0: float = 75.0, lon0: float = -150.0):
    """``n`` element centres at random in a square of side ``extent`` [m] around ``(lat0,
    lon0)``: orientations, zero velocities, 1 m thick squares of the pack's mean area."""
    from types import SimpleNamespace

    from siku_core.geometry.quat import q_from_latlon

    rng = np.random.default_rng(2)
    R = 6_371_000.0
    dlat = np.degrees(extent / 2 / R)
    dlon = dlat / np.cos(np.radians(lat0))
    lat = np.radians(lat0 + rng.uniform(-dlat, dlat, n))
    lon = np.radians(lon0 + rng.uniform(-dlon, dlon, n))
    q = np.array([q_from_latlon(a, b) for a, b in zip(lat, lon)])
    area = np.full(n, extent * extent / n)
    st = SimpleNamespace(m=area * 917.0, area=area)
    return q, np.zeros((n, 3)), st, np.ones(n, bool), lat, lon


def fields():
    from siku_forcing.waves.spectral_fast import FastJonswap
    from siku_forcing.waves.wave_field import Jonswap

    p = {k: v.default for k, v in Jonswap.params.items()}
    p.update(seed=1, origin=[-150.0, 75.0])
    out = {"jonswap": Jonswap(dict(p)), "fast_jonswap": FastJonswap(
        {k: v for k, v in p.items() if k in FastJonswap.params}),
        "jonswap lines": Jonswap({**p, "method": "lines"})}
    for f in out.values():
        f._build()
    return out


def rate(field, q, V, st, free, steps: int, dt: float = 0.5, t0: float = 0.0) -> float:
    """Element-steps/s of ``steps`` force evaluations at times ``t0 + i dt``."""
    F = np.zeros((len(q), 3))
    start = time.perf_counter()
    for i in range(steps):
        field.add_forces(t0 + i * dt, q, V, st, free, 9.81, True, 5.0, F)
    return len(q) * steps / (time.perf_counter() - start)


def error(fs, lat, lon, t: float = 12.5) -> dict[str, float]:
    """Largest difference of the interpolated sea from the direct sum over the elements, over
    its bound (``siku_forcing.waves.wave_lines``)."""
    a, b = fs["jonswap"], fs["jonswap lines"]
    A, B = a.evaluate(t, lat, lon), b.evaluate(t, lat, lon)
    m = np.cos(a.lat0) / np.cos(lat)
    bd = b._lines().bounds
    return {"eta": np.abs(A["eta"] - B["eta"]).max() / bd["eta"],
            "slope": max(np.abs((A["eta_e"] - B["eta_e"]) / m).max(),
                         np.abs(A["eta_n"] - B["eta_n"]).max()) / bd["slope"],
            "u": max(np.abs((A["u"] - B["u"]) / m).max(), np.abs(A["v"] - B["v"]).max())
            / bd["u"]}


def main(argv=None) -> None:
    import numba

    ap = argparse.ArgumentParser(prog="python -m bench.seas")
    ap.add_argument("--n", type=int, default=10_000, help="elements")
    ap.add_argument("--extent", type=float, default=1100.0, help="side of the pack [m]")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--steps", type=int, default=20, help="steps per round and case")
    ap.add_argument("--threads", default="1,2")
    a = ap.parse_args(argv)
    threads = [int(v) for v in a.threads.split(",")]
    q, V, st, free, lat, lon = pack(a.n, a.extent)
    fs = fields()
    print(f"load average before: {os.getloadavg()}")
    for f in fs.values():  # compile
        rate(f, q[:100], V[:100], st, free[:100], 1)
    numba.set_num_threads(max(threads))
    ref = rate(fs["jonswap"], q, V, st, free, 1)
    print(f"jonswap (direct sum, one step, {max(threads)} threads): {ref:12.0f} element-steps/s")
    runs = {(name, k): [] for name in ("fast_jonswap", "jonswap lines") for k in threads}
    for r in range(a.rounds):
        for (name, k), got in runs.items():
            numba.set_num_threads(k)
            got.append(rate(fs[name], q, V, st, free, a.steps, t0=1000.0 * r))
    print(f"load average after: {os.getloadavg()}")
    print(f"{a.n} elements over {a.extent:g} m, 768 components, {a.rounds} rounds of "
          f"{a.steps} steps (element-steps/s)")
    for (name, k), got in runs.items():
        print(f"  {name:14s} {k} thread(s): best {max(got):10.0f} median "
              f"{float(np.median(got)):10.0f}  rounds " + ", ".join(f"{v:.0f}" for v in got))
    lines = fs["jonswap lines"]._lines()
    print(f"lines: node spacing {lines.h:.4f} m; largest error over its bound at the elements:",
          ", ".join(f"{k} {v:.3g}" for k, v in error(fs, lat, lon).items()))


if __name__ == "__main__":
    main()
