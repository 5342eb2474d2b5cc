"""Slabs of square floes in a wave flume: energy reflection and transmission coefficients from
capytaine's multi-body diffraction, printed beside Table 1 of Orzech et al. (the coupled
NHWAVE–LIGGGHTS wave–ice model).

Their flume is 4 km × 2 km; the full slab, 200 m along the waves × 1.6 km across, holds square
floes of the sizes of Montiel et al. (2016), and the three sparser slabs keep the floes of the 4
largest types (64, 73, 82 and 91 m: 7 floes), of the 2 largest (82 and 91 m: 3 floes) and of
the largest (91 m: 2 floes), at the same places. Waves of 6 s and 9 s. The paper gives neither
the floes' places, their thickness nor the water depth; here the 7 floes are 2 × 91, 1 × 82,
2 × 73 and 2 × 64 m (3 and 2 floes in the sparser slabs, as in the paper), placed at random
without overlap (a fixed random seed) in the slab, 1 m thick (as the paper's single floes),
rigid, free in their six modes, in deep water, ice 920 and water 1025 kg/m³ (as the paper).

``siku_plugins.floating.scatter`` solves the diffraction and the 6 N radiation problems of all
floes together (every interaction included), moves the floes by their equations of motion,
and takes the far field of the diffracted and radiated waves: the energy reflected is the
power scattered backwards, the energy transmitted is the incident power through the flume's
width W = 1.6 km less what the floes remove from the forward wave (optical theorem) plus what
they scatter forwards; their sum is 1 for these lossless floes to the accuracy of the boundary
elements (printed). The walls' images of the floes are neglected.

The paper's K_r and K_t are energies measured in front of and behind the slab in its coupled
model (with its numerical dissipation: K_r + K_t = 0.80–0.98), K_r,mon those of Montiel et
al. for circular elastic floes; reported beside, not asserted: the models differ.

Run ``python examples/floating/slabs.py [--size 4]`` (``--size``: the panels [m]; about a
minute on two cores at 4 m; the results are cached like the floating process's coefficients:
``--cache FOLDER``, by default the user cache).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

#: slab (along the waves × across) and flume width [m], floe thickness [m]
SLAB_X, SLAB_Y, WIDTH, THICK = 200.0, 1600.0, 1600.0, 1.0
#: side lengths of the full slab's 7 floes [m] and the floe types of each configuration
SIDES = [91.0, 91.0, 82.0, 73.0, 73.0, 64.0, 64.0]
TYPES = {4: 64.0, 2: 82.0, 1: 91.0}
SEED = 2018
#: Table 1 of Orzech et al.: (period, types) -> (floes, K_r, K_r,mon, K_t)
PAPER = {(6, 4): (7, 0.32, 0.42, 0.48), (6, 2): (3, 0.29, 0.28, 0.52),
         (6, 1): (2, 0.21, 0.14, 0.59), (9, 4): (7, 0.18, 0.10, 0.75),
         (9, 2): (3, 0.13, 0.05, 0.848), (9, 1): (2, 0.08, 0.04, 0.855)}


def full_slab(seed: int = SEED) -> list[tuple[float, float, float, float]]:
    """``[(lx, ly, x, y), ...]``: the 7 square floes, largest first, at random places without
    overlap (their sides apart by at least 5 m) in the slab ``0 < x < 200``, ``0 < y < 1600``."""
    rng = np.random.default_rng(seed)
    out: list[tuple[float, float, float, float]] = []
    for a in SIDES:
        while True:
            x = rng.uniform(a / 2, SLAB_X - a / 2)
            y = rng.uniform(a / 2, SLAB_Y - a / 2)
            if all(abs(x - p) > (a + q) / 2 + 5 or abs(y - r) > (a + q) / 2 + 5
                   for q, _, p, r in out):
                out.append((a, a, x, y))
                break
    return out


def slab(types: int, seed: int = SEED):
    """The floes of the configuration keeping the ``types`` largest floe types."""
    return [f for f in full_slab(seed) if f[0] >= TYPES[types]]


def table(size: float, cache: str = ""):
    """``[(period, types, floes, K_r, K_t), ...]`` of the six cases."""
    from siku_plugins.floating import scatter

    rows = []
    for period in (6, 9):
        for types in (4, 2, 1):
            floes = slab(types)
            kr, kt, _ = scatter.coefficients(floes, THICK, period, WIDTH, size, cache)
            rows.append((period, types, len(floes), kr, kt))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=4.0, help="panel size [m] (default 4)")
    ap.add_argument("--cache", default="", help="cache folder (default: the user cache)")
    a = ap.parse_args(argv)
    from siku_core.errors import SikuError

    try:
        rows = table(a.size, a.cache)
    except SikuError as exc:      # capytaine missing, a cache folder that is not there
        print(f"slabs.py: {exc}", file=sys.stderr)
        return 2
    print(f"slabs of square floes, {THICK:g} m thick, in a flume {WIDTH:g} m wide; "
          f"panels {a.size:g} m")
    print("                      capytaine (rigid, lossless)   Orzech et al. Table 1")
    print(" T [s] types floes     K_r    K_t  K_r+K_t        K_r   K_r,mon   K_t")
    for period, types, n, kr, kt in rows:
        nf, pr, pm, pt = PAPER[(period, types)]
        assert nf == n
        print(f"{period:5d} {types:5d} {n:5d}   {kr:7.3f} {kt:6.3f} {kr + kt:7.3f}"
              f"      {pr:7.2f} {pm:7.2f} {pt:7.3f}")
    print("floes (side, x, y) [m]:", ", ".join(f"({f[0]:g}, {f[2]:.0f}, {f[3]:.0f})"
                                               for f in full_slab()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
