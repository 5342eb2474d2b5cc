"""Cost of the spectral wave field (siku_forcing.waves.spectral): the transport and absorption of
the
spectrum per cell, component and sub-step, and the local sea at the elements per element and
component; and the 768-component JONSWAP sea at 10 000 points summed directly (``jonswap``)
and by recurrences (``fast_jonswap``, siku_forcing.waves.spectral_fast).

    python -m bench.spectral            # about 20 s

Prints one line per case: grid cells, components, seconds per sub-step, nanoseconds per cell
and component; element evaluations per second of the local sea (slope, orbital velocity).
"""
from __future__ import annotations

import math
import time

import numpy as np

from siku_forcing.waves.spectral_transport import absorb, transport


def transport_cost(nx: int, ny: int, nc: int, steps: int = 50) -> float:
    """Seconds per sub-step (transport + absorption) of ``nc`` components on ``nx × ny``."""
    rng = np.random.default_rng(0)
    E = rng.random((nc, ny, nx))
    th = rng.uniform(0, 2 * np.pi, nc)
    cg = rng.uniform(3, 12, nc)
    cx, cy = cg * np.sin(th), cg * np.cos(th)
    ki = np.full((nc, ny, nx), 1e-4)
    C = rng.random((ny, nx))
    dt = 0.9 / np.max(np.abs(cx) / 50 + np.abs(cy) / 50)
    transport(E, cx, cy, 50.0, 50.0, dt, False, E[:, 0, 0])
    t0 = time.perf_counter()
    for _ in range(steps):
        E, _ = transport(E, cx, cy, 50.0, 50.0, dt, False, E[:, 0, 0])
        E, _ = absorb(E, cg, ki, C, dt)
    return (time.perf_counter() - t0) / steps


def local_sea_cost(n_elements: int, nc: int, repeat: int = 5) -> float:
    """Element evaluations per second of the local sea (``Spectral._sums``) for ``nc``
    components on a 40 × 40 grid."""
    from siku_forcing.waves.spectral import _cell_sums
    from siku_forcing.waves.wave_field import PlaneWaves

    rng = np.random.default_rng(1)
    ncell = 1600
    amp = rng.random((ncell, nc))
    uo = rng.random((ncell, nc))
    kx, ky, om, ph = (rng.random(nc) + 0.01 for _ in range(4))
    lat = rng.uniform(-1e-4, 1e-4, n_elements)
    lon = rng.uniform(-1e-4, 1e-4, n_elements)
    cell = rng.integers(0, ncell, n_elements)
    z = np.zeros(n_elements)
    w = PlaneWaves(lat0=0.0, lon0=0.0, R=6.371e6, depth=math.inf, amp=amp[0], kx=kx, ky=ky,
                   omega=om, phase=ph, k=np.hypot(kx, ky), uo=uo[0])
    _cell_sums(0.0, lat, lon, cell, w, amp, uo, z, z, False)
    t0 = time.perf_counter()
    for r in range(repeat):
        _cell_sums(float(r), lat, lon, cell, w, amp, uo, z, z, False)
    return n_elements * repeat / (time.perf_counter() - t0)


def jonswap_rates(n: int = 10_000, repeat: int = 5) -> dict[str, float]:
    """Element evaluations per second of ``jonswap`` and ``fast_jonswap`` (768 components:
    48 frequencies x 16 directions) at ``n`` points within 1 km of the origin."""
    from siku_forcing.waves.spectral_fast import FastJonswap
    from siku_forcing.waves.wave_field import Jonswap

    p = {k: v.default for k, v in Jonswap.params.items()}
    p.update(seed=1, origin=[-150.0, 75.0])
    rng = np.random.default_rng(2)
    lat = np.radians(75 + rng.uniform(-0.005, 0.005, n))
    lon = np.radians(-150 + rng.uniform(-0.02, 0.02, n))
    out = {}
    for cls in (Jonswap, FastJonswap):
        w = cls(dict(p))
        w._build()
        w.evaluate(0.0, lat, lon)
        t0 = time.perf_counter()
        for r in range(repeat):
            w.evaluate(float(r), lat, lon)
        out[cls.name] = n * repeat / (time.perf_counter() - t0)
    return out


def main() -> None:
    print("transport + absorption (numpy, one thread)")
    for nx, ny, nc in ((100, 1, 1), (200, 200, 1), (100, 100, 48), (100, 100, 768)):
        s = transport_cost(nx, ny, nc, steps=50 if nc < 100 else 5)
        print(f"  {nx:4d} x {ny:4d} cells, {nc:4d} components: {s * 1e3:9.3f} ms per sub-step, "
              f"{s / (nx * ny * nc) * 1e9:6.2f} ns per cell and component")
    print("local sea at the elements (numba, one thread)")
    for n, nc in ((10_000, 1), (10_000, 48), (10_000, 768)):
        rate = local_sea_cost(n, nc)
        print(f"  {n} elements, {nc:4d} components: {rate:12.0f} element evaluations/s")
    print("JONSWAP sea, 768 components, 10 000 points (numba threads: NUMBA_NUM_THREADS)")
    for name, rate in jonswap_rates().items():
        print(f"  {name:13s} {rate:12.0f} element evaluations/s")


if __name__ == "__main__":
    main()
